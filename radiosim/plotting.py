"""
Figures (matplotlib), generic: a figure factory, Markdown tables, a study's results loaded back,
a reading-against-parameter plot, and PNG files written atomically.

The library draws on a figure it creates and returns; it never shows windows. Axes carry units.
The paper's figures are in :mod:`radiosim.paper.figures`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError, RadiosimIOError

__all__ = ["figure", "markdown_table", "load_results", "select", "plot_versus", "save_figure"]


def figure(width, height):
    """A figure of ``width`` × ``height`` inches, independent of pyplot and of the active
    backend (it saves with Agg and displays inline in notebooks)."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def markdown_table(rows: list[dict], formats: dict | None = None) -> str:
    """
    A Markdown table of ``rows`` (dicts with the same keys), numbers formatted by ``formats``
    (key → format spec); NaN and empty values show as a dash.

    Examples
    --------
    >>> print(markdown_table([{"t [µs]": 1.0, "T [°C]": 739.04}], {"T [°C]": ".1f"}))
    | t [µs] | T [°C] |
    | --- | --- |
    | 1.0 | 739.0 |
    """
    if not rows:
        return ""
    formats = formats or {}
    keys = list(rows[0])

    def cell(key, value):
        if value is None or value == "" or (isinstance(value, float) and math.isnan(value)):
            return "—"
        if isinstance(value, (int, float, np.floating, np.integer)) and key in formats:
            return format(value, formats[key])
        return str(value)

    lines = ["| " + " | ".join(keys) + " |", "| " + " | ".join("---" for _ in keys) + " |"]
    lines += ["| " + " | ".join(cell(k, r.get(k)) for k in keys) + " |" for r in rows]
    return "\n".join(lines)



# -- a study's results ------------------------------------------------------------------

_NUMERIC = {"integration_time_us", "n_frames", "pixel_pitch_um", "pixel_samples",
            "sensor_area_um2", "t_start_us", "peak_scene_C", "peak_C", "peak_bias_K",
            "peak_uncertainty_K", "column_I_scene_C", "column_I_C", "column_I_bias_K",
            "column_I_uncertainty_K", "saturated_fraction", "under_range_fraction", "over_range_fraction", "time_us",
            "mean_C"}


def _rows(path: Path) -> list[dict]:
    import csv

    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        for key in _NUMERIC & set(row):
            row[key] = float(row[key]) if row[key] not in ("", None) else math.nan
    return rows


def load_results(folder) -> tuple[list[dict], list[dict]]:
    """The rows of a study's ``results.csv`` and ``pixel_history.csv`` (if any), numbers as
    floats."""
    folder = Path(folder)
    table = folder / "results.csv"
    if not table.is_file():
        raise RadiosimError(f"{folder} holds no results.csv (run a study into it first)")
    history = folder / "pixel_history.csv"
    return _rows(table), (_rows(history) if history.is_file() else [])


def select(rows, sweep, **match):
    """The rows of ``sweep`` whose keys equal ``match``."""
    return [r for r in rows if r["sweep"] == sweep and all(r[k] == v for k, v in match.items())]


def _label(camera: str, response: str) -> str:
    return camera if camera == response else f"{camera} ({response} response)"


def plot_versus(fig, rows, x_key, y_key, err_key, scene_key, xlabel, title, ylabel=None):
    """
    Reading ±1σ against a sweep parameter, one line per camera (response named where it differs
    from the camera's name), the scene's value as a dashed line; returns the axes.
    """
    ax = fig.add_subplot()
    groups = sorted({(r["camera"], r["response"]) for r in rows})
    for camera, response in groups:
        mine = sorted((r for r in rows if (r["camera"], r["response"]) == (camera, response)),
                      key=lambda r: r[x_key])
        x = [r[x_key] for r in mine]
        ax.errorbar(x, [r[y_key] for r in mine], yerr=[r[err_key] for r in mine], marker="o",
                    capsize=3, label=_label(camera, response))
    scene = [r[scene_key] for r in rows if np.isfinite(r[scene_key])]
    if scene:
        ax.axhline(max(scene), color="black", ls="--", lw=1, label="scene peak")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel or "temperature [°C]")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    return ax


def save_figure(fig, path, dpi: int = 110) -> Path:
    """Write ``fig`` as a PNG at ``path`` atomically (a temporary file renamed into place)."""
    from radiosim.files import atomic_write

    path = Path(path)
    try:
        with atomic_write(path, "wb") as stream:
            fig.savefig(stream, dpi=dpi, format="png")
    except OSError as exc:
        raise RadiosimIOError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path

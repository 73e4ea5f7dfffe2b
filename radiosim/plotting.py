"""
Figures (matplotlib), generic: a figure factory, Markdown tables, a study's results loaded back,
a reading-against-parameter plot, and PNG files written atomically.

The library draws on a figure it creates and returns; it never shows windows. Axes carry units.
The paper's figures are in :mod:`radiosim.paper.figures`.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError, RadiosimIOError

__all__ = ["DPI", "figure", "markdown_table", "load_results", "select", "plot_versus", "save_figure"]


#: Resolution of the PNG files [dots per inch]. Figures are created at it, so the layout computed
#: once is the one drawn.
DPI = 110


def figure(width, height, dpi: float = DPI):
    """
    A figure of ``width`` × ``height`` inches at ``dpi``, with constrained layout, drawn by Agg.

    It does not import pyplot and does not depend on the active backend: the canvas is Agg's
    (which also displays inline in notebooks), created with the figure.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


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


@contextmanager
def _laid_out(fig, dpi):
    """
    ``fig`` at ``dpi`` on an Agg canvas, its layout engine run once and then held off, so that a
    ``savefig`` inside draws it once. (``savefig`` with a layout engine draws the figure twice:
    a draw with rendering off, to lay it out, then the real one.) The figure's dpi, canvas and
    layout engine are restored on exit.
    """
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas, engine, old_dpi = fig.canvas, fig.get_layout_engine(), fig.dpi
    if not isinstance(canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    if dpi != old_dpi:
        fig.set_dpi(dpi)
    try:
        if engine is not None:
            engine.execute(fig)  # with the canvas's renderer, the one the draw reuses
            with matplotlib.rc_context({"figure.autolayout": False,
                                        "figure.constrained_layout.use": False}):
                fig.set_layout_engine(None)
        yield fig
    finally:
        if engine is not None:
            fig.set_layout_engine(engine)
        if dpi != old_dpi:
            fig.set_dpi(old_dpi)
        if fig.canvas is not canvas:
            fig.set_canvas(canvas)


def save_figure(fig, path, dpi: float = DPI) -> Path:
    """
    Write ``fig`` as a PNG at ``path`` atomically (a temporary file renamed into place).

    The figure is laid out once and drawn once, at ``dpi`` [dots per inch]; the PNG is
    compressed lightly (zlib level 1: the encoding costs a fraction of the default's, the file
    is somewhat larger).
    """
    from radiosim.files import atomic_write

    path = Path(path)
    try:
        with atomic_write(path, "wb") as stream, _laid_out(fig, dpi):
            fig.savefig(stream, dpi=dpi, format="png", pil_kwargs={"compress_level": 1})
    except OSError as exc:
        raise RadiosimIOError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path

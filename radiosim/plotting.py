"""
Figures (matplotlib): scene previews with the paper's reference lines.

The library draws on a figure it creates and returns; it never shows windows. Axes carry units.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError

__all__ = [
    "figure",
    "markdown_table",
    "preview_scene",
    "load_results",
    "plot_peak",
    "plot_column_i",
    "plot_column_profiles",
    "plot_long_integration",
    "plot_maps",
    "make_figures",
]

_C = 273.15


def _tool_outline(p, width, height):
    """Polygon (x, y) [µm] of the tool: rounded tip, rake face up, clearance face right."""
    a, g = p.rake_angle, p.clearance_angle
    tip = np.array([p.tool_tip_x, p.tool_tip_y])
    t_r = np.array([math.sin(a), math.cos(a)])  # up the rake face
    t_c = np.array([math.cos(g), math.sin(g)])  # along the clearance face
    r = p.edge_radius
    centre = tip + r * t_r + r * t_c
    arc = [centre + r * (math.cos(v) * -t_c + math.sin(v) * -t_r)
           for v in np.linspace(0, math.pi / 2, 12)]
    far = 4 * max(width, height)
    points = [tip + far * t_r, *arc, tip + far * t_c, tip + far * (t_r + t_c)]
    return np.array(points) * 1e6


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


def preview_scene(scene, t=None, path=None, columns=True, pixel_pitch=6e-6):
    """
    Plot a frame of a scene in °C, like the paper's Figure 4.

    For the segmented-chip scene the tool outline, the shear-band line L0, Columns I–III and a
    cross-hair on the peak temperature are drawn.

    Parameters
    ----------
    scene
        A scene; :class:`~radiosim.scenes.SegmentedChip` gets the reference lines.
    t
        Time [s]; default: ``scene.event_time`` (or 0).
    path
        Write a PNG there if given.
    columns
        Draw Columns I–III (as the pixel columns of ``pixel_pitch`` [m] that contain them).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if t is None:
        t = scene.event_time if scene.event_time is not None else 0.0
    from radiosim.scenes import SegmentedChip

    chip = isinstance(scene, SegmentedChip)
    # The chip is defined at any time; other scenes show the frame that holds t.
    frame = scene.temperature(t) if chip else scene.frame(int(math.floor(t / scene.dt)))
    height, width = scene.shape[0] * scene.dx, scene.shape[1] * scene.dx
    fig = figure(8.0, 8.0 * height / width + 0.6)
    ax = fig.add_subplot()
    image = ax.imshow(frame - _C, extent=(0, width * 1e6, 0, height * 1e6), cmap="inferno",
                      origin="upper", interpolation="nearest")
    fig.colorbar(image, ax=ax, label="temperature [°C]", shrink=0.85)
    ax.set_xlabel("x [µm]")
    ax.set_ylabel("y [µm]")
    ax.set_title(f"t = {t * 1e6:.2f} µs, peak {frame.max() - _C:.0f} °C")
    if chip:
        p = scene.params
        outline = _tool_outline(p, width, height)
        ax.fill(outline[:, 0], outline[:, 1], facecolor="none", edgecolor="white", lw=1.2)
        (x0, y0), (x1, y1) = scene.shear_plane()
        ax.plot([x0 * 1e6, x1 * 1e6], [y0 * 1e6, y1 * 1e6], "--", color="cyan", lw=1.0,
                label="shear plane L0")
        if columns:
            for name, style in zip(("I", "II", "III"), ("-", "--", ":")):
                x = scene.column_x(name)
                left = math.floor(x / pixel_pitch) * pixel_pitch * 1e6
                ax.axvline(left + pixel_pitch * 5e5, color="lime", ls=style, lw=1.0,
                           label=f"Column {name}")
        ax.legend(loc="lower left", fontsize=8, framealpha=0.6)
    i, j = np.unravel_index(np.argmax(frame), frame.shape)
    xp, yp = (j + 0.5) * scene.dx * 1e6, height * 1e6 - (i + 0.5) * scene.dx * 1e6
    ax.plot([xp], [yp], marker="+", color="white", markersize=18, mew=1.5)
    ax.set_xlim(0, width * 1e6)
    ax.set_ylim(0, height * 1e6)
    if path is not None:
        path = Path(path)
        if not path.parent.is_dir():
            raise RadiosimError(f"cannot write {path}: folder {path.parent} does not exist")
        fig.savefig(path, dpi=110)
    return fig


# -- study figures (the paper's Figures 5-11) ------------------------------------------------------

_NUMERIC = {"integration_time_us", "n_frames", "pixel_pitch_um", "pixel_samples",
            "sensor_area_um2", "t_start_us", "peak_scene_C", "peak_C", "peak_error_K",
            "peak_uncertainty_K", "column_I_scene_C", "column_I_C", "column_I_error_K",
            "column_I_uncertainty_K", "saturated_fraction", "under_range_fraction", "time_us",
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


def _select(rows, sweep, **match):
    return [r for r in rows if r["sweep"] == sweep and all(r[k] == v for k, v in match.items())]


def _versus(fig, rows, x_key, y_key, err_key, scene_key, xlabel, title):
    """Reading ±1σ against x, one line per camera/response, the scene value as a line."""
    ax = fig.add_subplot()
    groups = sorted({(r["camera"], r["response"]) for r in rows})
    for camera, response in groups:
        mine = sorted((r for r in rows if (r["camera"], r["response"]) == (camera, response)),
                      key=lambda r: r[x_key])
        x = [r[x_key] for r in mine]
        ax.errorbar(x, [r[y_key] for r in mine], yerr=[r[err_key] for r in mine], marker="o",
                    capsize=3, label=f"{camera} ({response})")
    scene = [r[scene_key] for r in rows if np.isfinite(r[scene_key])]
    if scene:
        ax.axhline(max(scene), color="black", ls="--", lw=1, label="scene (FEA) peak")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("temperature [°C]")
    ax.set_title(title)
    ax.legend(fontsize=8)
    return ax


def _two_panels(rows, sweeps, y_key, err_key, scene_key, subject):
    fig = figure(11, 4.2)
    left, right = fig.subfigures(1, 2)
    _versus(left, _select(rows, sweeps[0]), "integration_time_us", y_key, err_key, scene_key,
            "integration time [µs]", f"A) {subject} vs integration time (9 × 9 × n)")
    _versus(right, _select(rows, sweeps[1]), "sensor_area_um2", y_key, err_key, scene_key,
            "sensor element area [µm²]", f"B) {subject} vs sensor area (p × p × 1)")
    return fig


def plot_peak(rows, sweeps=("integration-time", "size-of-source")):
    """Figure 5: peak temperature against integration time and sensor area, ±1σ bars."""
    return _two_panels(rows, sweeps, "peak_C", "peak_uncertainty_K", "peak_scene_C", "peak")


def plot_column_i(rows, sweeps=("integration-time", "size-of-source")):
    """Figure 7: the shear band's peak in Column I against integration time and sensor area."""
    return _two_panels(rows, sweeps, "column_I_C", "column_I_uncertainty_K", "column_I_scene_C",
                       "Column I peak")


def plot_column_profiles(rows, folder, scene, sweep="integration-time", camera="linear"):
    """Figure 6: vertical temperature profiles along Columns I, II and III, one line per
    integration time, with the scene's event frame."""
    from radiosim.io.exr import read_exr

    mine = sorted(_select(rows, sweep, camera=camera), key=lambda r: r["integration_time_us"])
    fig = figure(12, 4.5)
    axes = fig.subplots(1, 3, sharey=True)
    event = scene.temperature(scene.event_time) if hasattr(scene, "temperature") else None
    for ax, name in zip(axes, ("I", "II", "III")):
        for r in mine:
            m = read_exr(Path(folder) / r["exr"])
            pitch = m.camera.fpa.pixel_pitch
            j = int(scene.column_x(name) // pitch)
            y = (scene.shape[0] * scene.dx - (np.arange(m.shape[0]) + 0.5) * pitch) * 1e6
            ax.plot(m.apparent_temperature[:, j] - _C, y, label=f"{r['integration_time_us']:g} µs")
        if event is not None:
            j = int(scene.column_x(name) / scene.dx)
            y = (scene.shape[0] - np.arange(scene.shape[0]) - 0.5) * scene.dx * 1e6
            ax.plot(event[:, j] - _C, y, color="black", lw=0.8, label="scene")
        ax.set_title(f"Column {name}")
        ax.set_xlabel("temperature [°C]")
    axes[0].set_ylabel("y [µm]")
    axes[0].legend(fontsize=7)
    return fig


def plot_long_integration(rows, history, sweep="long-integration"):
    """Figure 8: one pixel's instantaneous mean over time, and the reading and standard
    deviation at an integration time equal to the position on the axis."""
    fig = figure(8, 4.5)
    ax = fig.add_subplot()
    if history:
        ax.plot([h["time_us"] for h in history], [h["mean_C"] for h in history], lw=0.8,
                color="tab:blue", label="9 × 9 average, instantaneous")
    mine = sorted(_select(rows, sweep), key=lambda r: r["integration_time_us"])
    x = [r["integration_time_us"] for r in mine]
    ax.plot(x, [r["peak_C"] for r in mine], "o-", color="tab:red", label="measurement (mean)")
    ax.plot(x, [r["peak_uncertainty_K"] for r in mine], "s-", color="tab:green",
            label="standard deviation [K]")
    ax.set_xlabel("time, integration time [µs]")
    ax.set_ylabel("temperature [°C], standard deviation [K]")
    ax.legend(fontsize=8)
    return fig


def plot_maps(folder, rows, cases):
    """Figures 9-11: maps of apparent temperature, peak error and uncertainty, one column per
    case (rows of the results table)."""
    from radiosim.io.exr import read_exr

    fig = figure(3.2 * len(cases) + 1, 8.5)
    axes = fig.subplots(3, len(cases), squeeze=False)
    titles = ("apparent temperature [°C]", "peak error [K]", "uncertainty [K]")
    for c, row in enumerate(cases):
        m = read_exr(Path(folder) / row["exr"])
        pitch = m.camera.fpa.pixel_pitch * 1e6
        extent = (0, m.shape[1] * pitch, 0, m.shape[0] * pitch)
        fields = (m.apparent_temperature - _C, m.tensor_max - m.apparent_temperature,
                  m.tensor_std)
        for r, (values, title) in enumerate(zip(fields, titles)):
            image = axes[r, c].imshow(values, extent=extent, cmap="inferno", origin="upper")
            fig.colorbar(image, ax=axes[r, c], shrink=0.8, label=title)
            axes[r, c].set_xlabel("x [µm]")
            axes[r, c].set_ylabel("y [µm]")
        label = (f"{row['pixel_samples']:g}×{row['pixel_samples']:g}×{row['n_frames']:g} "
                 f"({row['integration_time_us']:g} µs)")
        axes[0, c].set_title(label, fontsize=9)
    return fig


def make_figures(folder, scene=None, camera="linear") -> list[Path]:
    """
    Write the paper's figures for a study's results folder into ``folder/figures``.

    Returns the PNG paths written: figures whose sweeps the study lacks, or whose EXR files
    were not written (profiles, maps), are skipped.
    """
    folder = Path(folder)
    rows, history = load_results(folder)
    out = folder / "figures"
    out.mkdir(exist_ok=True)
    written = []

    def save(fig, name):
        path = out / name
        fig.savefig(path, dpi=110)
        written.append(path)

    sweeps = {r["sweep"] for r in rows}
    if {"integration-time", "size-of-source"} <= sweeps:
        save(plot_peak(rows), "fig05_peak.png")
        if any(np.isfinite(r["column_I_C"]) for r in rows):
            save(plot_column_i(rows), "fig07_column_I.png")
    timed = [r for r in rows if r["sweep"] == "integration-time" and r["camera"] == camera]
    if scene is not None and hasattr(scene, "column_x") and timed and all(
            r.get("exr") for r in timed):
        save(plot_column_profiles(rows, folder, scene, camera=camera), "fig06_profiles.png")
    if "long-integration" in sweeps:
        save(plot_long_integration(rows, history), "fig08_long_integration.png")
    cases = [r for r in rows if r["sweep"] == "size-of-source" and r["camera"] == camera
             and r["pixel_samples"] == 9]
    cases += [r for r in rows if r["sweep"] == "integration-time" and r["camera"] == camera
              and r["integration_time_us"] in (10, 45, 90)]
    cases = [c for c in cases if c.get("exr")]
    if cases:
        save(plot_maps(folder, rows, cases), "fig09-11_maps.png")
    return written

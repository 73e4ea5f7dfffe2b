"""
The paper's figures (MSEC2009-84319, Figures 4–11), drawn from a study's results folder.

Every figure reads on its own: a title that says what is shown and by which camera, a legend
for every line and marker, one quantity per axis, and a note on what the error bars are.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from radiosim.paper.columns import COLUMN_NAMES, column_index, has_columns
from radiosim.plotting import (collector_held, few_ticks, figure, fixed_axes, load_results,
                               plot_versus, preload, save_figure, select, title_block, wrap_text)
from radiosim.units import CELSIUS_OFFSET

__all__ = ["preview_scene", "plot_peak", "plot_column_i", "plot_column_profiles",
           "plot_long_integration", "plot_maps", "make_figures", "draw_figures", "prepare",
           "ERROR_BARS"]

#: What the error bars of Figures 5 and 7 are.
ERROR_BARS = ("bars: ±1σ, the standard deviation of the scene temperature over the pixel's "
              "footprint × window (the paper's uncertainty)")


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
    image = ax.imshow(frame - CELSIUS_OFFSET, extent=(0, width * 1e6, 0, height * 1e6), cmap="inferno",
                      origin="upper", interpolation="nearest", rasterized=True)
    fig.colorbar(image, ax=ax, label="temperature [°C]", shrink=0.85)
    ax.set_xlabel("x [µm]")
    ax.set_ylabel("y [µm]")
    ax.set_title(f"t = {t * 1e6:.2f} µs, peak {frame.max() - CELSIUS_OFFSET:.0f} °C")
    if chip:
        p = scene.params
        outline = _tool_outline(p, width, height)
        ax.fill(outline[:, 0], outline[:, 1], facecolor="none", edgecolor="white", lw=1.2,
                label="tool")
        (x0, y0), (x1, y1) = scene.shear_plane()
        ax.plot([x0 * 1e6, x1 * 1e6], [y0 * 1e6, y1 * 1e6], "--", color="cyan", lw=1.0,
                label="shear plane L0")
        if columns:
            for name, style in zip(COLUMN_NAMES, ("-", "--", ":")):
                left = column_index(scene, pixel_pitch, name) * pixel_pitch * 1e6
                ax.axvline(left + pixel_pitch * 5e5, color="lime", ls=style, lw=1.0,
                           label=f"Column {name}")
    i, j = np.unravel_index(np.argmax(frame), frame.shape)
    xp, yp = (j + 0.5) * scene.dx * 1e6, height * 1e6 - (i + 0.5) * scene.dx * 1e6
    ax.plot([xp], [yp], marker="+", color="white", markersize=18, mew=1.5, ls="none",
            label=f"peak, {frame.max() - CELSIUS_OFFSET:.0f} °C")
    ax.legend(loc="lower left", fontsize=8, framealpha=0.6)
    ax.set_xlim(0, width * 1e6)
    ax.set_ylim(0, height * 1e6)
    if path is not None:
        save_figure(fig, path)
    return fig


#: Margins [in] of the paper's plots (fixed: the figures are laid out without measuring every
#: text, and drawn once): room for tick labels and an axis label left of and below the axes.
_LEFT, _RIGHT, _BOTTOM, _GAP = 0.85, 0.2, 0.62, 0.95
#: Height [in] an axes title of ``lines`` lines at ``size`` [pt] takes above its axes (with
#: matplotlib's 6 pt pad).
_AXES_TITLE_PAD = 6 / 72


def _axes_title_height(lines, size):
    return (1.2 * lines + 0.1) * size / 72 + _AXES_TITLE_PAD


def _two_panels(rows, sweeps, y_key, err_key, scene_key, subject):
    width, height = 11, 4.6
    fig = figure(width, height, layout=None)
    top = title_block(fig, f"{subject}: reading of each camera against the scene; {ERROR_BARS}")
    panel = (width - _LEFT - _RIGHT - _GAP) / 2
    nbsp = "\u00a0"  # the tensor's shape is not broken across lines
    titles = [wrap_text(fig, f"A) {subject} vs integration time "
                        f"({nbsp.join('9 × 9 × n'.split())})", panel, 10),
              wrap_text(fig, f"B) {subject} vs sensor area ({nbsp.join('p × p × 1'.split())})",
                        panel, 10)]
    lines = max(t.count("\n") + 1 for t in titles)
    left, right = fixed_axes(fig, 1, 2, _LEFT, _RIGHT, _BOTTOM,
                             top + _axes_title_height(lines, 10) + 0.04, wspace=_GAP)
    plot_versus(left, select(rows, sweeps[0]), "integration_time_us", y_key, err_key,
                scene_key, "integration time [µs]", titles[0])
    plot_versus(right, select(rows, sweeps[1]), "sensor_area_um2", y_key, err_key, scene_key,
                "sensor element area [µm²]", titles[1])
    return fig


def plot_peak(rows, sweeps=("integration-time", "size-of-source")):
    """Figure 5: peak temperature against integration time and sensor area, ±1σ bars."""
    return _two_panels(rows, sweeps, "peak_C", "peak_uncertainty_K", "peak_scene_C",
                       "Figure 5, peak temperature")


def plot_column_i(rows, sweeps=("integration-time", "size-of-source")):
    """Figure 7: the shear band's peak in Column I against integration time and sensor area."""
    return _two_panels(rows, sweeps, "column_I_C", "column_I_uncertainty_K", "column_I_scene_C",
                       "Figure 7, shear band peak in Column I")


def plot_column_profiles(rows, folder, scene, sweep="integration-time", camera="linear",
                         cache=None, event=None):
    """Figure 6: vertical temperature profiles along Columns I, II and III, one line per
    integration time, with the scene's event frame [K] (``event``, else computed from ``scene``
    if it has ``temperature``). ``cache`` as in :func:`plot_maps`."""
    mine = sorted(select(rows, sweep, camera=camera), key=lambda r: r["integration_time_us"])
    fig = figure(12, 4.8, layout=None)
    top = title_block(fig, f"Figure 6: vertical profiles of the camera {camera!r} "
                      f"({mine[0]['response'] if mine else ''} response) along Columns I–III, "
                      "one line per integration time, centred on the shear band; black: the "
                      "scene's event frame")
    axes = fixed_axes(fig, 1, 3, _LEFT, _RIGHT, _BOTTOM, top + _axes_title_height(1, 12) + 0.04,
                      wspace=0.2, sharey=True)
    if event is None and hasattr(scene, "temperature"):
        event = scene.temperature(scene.event_time)
    for ax, name in zip(axes, ("I", "II", "III")):
        for r in mine:
            m = _read(folder, r["exr"], cache)
            pitch = m.camera.fpa.pixel_pitch
            j = column_index(scene, pitch, name, m.camera.fpa.origin[1])
            y = (scene.shape[0] * scene.dx - (np.arange(m.shape[0]) + 0.5) * pitch) * 1e6
            ax.plot(m.apparent_temperature[:, j] - CELSIUS_OFFSET, y,
                    label=f"{r['integration_time_us']:g} µs")
        if event is not None:
            j = column_index(scene, scene.dx, name)
            y = (scene.shape[0] - np.arange(scene.shape[0]) - 0.5) * scene.dx * 1e6
            ax.plot(event[:, j] - CELSIUS_OFFSET, y, color="black", lw=0.8, label="scene, event frame")
        ax.set_title(f"Column {name}", y=1.0)
        ax.set_xlabel("temperature [°C]")
        few_ticks(ax, 5, 7)
    axes[0].set_ylabel("y [µm]")
    axes[0].legend(fontsize=7)
    return fig


def plot_long_integration(rows, history, sweep="long-integration"):
    """
    Figure 8, one quantity per axis: above, the band pixel's instantaneous 9 × 9 mean over time
    and its reading at an integration time equal to the position on the axis [°C]; below, the
    standard deviation of the scene over the same tensor [K].
    """
    mine = sorted(select(rows, sweep), key=lambda r: r["integration_time_us"])
    camera = mine[0]["camera"] if mine else ""
    fig = figure(8, 6.5, layout=None)
    top = title_block(fig, f"Figure 8: the Column I pixel where the shear band peaks, camera "
                      f"{camera!r}; windows start at the event frame")
    top_ax, bottom = fixed_axes(fig, 2, 1, _LEFT, _RIGHT, _BOTTOM, top + 0.1, hspace=0.15,
                                sharex=True)
    if history:
        top_ax.plot([h["time_us"] for h in history], [h["mean_C"] for h in history], lw=0.8,
                    color="tab:blue", label="pixel footprint mean, instantaneous (x = time)")
    x = [r["integration_time_us"] for r in mine]
    top_ax.plot(x, [r["peak_C"] for r in mine], "o-", color="tab:red",
                label="reading (x = integration time)")
    top_ax.set_ylabel("temperature [°C]")
    top_ax.legend(fontsize=8)
    bottom.plot(x, [r["peak_uncertainty_K"] for r in mine], "s-", color="tab:green",
                label="standard deviation over the tensor (x = integration time)")
    bottom.set_ylabel("standard deviation [K]")
    bottom.set_xlabel("time since the event frame's start; integration time [µs]")
    bottom.legend(fontsize=8)
    few_ticks(top_ax, 8, 7)
    few_ticks(bottom, 8, 7)
    return fig


def plot_maps(folder, rows, cases, cache=None):
    """
    Figures 9-11: maps of apparent temperature, peak error and uncertainty, one column per
    case (rows of the results table).

    Each row of maps shares one colour scale and one colorbar, so a colour means the same
    value in every case of the row. ``cache`` (optional) maps EXR names to measurements
    already read, and is filled with the ones read here.
    """
    titles = ("apparent temperature [°C]", "peak error [K]", "uncertainty [K]")
    row_names = ("Fig. 9: reading", "Fig. 10: peak error", "Fig. 11: uncertainty")
    maps = [[] for _ in titles]
    labels, extents = [], []
    for row in cases:
        m = _read(folder, row["exr"], cache)
        pitch = m.camera.fpa.pixel_pitch * 1e6
        extent = (0, m.shape[1] * pitch, 0, m.shape[0] * pitch)
        extents.append(extent)
        fields = (m.apparent_temperature - CELSIUS_OFFSET, m.tensor_max - m.apparent_temperature,
                  m.tensor_std)
        for r, values in enumerate(fields):
            maps[r].append((values, extent))
        p = round(row["pixel_samples"], 3)
        labels.append(f"{p:g}×{p:g}×{row['n_frames']:g} "
                      f"({row['integration_time_us']:g} µs, {row['camera']})")
    # One map 2.75 in wide, as tall as the first case's field. Maps of one extent are drawn
    # side by side with ticks on the outer ones only (fewer texts to lay out and draw).
    shared = all(np.allclose(e, extents[0], rtol=1e-9, atol=0) for e in extents)
    n = len(cases)
    width = 2.75
    aspect = (extents[0][3] / extents[0][1]) if extents and extents[0][1] > 0 else 0.75
    height = width * min(max(aspect, 0.2), 2.0)
    left, gap = 1.0, (0.2 if shared else 0.85)
    rowgap = 0.2 if shared else 0.6
    bar_gap, bar, right = 0.12, 0.14, 0.95
    fig_width = left + n * width + (n - 1) * gap + bar_gap + bar + right
    fig = figure(fig_width, 1.0, layout=None)  # its height once the title's lines are known
    top = title_block(fig, "Figures 9–11: maps of each case (columns); rows: the reading, the "
                      "paper's peak error (tensor max − reading, > 0 when the camera reads low) "
                      "and its uncertainty (tensor standard deviation); one colour scale per row")
    labels = [wrap_text(fig, label, width, 9) for label in labels]
    top += _axes_title_height(max(label.count("\n") + 1 for label in labels), 9) + 0.04
    fig_height = top + 3 * height + 2 * rowgap + _BOTTOM
    fig.set_size_inches(fig_width, fig_height)  # the title stays where it is from the top
    axes = fixed_axes(fig, 3, n, left, bar_gap + bar + right, _BOTTOM, top, wspace=gap,
                      hspace=rowgap, squeeze=False)
    for c, label in enumerate(labels):
        axes[0, c].set_title(label, fontsize=9, y=1.0)
    for r, (title, name) in enumerate(zip(titles, row_names)):
        vmin, vmax = _limits([values for values, _ in maps[r]])
        for c, (values, extent) in enumerate(maps[r]):
            ax = axes[r, c]
            image = ax.imshow(values, extent=extent, cmap="inferno", origin="upper", vmin=vmin,
                              vmax=vmax, interpolation="nearest")
            few_ticks(ax, "auto", "auto")  # matplotlib's default ticks, the ones in view
            if shared and r < 2:
                ax.set_xticks([])
            else:
                ax.set_xlabel("x [µm]")
            if shared and c > 0:
                ax.set_yticks([])
            else:
                ax.set_ylabel(f"{name}\ny [µm]" if c == 0 else "y [µm]")
        box = axes[r, -1].get_position()
        cax = fig.add_axes((box.x1 + bar_gap / fig_width, box.y0, bar / fig_width, box.height))
        fig.colorbar(image, cax=cax, label=title)
    return fig


def _limits(arrays):
    """The colour scale (vmin, vmax) common to ``arrays``: their finite minimum and maximum."""
    finite = [(float(np.nanmin(a)), float(np.nanmax(a))) for a in arrays
              if np.isfinite(a).any()]
    if not finite:
        return None, None
    return min(lo for lo, _ in finite), max(hi for _, hi in finite)


def _read(folder, name, cache=None):
    """The measurement in EXR file ``name`` of ``folder``, read once per ``cache``."""
    if cache is not None and name in cache:
        return cache[name]
    from radiosim.io.exr import read_exr

    measurement = read_exr(Path(folder) / name)
    if cache is not None:
        cache[name] = measurement
    return measurement


def _cases(rows, camera):
    """The cases of Figures 9-11: the 9-sample size-of-source case and the 10, 45 and 90 µs
    integration times of ``camera``, those with an EXR file."""
    cases = [r for r in rows if r["sweep"] == "size-of-source" and r["camera"] == camera
             and round(r["pixel_samples"], 6) == 9]
    cases += [r for r in rows if r["sweep"] == "integration-time" and r["camera"] == camera
              and r["integration_time_us"] in (10, 45, 90)]
    return [c for c in cases if c.get("exr")]


def _names(rows, scene, camera) -> list[str]:
    """The figures ``rows`` (and ``scene``) make, in the order they are written."""
    names = []
    sweeps = {r["sweep"] for r in rows}
    if {"integration-time", "size-of-source"} <= sweeps:
        names.append("fig05_peak.png")
        if any(np.isfinite(r.get("column_I_C", math.nan)) for r in rows):
            names.append("fig07_column_I.png")
    timed = [r for r in rows if r["sweep"] == "integration-time" and r["camera"] == camera]
    if scene is not None and has_columns(scene) and timed and all(r.get("exr") for r in timed):
        names.append("fig06_profiles.png")
    if "long-integration" in sweeps:
        names.append("fig08_long_integration.png")
    if _cases(rows, camera):
        names.append("fig09-11_maps.png")
    return names


def draw_figures(folder, names, scene=None, camera="linear", event=None) -> list[Path]:
    """
    Write the figures ``names`` (of :func:`make_figures`) of a study's results ``folder`` into
    ``folder/figures``, which exists; returns their paths. ``scene``: the scene with reference
    columns (Figure 6), ``event`` its event frame [K] if already computed.
    """
    folder = Path(folder)
    rows, history = load_results(folder)
    cache = {}  # the EXR files Figures 6 and 9-11 share, read once
    builders = {
        "fig05_peak.png": lambda: plot_peak(rows),
        "fig07_column_I.png": lambda: plot_column_i(rows),
        "fig06_profiles.png": lambda: plot_column_profiles(rows, folder, scene, camera=camera,
                                                           cache=cache, event=event),
        "fig08_long_integration.png": lambda: plot_long_integration(rows, history),
        "fig09-11_maps.png": lambda: plot_maps(folder, rows, _cases(rows, camera),
                                               cache=cache),
    }
    # The collector held off: the figures' objects are freed at once at the end, and the
    # process's old objects are not walked on the way (radiosim.plotting.collector_held).
    with collector_held():
        return [save_figure(builders[name](), folder / "figures" / name) for name in names]


def make_figures(folder, scene=None, camera="linear") -> list[Path]:
    """
    Write the paper's figures for a study's results folder into ``folder/figures`` (the
    ``figures`` hook of the ``msec2009`` study).

    Returns the PNG paths written, in the order they are drawn: figures whose sweeps the study
    lacks, or whose EXR files were not written (profiles, maps), are skipped.
    """
    folder = Path(folder)
    rows, _ = load_results(folder)
    names = _names(rows, scene, camera)
    if not names:
        return []
    (folder / "figures").mkdir(exist_ok=True)
    event = None
    if "fig06_profiles.png" in names and hasattr(scene, "temperature"):
        event = scene.temperature(scene.event_time)
    return draw_figures(folder, names, scene, camera, event)


def prepare() -> None:
    """Before a study measures (its figures hook's ``prepare``): load matplotlib on a
    background thread meanwhile (:func:`radiosim.plotting.preload`)."""
    preload()


#: A study calls its figures hook's ``prepare`` when it starts measuring.
make_figures.prepare = prepare

"""
Figures (matplotlib): scene previews with the paper's reference lines.

The library draws on a figure it creates and returns; it never shows windows. Axes carry units.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError

__all__ = ["preview_scene"]

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
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    if t is None:
        t = scene.event_time if scene.event_time is not None else 0.0
    k = int(math.floor(t / scene.dt))
    frame = scene.temperature(t) if hasattr(scene, "temperature") and callable(
        getattr(scene, "temperature")) and hasattr(scene, "params") else scene.frame(k)
    height, width = scene.shape[0] * scene.dx, scene.shape[1] * scene.dx
    fig = Figure(figsize=(8.0, 8.0 * height / width + 0.6), layout="constrained")
    ax = fig.add_subplot()
    image = ax.imshow(frame - _C, extent=(0, width * 1e6, 0, height * 1e6), cmap="inferno",
                      origin="upper", interpolation="nearest")
    fig.colorbar(image, ax=ax, label="temperature [°C]", shrink=0.85)
    ax.set_xlabel("x [µm]")
    ax.set_ylabel("y [µm]")
    ax.set_title(f"t = {t * 1e6:.2f} µs, peak {frame.max() - _C:.0f} °C")
    if hasattr(scene, "params"):
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

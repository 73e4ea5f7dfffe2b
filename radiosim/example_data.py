"""
Example data: the files the README's and the how-to guides' snippets read
(``radiosim example-data DIR``, :func:`write_example_data`).

One physically meaningful field stands behind all of them: a shear band 8 µm wide (σ), 500 K
above a 20 °C chip, crossing the field at the chip speed of the paper's cut (V_c = rV ≈
2.29 m/s; :class:`~radiosim.scenes.analytic.MovingGaussianBand`, closed form, so each file can
be checked against it). It is written as

========================  ==========================================================================
``fea_frames.npy``        frames [K], float32 (60, 96, 128): 0.2 µs frames, 960/1440 µm samples
``frames.npy``            the same frames in °C
``run/frame_0000.exr`` …  the first 20 frames as EXR files [°C] with ``temperature_unit``,
                          ``dt_s`` and ``dx_m`` header attributes
``nodes.csv``             FEA nodal output: ``time, x, y, temperature`` of 325 scattered nodes
                          every 1 µs from 0 to 40 µs, with a ``# units: time=us, length=um,
                          temperature=C`` line
``run.pvd``, ``run/*.vtu``  the same field on a triangle mesh (meshio), point data
                          ``temperature_C``, a ParaView collection of 11 steps (µm, µs)
``my-camera.toml``        the ``nist-ir`` camera as a camera file
``table.csv``             a blackbody calibration table of that camera at 100 µs (mean counts of
                          16 read-outs of its central pixels, 50–450 °C)
``my-study.toml``         a study of ``frames.npy``: the ``nist-ir`` camera at 1 and 10 µs
========================  ==========================================================================

The folder must be new or empty; every file is written atomically and listed in the folder's
``radiosim-manifest.json`` (:class:`radiosim.files.OutputFolder`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.files import OutputFolder, atomic_path, atomic_write, write_text
from radiosim.units import CELSIUS_OFFSET, MICRO

__all__ = ["write_example_data", "example_band", "FRAME_DT", "FRAME_DX", "CALIBRATION_TIME"]

#: Frame interval of the stacks [s] and their sample pitch [m] (the paper's grid).
FRAME_DT = 0.2e-6
FRAME_DX = 960e-6 / 1440
#: Integration time of the calibration table [s].
CALIBRATION_TIME = 100e-6
_NODE_STEP = 1e-6  # FEA output interval [s]
_BAND = {"background": CELSIUS_OFFSET + 20.0, "amplitude": 500.0, "sigma": 8e-6,
         "velocity": 0.55 * 250 / 60, "x0": 15e-6}


def example_band(shape=(96, 128), dx: float = FRAME_DX, dt: float = FRAME_DT, n_frames=60):
    """The example data's field: a :class:`~radiosim.scenes.analytic.MovingGaussianBand`
    (20 °C chip, a band 500 K hotter with σ = 8 µm, moving at 2.29 m/s in +x from x = 15 µm).
    """
    from radiosim.scenes.analytic import MovingGaussianBand

    return MovingGaussianBand(**_BAND, shape=shape, dx=dx, dt=dt, n_frames=n_frames)


def _band_at(x, t):
    """The band's temperature [K] at positions x [m] and time t [s]."""
    centre = _BAND["x0"] + _BAND["velocity"] * t
    return _BAND["background"] + _BAND["amplitude"] * np.exp(
        -((x - centre) ** 2) / (2 * _BAND["sigma"] ** 2))


def _save_npy(path: Path, array: np.ndarray) -> None:
    with atomic_write(path, "wb") as stream:
        np.save(stream, array)


def _write_frames(folder: Path) -> None:
    from radiosim.io.exr import _typed, write_channels

    band = example_band()
    kelvin = np.stack([band.frame(k) for k in range(band.n_frames)]).astype(np.float32)
    _save_npy(folder / "fea_frames.npy", kelvin)
    _save_npy(folder / "frames.npy", (kelvin - CELSIUS_OFFSET).astype(np.float32))
    (folder / "run").mkdir(exist_ok=True)
    header = {"temperature_unit": _typed("C"), "dt_s": _typed(FRAME_DT),
              "dx_m": _typed(FRAME_DX)}
    for k in range(20):
        write_channels(folder / "run" / f"frame_{k:04d}.exr",
                       {"temperature": kelvin[k] - CELSIUS_OFFSET}, header)


def _node_grid(rng):
    """Scattered nodes [m]: a 25 × 13 grid over 120 × 60 µm, jittered inside (the boundary
    nodes stay on the boundary, so every step covers the same rectangle)."""
    x, y = np.meshgrid(np.linspace(0, 120e-6, 25), np.linspace(0, 60e-6, 13))
    jitter = rng.uniform(-1.5e-6, 1.5e-6, (2,) + x.shape)
    inner = np.zeros(x.shape, bool)
    inner[1:-1, 1:-1] = True
    return (x + jitter[0] * inner).ravel(), (y + jitter[1] * inner).ravel()


def _write_nodes(folder: Path, rng) -> None:
    lines = ["# FEA nodal output: a shear band crossing a 20 °C chip (radiosim example data)",
             "# units: time=us, length=um, temperature=C", "time,x,y,temperature"]
    for k in range(41):
        t = k * _NODE_STEP
        x, y = _node_grid(rng)  # remeshed at every step
        celsius = _band_at(x, t) - CELSIUS_OFFSET
        lines += [f"{t / MICRO:g},{a / MICRO:.4f},{b / MICRO:.4f},{c:.3f}"
                  for a, b, c in zip(x, y, celsius)]
    write_text(folder / "nodes.csv", "\n".join(lines) + "\n")


def _write_mesh(folder: Path) -> None:
    import meshio

    x, y = (a.ravel() for a in np.meshgrid(np.linspace(0, 120, 25), np.linspace(0, 60, 13)))
    points = np.column_stack([x, y, np.zeros_like(x)])  # [µm]
    index = np.arange(25 * 13).reshape(13, 25)
    a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, 1:], index[1:, :-1]
    triangles = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                                np.stack([a, c, d], -1).reshape(-1, 3)])
    entries = []
    for k in range(11):
        t = k * _NODE_STEP
        celsius = _band_at(x * MICRO, t) - CELSIUS_OFFSET
        name = f"run/step_{k:02d}.vtu"
        mesh = meshio.Mesh(points, [("triangle", triangles)],
                           point_data={"temperature_C": celsius})
        with atomic_path(folder / name) as temporary:
            meshio.write(temporary, mesh, file_format="vtu")
        entries.append(f'    <DataSet timestep="{t / MICRO:g}" part="0" file="{name}"/>')
    write_text(folder / "run.pvd", "\n".join([
        '<?xml version="1.0"?>',
        "<!-- radiosim example data: times in µs, lengths in µm -->",
        '<VTKFile type="Collection" version="0.1">', "  <Collection>", *entries,
        "  </Collection>", "</VTKFile>"]) + "\n")


def _write_camera_and_table(folder: Path, rng) -> None:
    from radiosim.camera import Camera
    from radiosim.characterization import flat_field
    from radiosim.presets import PRESET_DIRECTORY

    # the preset's own file, with its provenance comments
    write_text(folder / "my-camera.toml",
               (PRESET_DIRECTORY / "nist-ir.toml").read_text(encoding="utf-8"))
    camera = Camera.from_toml(folder / "my-camera.toml")
    rows, cols = camera.fpa.shape
    centre = (slice(rows // 2 - 8, rows // 2 + 8), slice(cols // 2 - 8, cols // 2 + 8))
    lines = ["# blackbody calibration of my-camera.toml at 100 us: mean counts of 16 read-outs "
             "of the central 16 x 16 pixels (radiosim example data)",
             "temperature_C,counts"]
    for celsius in range(50, 451, 50):
        counts, _ = flat_field(camera, celsius + CELSIUS_OFFSET, CALIBRATION_TIME, 16, rng)
        lines.append(f"{celsius},{counts[centre].mean():.2f}")
    write_text(folder / "table.csv", "\n".join(lines) + "\n")


_STUDY = '''name = "my-study"
description = "The example frames (a shear band crossing a 20 °C chip) seen by nist-ir"

[scene]
type = "frames"
path = "frames.npy"
dt_us = 0.2
dx_um = {dx_um!r}
units = "C"
emissivity = 0.3

[cameras.nist]
preset = "nist-ir"
assumed_emissivity = 0.3

[[sweeps]]
name = "integration-time"
cameras = ["nist"]
integration_time_us = [1, 10]
'''


def write_example_data(folder, rng=0) -> list[Path]:
    """
    Write the example data (see the module docstring) into ``folder``, which must be new or
    empty; returns the files written. ``rng`` seeds the nodes' scatter and the calibration
    table's noise.
    """
    folder = Path(folder).resolve()
    if folder.is_dir() and any(folder.iterdir()):
        raise RadiosimError(f"{folder} is not empty; the example data goes into a new or "
                            "empty folder")
    rng = np.random.default_rng(rng)
    out = OutputFolder(folder, option="the example data's folder")
    try:
        staging = out.staging
        _write_frames(staging)
        _write_nodes(staging, rng)
        _write_mesh(staging)
        _write_camera_and_table(staging, rng)
        write_text(staging / "my-study.toml", _STUDY.format(dx_um=FRAME_DX / MICRO))
    except BaseException:
        out.abandon(keep=False)
        raise
    return out.commit()

"""
The ``radiosim`` command.

``radiosim run`` measures the built-in demonstration scene (a hot band moving at the cutting
speed, the motion-blur problem of the paper) with the linear ideal camera and the ``nist-ir``
preset over a sweep of integration times, and prints (and optionally writes) a table.
``radiosim presets`` lists the camera presets. The command owns all console output; the library
only logs and warns.
"""

from __future__ import annotations

import argparse
import csv
import logging
import sys
import warnings
from pathlib import Path

import numpy as np

from radiosim import __version__
from radiosim.camera import Camera, available_presets
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.scenes import MovingGaussianBand

__all__ = ["main", "demo_scene"]

_UNITS = {"us": 1e-6, "µs": 1e-6, "ms": 1e-3, "ns": 1e-9, "s": 1.0}


def parse_time(text: str) -> float:
    """A duration with a unit (``10us``, ``0.5ms``, ``200ns``) in seconds."""
    for unit in sorted(_UNITS, key=len, reverse=True):
        if text.endswith(unit):
            number = text[: -len(unit)].strip()
            try:
                value = float(number) * _UNITS[unit]
            except ValueError:
                break
            if value > 0:
                return value
            break
    raise argparse.ArgumentTypeError(
        f"{text!r} is not a positive duration with a unit (e.g. 10us, 0.5ms, 200ns)"
    )


def demo_scene(emissivity: float = 1.0) -> MovingGaussianBand:
    """
    The demonstration scene: a 12 µm-wide (σ = 6 µm) band at 739 °C on a 20 °C background,
    moving at 250 m/min (4.17 m/s) across a 960 µm wide strip sampled as the paper's movie
    (1440 columns, 0.2 µs frames).
    """
    return MovingGaussianBand(
        background=293.15, amplitude=719.0, sigma=6e-6, velocity=250 / 60, x0=100e-6,
        shape=(216, 1440), dx=960e-6 / 1440, dt=0.2e-6, emissivity=emissivity,
    )


def _run(args) -> int:
    scene = demo_scene(args.emissivity)
    cameras = [Camera.linear_ideal(6e-6), Camera.preset("nist-ir")]
    rows = []
    for camera in cameras:
        for t_int in args.integration_times:
            with warnings.catch_warnings(record=True):
                warnings.simplefilter("always", RadiosimWarning)
                m = camera.measure(scene, t_int, rng=args.seed)
            j = np.unravel_index(np.argmax(m.tensor_mean), m.shape)
            rows.append({
                "camera": camera.name,
                "response": camera.response,
                "integration_time_us": t_int * 1e6,
                "frames": m.n_frames,
                "tensor_max_C": float(m.tensor_max.max()) - 273.15,
                "apparent_at_band_C": float(m.apparent_temperature[j]) - 273.15,
                "mean_at_band_C": float(m.tensor_mean[j]) - 273.15,
                "std_at_band_K": float(m.tensor_std[j]),
                "saturated_fraction": m.saturated_fraction,
            })
    header = (f"{'camera':<13}{'t_int':>8}{'frames':>7}{'scene max':>11}{'mean':>9}"
              f"{'apparent':>10}{'std':>8}{'saturated':>11}")
    print(f"radiosim {__version__}: hot band (739 °C, σ = 6 µm) at 250 m/min, "
          f"emissivity {args.emissivity}; values at the hottest pixel")
    print(header)
    print(f"{'':<13}{'[µs]':>8}{'':>7}{'[°C]':>11}{'[°C]':>9}{'[°C]':>10}{'[K]':>8}{'[%]':>11}")
    for r in rows:
        apparent = "saturated" if np.isnan(r["apparent_at_band_C"]) else \
            f"{r['apparent_at_band_C']:.1f}"
        print(f"{r['camera']:<13}{r['integration_time_us']:>8.1f}{r['frames']:>7d}"
              f"{r['tensor_max_C']:>11.1f}{r['mean_at_band_C']:>9.1f}{apparent:>10}"
              f"{r['std_at_band_K']:>8.1f}{100 * r['saturated_fraction']:>11.1f}")
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        path = out / "demo.csv"
        with path.open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        print(f"wrote {path}")
    return 0


def _presets(args) -> int:
    for name in available_presets():
        camera = Camera.preset(name)
        rows, cols = camera.fpa.shape or ("-", "-")
        print(f"{name:<12} {camera.response:<7} {cols} x {rows} px, "
              f"{camera.fpa.pixel_pitch * 1e6:g} µm object pixel, "
              f"{camera.optics.band[0] * 1e6:g}-{camera.optics.band[1] * 1e6:g} µm")
    return 0


def _preview(args) -> int:
    from radiosim.plotting import preview_scene
    from radiosim.scenes import SegmentedChip

    scene = SegmentedChip(args.params) if args.params else SegmentedChip()
    t = args.time if args.time is not None else scene.event_time
    preview_scene(scene, t, args.out)
    print(f"wrote {args.out} (t = {t * 1e6:.2f} µs)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="radiosim", description="Radiometric simulation of infrared cameras."
    )
    parser.add_argument("--version", action="version", version=f"radiosim {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="measure the built-in demonstration scene")
    run.add_argument("--integration-times", type=parse_time, nargs="+",
                     default=[1e-6, 10e-6, 45e-6, 90e-6], metavar="T",
                     help="integration times with units (default: 1us 10us 45us 90us)")
    run.add_argument("--emissivity", type=float, default=0.18,
                     help="emissivity of the scene (default 0.18, clean steel in 3-5 µm)")
    run.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    run.add_argument("--out", help="folder to write demo.csv into")
    run.set_defaults(func=_run)
    presets = sub.add_parser("presets", help="list the camera presets")
    presets.set_defaults(func=_presets)
    scene = sub.add_parser("scene", help="the built-in segmented-chip scene")
    scene_sub = scene.add_subparsers(dest="scene_command", required=True)
    preview = scene_sub.add_parser("preview", help="write a PNG of the scene with the tool, "
                                   "shear plane and Columns I-III (like the paper's Figure 4)")
    preview.add_argument("--time", type=parse_time, default=None,
                         help="time with a unit (default: the fully developed band)")
    preview.add_argument("--params", help="TOML file of chip parameters")
    preview.add_argument("--out", default="scene.png", help="PNG path (default scene.png)")
    preview.set_defaults(func=_preview)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return args.func(args)
    except RadiosimError as exc:
        print(f"radiosim: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

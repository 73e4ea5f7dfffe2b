"""
The ``radiosim`` command.

``radiosim run`` measures the built-in segmented-chip scene with the linear ideal camera and the
``nist-ir`` preset over a sweep of integration times, and prints (and optionally writes) a
table; ``radiosim scene preview`` draws the scene like the paper's Figure 4.
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
from radiosim.units import parse_quantity

__all__ = ["main", "demo_scene"]

def parse_time(text: str) -> float:
    """A duration with a unit (``10us``, ``0.5ms``, ``200ns``) in seconds, > 0."""
    try:
        value = parse_quantity(text, "time")
    except RadiosimError:
        value = None
    if value is None or not value > 0:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a positive duration with a unit (e.g. 10us, 0.5ms, 200ns)")
    return value


def demo_scene(emissivity: float = 1.0, dt: float = 0.2e-6):
    """
    The demonstration scene: the built-in segmented chip, with a grey ``emissivity`` for the
    steel (chip and workpiece) and the tool, and the air seen as a blackbody background.
    """
    from radiosim.scenes import SegmentedChip

    grey = {"chip": emissivity, "workpiece": emissivity, "tool": emissivity, "air": 1.0}
    return SegmentedChip(dt=dt, emissivity=grey)


def _run(args) -> int:
    scene = demo_scene(args.emissivity)
    column = int(scene.column_x("I") // 6e-6)
    cameras = [Camera.linear_ideal(6e-6), Camera.preset("nist-ir")]
    rows = []
    for camera in cameras:
        for t_int in args.integration_times:
            with warnings.catch_warnings(record=True):
                warnings.simplefilter("always", RadiosimWarning)
                m = camera.measure(scene, t_int, rng=args.seed)
            col = m.apparent_temperature[:, column]
            rows.append({
                "camera": camera.name,
                "response": camera.response,
                "integration_time_us": t_int * 1e6,
                "frames": m.n_frames,
                "scene_peak_C": float(m.tensor_max.max()) - 273.15,
                "apparent_peak_C": float(np.nanmax(m.apparent_temperature)) - 273.15
                if m.valid.any() else float("nan"),
                "column_I_scene_C": float(m.tensor_max[:, column].max()) - 273.15,
                "column_I_apparent_C": float(np.nanmax(col)) - 273.15
                if np.isfinite(col).any() else float("nan"),
                "saturated_fraction": m.saturated_fraction,
            })

    def cell(value):
        return f"{'—':>10}" if np.isnan(value) else f"{value:>10.1f}"

    print(f"radiosim {__version__}: segmented chip (250 m/min, AISI 1045-like), emissivity "
          f"{args.emissivity}; event of the fully developed shear band")
    print(f"{'camera':<13}{'t_int':>7}{'frames':>7}{'peak':>10}{'read':>10}"
          f"{'col. I':>10}{'read':>10}{'saturated':>11}")
    print(f"{'':<13}{'[µs]':>7}{'':>7}{'[°C]':>10}{'[°C]':>10}{'[°C]':>10}{'[°C]':>10}"
          f"{'[%]':>11}")
    for r in rows:
        print(f"{r['camera']:<13}{r['integration_time_us']:>7.1f}{r['frames']:>7d}"
              f"{cell(r['scene_peak_C'])}{cell(r['apparent_peak_C'])}"
              f"{cell(r['column_I_scene_C'])}{cell(r['column_I_apparent_C'])}"
              f"{100 * r['saturated_fraction']:>11.1f}")
    print("peak / col. I: scene maxima over the window; read: the camera's highest valid "
          "reading (— where all saturated)")
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
    run = sub.add_parser("run", help="measure the built-in segmented-chip scene")
    run.add_argument("--integration-times", type=parse_time, nargs="+",
                     default=[1e-6, 10e-6, 45e-6, 90e-6], metavar="T",
                     help="integration times with units (default: 1us 10us 45us 90us)")
    run.add_argument("--emissivity", type=float, default=1.0,
                     help="grey emissivity of chip, workpiece and tool (default 1, the "
                     "paper's blackbody; clean steel is about 0.2 in 3-5 µm)")
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

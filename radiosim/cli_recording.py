"""
``radiosim recording``: what a camera recorded, read by :func:`radiosim.io.read_recording`.

-   ``radiosim recording info FILE``: the file's metadata as a table.
-   ``radiosim recording export FILE --out T.nc|T.exr [--camera C] [--frames A:B]``: its
    temperatures (through the file's own calibration, or a radiosim camera's at the
    recording's integration time and housing temperature) with their provenance, in a new file.
-   ``radiosim compare RECORDING SIMULATION --out FOLDER``: the recording beside a simulated
    measurement (:func:`radiosim.comparison.compare`): the statistics printed, the images and
    their difference in ``comparison.nc``, the figure in ``comparison.png``.
-   ``radiosim correct MEASUREMENT --out CORRECTED.nc [--velocity VX,VY]``: a measurement's
    reading corrected for its camera's blur and a known motion
    (:func:`radiosim.correction.correct`), with its uncertainty.
"""

from __future__ import annotations

__all__ = ["add_recording_parser", "add_compare_parser", "add_correct_parser"]


def _frames(text: str):
    """``A:B`` (a slice), ``K`` (one frame) or ``None``."""
    import argparse

    if text is None:
        return None
    try:
        if ":" in text:
            start, _, stop = text.partition(":")
            return slice(int(start) if start else None, int(stop) if stop else None)
        return [int(text)]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--frames {text!r}: expected K or A:B (frame "
                                         "indices)") from None


def _out_file(parser, what: str) -> None:
    """The required ``--out FILE`` and ``--overwrite`` of a command that writes one file."""
    parser.add_argument("--out", required=True, help=what)
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")


def _info(args) -> int:
    from radiosim.io.recordings import info_lines, read_recording

    print("\n".join(info_lines(read_recording(args.file))))
    return 0


def _export(args) -> int:
    from pathlib import Path

    from radiosim.cli_checks import camera_from_argument, check_out_file
    from radiosim.errors import RadiosimError
    from radiosim.io.recordings import export_recording, read_recording

    suffix = Path(args.out).suffix.lower()
    if suffix not in (".nc", ".exr"):
        raise RadiosimError(f"--out {args.out}: radiosim exports recordings to .nc or .exr")
    check_out_file(args, suffix, "the temperatures are a NetCDF or EXR file")
    recording = read_recording(args.file)
    camera = (camera_from_argument(args.camera, command="recording export") if args.camera
              else None)
    frames = args.frames
    if suffix == ".exr":
        if isinstance(frames, slice):
            raise RadiosimError("--frames: an EXR holds one frame; give one index K")
        frames = None if frames is None else frames[0]
    path = export_recording(recording, args.out, camera, frames)
    print(f"wrote {path}")
    return 0


def add_recording_parser(sub) -> None:
    """Add ``recording info`` and ``recording export`` to the command's subparsers."""
    recording = sub.add_parser("recording", help="read what a camera recorded (.ptw, .fff, "
                               ".seq): its metadata, its temperatures")
    commands = recording.add_subparsers(dest="recording_command", required=True,
                                        metavar="info|export")
    info = commands.add_parser("info", help="the recording's metadata as a table")
    info.add_argument("file", help="a .ptw, .fff or .seq recording")
    info.set_defaults(func=_info)
    export = commands.add_parser(
        "export", help="its temperatures, with provenance, to a new .nc or .exr file",
        description="Write the recording's temperatures and counts to a CF NetCDF file (all "
        "frames, or --frames A:B, streamed) or an EXR of one frame. A FLIR file is calibrated "
        "by its own curve and object parameters; a file without one (.ptw) needs --camera, "
        "whose calibration is taken at the recording's integration time and housing "
        "temperature.")
    export.add_argument("file", help="a .ptw, .fff or .seq recording")
    _out_file(export, "a new .nc or .exr file")
    export.add_argument("--camera", help="preset name or camera TOML (fitted to this camera)")
    export.add_argument("--frames", type=_frames, default=None, metavar="A:B",
                        help="frames to export: K or A:B (default all; an EXR: frame 0)")
    export.set_defaults(func=_export)


def _shift(text: str):
    import argparse

    try:
        rows, columns = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected two numbers separated by a "
                                         "comma, e.g. 2.5,-1") from None
    return rows, columns


def _compare(args) -> int:
    from pathlib import Path

    from radiosim.cli_checks import camera_from_argument
    from radiosim.comparison import compare
    from radiosim.errors import RadiosimError
    from radiosim.files import OutputFolder
    from radiosim.io.netcdf import write_netcdf
    from radiosim.io.recordings import read_recording
    from radiosim.plotting import save_figure

    simulation = Path(args.simulation)
    if simulation.suffix.lower() == ".nc":
        from radiosim.io.netcdf import read_netcdf as read
    elif simulation.suffix.lower() == ".exr":
        from radiosim.io.exr import read_exr as read
    else:
        raise RadiosimError(f"{simulation}: a simulated measurement is a .nc or .exr file "
                            "(radiosim measure --out)")
    recording = read_recording(args.recording)
    measurement = read(simulation)
    camera = (camera_from_argument(args.camera, command="compare") if args.camera else None)
    result = compare(recording, measurement, camera, frame=args.frame, shift=args.shift,
                     scale=args.scale)
    stats = result.statistics()
    out = OutputFolder(Path(args.out), overwrite=args.overwrite,
                       inputs=(args.recording, simulation))
    completed = False
    try:
        write_netcdf(out.staging / "comparison.nc", result.to_xarray(args.command_line))
        save_figure(result.figure(), out.staging / "comparison.png")
        out.commit()
        completed = True
    finally:
        if not completed:
            out.abandon(keep=False)
    print(f"{recording.path.name} frame {args.frame} beside {simulation.name}: shift "
          f"{stats['shift_rows']:+.2f}, {stats['shift_columns']:+.2f} px, {stats['pixels']} "
          "pixels in common")
    print(f"  recorded − simulated: mean {stats['mean_K']:+.2f} K, σ {stats['std_K']:.2f} K, "
          f"5–95 % {stats['p5_K']:+.2f} to {stats['p95_K']:+.2f} K; "
          f"{100 * stats['within_uncertainty']:.1f} % within {result.coverage:g} × the "
          "simulation's uncertainty")
    print(f"wrote {out.path / 'comparison.nc'}, comparison.png")
    return 0


def add_compare_parser(sub) -> None:
    """Add ``compare`` to the command's subparsers."""
    cmp = sub.add_parser("compare", help="a recording beside a simulated measurement",
                         description="Register a simulated measurement (a .nc or .exr of "
                         "radiosim measure) on a frame of a recording (sub-pixel, by phase "
                         "correlation and least squares), and write the recorded and "
                         "simulated images, their difference and its statistics "
                         "(comparison.nc, comparison.png) into a new or empty folder.")
    cmp.add_argument("recording", help="a .ptw, .fff or .seq recording")
    cmp.add_argument("simulation", help="a simulated measurement (.nc or .exr)")
    cmp.add_argument("--out", required=True, help="a new or empty folder")
    cmp.add_argument("--overwrite", action="store_true",
                     help="replace the files of radiosim's previous comparison in --out")
    cmp.add_argument("--camera", help="the camera that calibrates a recording without its own "
                     "calibration (.ptw)")
    cmp.add_argument("--frame", type=int, default=0, help="the recording's frame (default 0)")
    cmp.add_argument("--shift", type=_shift, default=None, metavar="ROWS,COLUMNS",
                     help="use this shift [pixels] instead of registering")
    cmp.add_argument("--scale", type=float, default=None,
                     help="the simulation's pixel over the recording's, in object space")
    cmp.set_defaults(func=_compare)


def _read_measurement(path):
    from pathlib import Path

    from radiosim.errors import RadiosimError

    path = Path(path)
    if path.suffix.lower() == ".nc":
        from radiosim.io.netcdf import read_netcdf

        return read_netcdf(path)
    if path.suffix.lower() == ".exr":
        from radiosim.io.exr import read_exr

        return read_exr(path)
    raise RadiosimError(f"{path}: a measurement is a .nc or .exr file (radiosim measure --out)")


def _correct(args) -> int:
    from pathlib import Path

    import numpy as np
    import xarray as xr

    from radiosim.cli_checks import check_out_file
    from radiosim.correction import correct
    from radiosim.io.netcdf import write_netcdf

    from radiosim.errors import RadiosimError
    from radiosim.io.recordings import RECORDING_READERS

    check_out_file(args, ".nc", "the corrected reading is a NetCDF file")
    if Path(args.measurement).suffix.lower() in RECORDING_READERS:
        from radiosim.cli_checks import camera_from_argument
        from radiosim.io.recordings import read_recording

        if args.camera is None:
            raise RadiosimError(f"{args.measurement}: a recording is corrected through a "
                                "camera fitted to it, with its PSF: give --camera FILE")
        recording = read_recording(args.measurement)
        camera = camera_from_argument(args.camera, command="correct")
        bad = None
        if args.replace_defects:  # from the frames around the one corrected, not all of them
            index = int(recording.frame_indices([args.frame])[0])
            near = slice(max(0, index - 8), index + 8)
            bad = recording.defect_pixels(near).any
        measurement = recording.measurement(camera, frame=args.frame, bad_pixels=bad,
                                            integration_time=args.integration_time)
    else:
        if (args.camera is not None or args.frame != 0 or args.replace_defects
                or args.integration_time is not None):
            raise RadiosimError(f"{args.measurement}: --camera, --frame, --integration-time "
                                "and --replace-defects apply to a recording; a measurement "
                                "carries its camera and window")
        measurement = _read_measurement(args.measurement)
    result = correct(measurement, velocity=args.velocity)
    dims = ("y", "x")
    dataset = xr.Dataset(
        {"apparent_temperature": (dims, measurement.apparent_temperature,
                                  {"units": "K", "long_name": "the camera's reading"}),
         "corrected_temperature": (dims, result.temperature,
                                   {"units": "K", "long_name": "reading corrected for the "
                                    "camera's blur" + (" and motion" if args.velocity else "")}),
         "uncertainty": (dims, result.uncertainty,
                         {"units": "K", "long_name": "standard uncertainty of the correction"})},
        attrs={"Conventions": "CF-1.10", "history": args.command_line,
               "source": str(Path(args.measurement))})
    path = write_netcdf(args.out, dataset)
    trusted = np.isfinite(result.temperature)
    change = (result.temperature - measurement.apparent_temperature)[trusted]
    print(f"{Path(args.measurement).name}: {int(trusted.sum())} of {trusted.size} pixels "
          f"corrected" + (f", by {np.median(change):+.2f} K (median) up to "
                          f"{change[np.argmax(np.abs(change))]:+.1f} K; median uncertainty "
                          f"{np.median(result.uncertainty[trusted]):.2f} K" if change.size
                          else ""))
    print(f"wrote {path}")
    return 0


def add_correct_parser(sub) -> None:
    """Add ``correct`` to the command's subparsers."""
    from radiosim.units import parse_time

    cor = sub.add_parser("correct", help="a measurement's reading corrected for its camera's "
                         "blur (and a known motion), with its uncertainty",
                         description="Correct a simulated or recorded measurement (a .nc or "
                         ".exr of radiosim measure) for its camera's optical blur and, with "
                         "--velocity, a uniform motion over its window, in the calibrated "
                         "object signal (a Wiener filter); write the reading, the corrected "
                         "temperature and its uncertainty to a new NetCDF file. A camera's "
                         "recording (.ptw, .seq, .fff, .jpg, .tif) is read through --camera "
                         "(fitted to it, with its PSF).")
    cor.add_argument("measurement", help="a measurement (.nc or .exr) or a recording")
    cor.add_argument("--camera", default=None, metavar="FILE",
                     help="a recording's camera (a camera TOML file or preset with its PSF)")
    cor.add_argument("--frame", type=int, default=0, metavar="K",
                     help="the recording's frame to correct (default 0)")
    cor.add_argument("--integration-time", type=parse_time, default=None, metavar="T",
                     help="a recording's integration time, for a file that states none "
                     "(e.g. 10us)")
    cor.add_argument("--replace-defects", action="store_true",
                     help="replace the recording's defect pixels (EMVA 1288 rules, on the 16 "
                     "frames around --frame) by their good neighbours' median first")
    _out_file(cor, "a new .nc file")
    cor.add_argument("--velocity", type=_shift, default=None, metavar="VX,VY",
                     help="the scene's uniform velocity in object space [m/s], x along the "
                     "columns, y down the rows")
    cor.set_defaults(func=_correct)

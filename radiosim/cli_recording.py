"""
``radiosim recording``: what a camera recorded, read by :func:`radiosim.io.read_recording`.

-   ``radiosim recording info FILE``: the file's metadata as a table.
-   ``radiosim recording export FILE --out T.nc|T.exr [--camera C] [--frames A:B]``: its
    temperatures (through the file's own calibration, or a radiosim camera's at the
    recording's integration time and housing temperature) with their provenance, in a new file.
"""

from __future__ import annotations

__all__ = ["add_recording_parser"]


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
    export.add_argument("--out", required=True, help="a new .nc or .exr file")
    export.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    export.add_argument("--camera", help="preset name or camera TOML (fitted to this camera)")
    export.add_argument("--frames", type=_frames, default=None, metavar="A:B",
                        help="frames to export: K or A:B (default all; an EXR: frame 0)")
    export.set_defaults(func=_export)

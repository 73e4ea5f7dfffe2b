"""
The ``radiosim`` command's checks of its arguments, before any work, each refusal in the
command's words: the options as the user typed them (``--dx 0.5nm``), the files named.

:mod:`radiosim.cli` runs the commands; these are what it asks of their arguments first: a
camera from the command line (a preset, ``linear-ideal`` or a TOML file), a scene reader's
refusal said with the options, scales a thousandth of the scene's (a unit slip), an output
file, an integration time past the camera's frame period and a Dask scheduler address. Nothing
heavy is imported at the top: ``radiosim --help`` loads none of it.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from radiosim.errors import RadiosimError
from radiosim.units import readable_time, typed as _typed

if TYPE_CHECKING:
    from radiosim.camera import Camera

__all__ = ["scene_refusal", "check_scale", "check_out_file", "camera_from_argument", "from_file",
           "check_frame_period_option", "PROTOCOLS", "check_scheduler"]


#: read_scene's keywords as the command's options.
_SCENE_OPTIONS = {"dt": "--dt", "dx": "--dx", "units": "--units", "time_unit": "--time-unit",
                  "length_unit": "--length-unit", "fill": "--fill"}


def scene_refusal(exc, args) -> str:
    """radiosim.io.read_scene's refusal (SceneArgumentError) in the command's words: its
    options, with their values as typed."""
    path = exc.path
    if exc.reason == "mesh":
        return (f"{path}: FEA meshes are read in Python, with their times and units: "
                "radiosim.io.read_fea_mesh (docs/howto.md); radiosim measure takes .npy/.npz "
                "stacks, EXR frames or a nodal .csv")
    if exc.reason == "not-taken" and exc.keywords == ("fill",):
        return (f"--fill {_typed(args.fill, 'K')}: {path} is not an FEA nodal .csv; a stack or "
                "EXR frames cover the whole field (expected --fill only with a .csv, for the "
                "points outside the mesh)")
    if exc.reason == "not-taken":
        given = [f"{_SCENE_OPTIONS[k]} {getattr(args, k)}" for k in exc.keywords]
        return (f"{' and '.join(given)}: {path} is not an FEA nodal .csv; the units of its "
                "frames are --dt, --dx and --units (expected --time-unit and --length-unit only "
                "with a .csv)")
    if exc.reason == "missing":
        missing = [_SCENE_OPTIONS[k] for k in exc.keywords]
        return (f"{path}: give {', '.join(missing)} (the file does not state "
                f"{'them' if len(missing) > 1 else 'it'}; e.g. --dt 0.2us --dx 0.5um --units C)")
    if exc.reason == "units":
        return (f"{path}: give the units on the command line with --time-unit, --length-unit "
                "and --units (or a header line '# units: time=…, length=…, temperature=…')")
    return str(exc)


def check_scale(args, scene, camera: Camera):
    """The measurement's scales against the scene's, with the options the user typed: a pixel
    or a window a thousandth of a sample or of a frame (or smaller) is a unit slip, and the
    message names the quantities involved (the library's check cannot know which was typed)."""
    from radiosim.integrator import IMPLAUSIBLE_RATIO

    pitch, t_int = camera.fpa.pixel_pitch, args.integration_time
    if pitch / scene.dx <= IMPLAUSIBLE_RATIO:
        pitch_text = (f"--pixel-pitch {_typed(args.pixel_pitch, 'm')}" if args.pixel_pitch
                      is not None else f"{camera.name}'s pixel pitch {pitch * 1e6:g} µm")
        dx_text = (f"--dx {_typed(args.dx, 'm')}" if args.dx is not None
                   else f"the scene's sample pitch {scene.dx * 1e6:g} µm")
        raise RadiosimError(
            f"{pitch_text} is {pitch / scene.dx:.2g} of {dx_text}: a pixel would see a "
            f"fraction of one sample; expected a pitch ≥ {IMPLAUSIBLE_RATIO:g} × dx. Is one "
            "of them in the wrong unit (µm given as nm, or as m)?")
    if t_int / scene.dt <= IMPLAUSIBLE_RATIO:
        dt_text = (f"--dt {_typed(args.dt)}" if args.dt is not None
                   else f"the scene's frame interval {scene.dt * 1e6:g} µs")
        raise RadiosimError(
            f"--integration-time {_typed(t_int)} is {t_int / scene.dt:.2g} of {dt_text}: the "
            f"window would see a fraction of one frame; expected at least "
            f"{IMPLAUSIBLE_RATIO:g} × dt. Is one of them in the wrong unit (µs given as ns, "
            "or as s)?")


def check_out_file(args, suffix, what: str):
    """``--out`` of a command that writes one file: the right suffix (``suffix``: one, or a
    tuple of those it can write), and a new file unless ``--overwrite`` (checked before any
    work)."""
    if args.out is None:
        return
    suffixes = (suffix,) if isinstance(suffix, str) else tuple(suffix)
    if Path(args.out).suffix.lower() not in suffixes:
        raise RadiosimError(f"--out {args.out}: {what}; give a path ending in "
                            f"{' or '.join(suffixes)}")
    from radiosim.files import check_output_file

    check_output_file(args.out)  # its folder, and a name the file system takes
    if Path(args.out).exists() and not args.overwrite:
        raise RadiosimError(f"--out {args.out} exists; choose a new name or pass --overwrite")


def camera_from_argument(name: str, pixel_pitch: float | None = None,
                         command: str | None = None) -> Camera:
    """A camera from the command line: a preset name, linear-ideal (with a pitch) or a TOML.
    ``command``: the subcommand, when it has no ``--pixel-pitch`` option."""
    from radiosim.camera import Camera, available_presets  # heavy: not for --help

    if name == "linear-ideal":
        if command is not None:
            raise RadiosimError(
                f"radiosim {command} takes a camera preset ({', '.join(available_presets())}) "
                "or a camera TOML file, not linear-ideal (an ideal camera of any pitch, "
                "for radiosim measure --pixel-pitch)")
        if pixel_pitch is None:
            raise RadiosimError("the linear-ideal camera needs --pixel-pitch (e.g. 6um)")
        return Camera.linear_ideal(pixel_pitch)
    camera = (from_file(name, "camera file", Camera.from_toml) if name.endswith(".toml")
              else Camera.preset(name))
    return camera if pixel_pitch is None else camera.with_pixel_pitch(pixel_pitch)


def from_file(path, what: str, load):
    """``load(path)``, with the file named in any error whose message does not name it."""
    path = Path(path)
    if not path.is_file():
        raise RadiosimError(f"{path}: no such {what}" if not path.exists()
                            else f"{path} is not a file (expected a {what}, TOML)")
    try:
        return load(path)
    except RadiosimError as exc:
        message = str(exc)
        if str(path) in message or path.name in message:
            raise
        raise type(exc)(f"{path}: {message}") from None


def check_frame_period_option(camera: Camera, args, default: float | None = None):
    """:meth:`Camera.window`'s rule, before the work: the integration with its readout fits in
    a frame; an ``--integration-time`` not given is set to ``default`` [s] first."""
    from radiosim.acquisition import check_frame_period

    said = "" if args.integration_time is not None else " (the default)"
    t_int = args.integration_time = default if said else args.integration_time  # [s]
    given = readable_time(t_int) if said else _typed(t_int)
    check_frame_period(camera, t_int, f"--integration-time {given}{said}")


#: Dask protocols a scheduler address may use.
PROTOCOLS = ("tcp", "tls", "ucx", "inproc", "ws", "wss")


def check_scheduler(address):
    """``--scheduler``: synchronous, threads or PROTOCOL://HOST:PORT, checked before any work
    (a malformed address would otherwise fail deep inside distributed)."""
    import re

    if address is None or address in ("synchronous", "sync", "threads"):
        return
    match = re.fullmatch(r"([a-z]+)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+)(?::([0-9]+))?",
                         address)
    problem = None
    if not match:
        problem = "not synchronous, threads nor an address PROTOCOL://HOST:PORT"
    elif match.group(1) not in PROTOCOLS:
        problem = f"unknown protocol {match.group(1)!r} (expected {', '.join(PROTOCOLS)})"
    elif match.group(3) is not None and not 0 < int(match.group(3)) < 65536:
        problem = f"port {match.group(3)} is outside 1-65535"
    if problem:
        source = "" if address != os.environ.get("RADIOSIM_SCHEDULER") else \
            " (from $RADIOSIM_SCHEDULER)"
        raise RadiosimError(f"--scheduler {address!r}{source}: {problem}; expected "
                            "synchronous, threads or e.g. tcp://127.0.0.1:8786")

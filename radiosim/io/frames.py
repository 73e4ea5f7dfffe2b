"""
Frame stacks from NumPy files (memory-mapped) and EXR sequences (one file per frame).
"""

from __future__ import annotations

import glob
import re
import warnings
import zipfile
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.files import why_not_a_file
from radiosim.scenes.base import Scene
from radiosim.scenes.exr_sequence import EXR_TEMPERATURE_CHANNELS, ExrSequence, temperature_unit
from radiosim.scenes.framestack import FrameStack

__all__ = ["read_frames", "ExrSequence", "EXR_TEMPERATURE_CHANNELS", "NO_TIME_UNIT"]


def _npz_member(path: Path, key: str | None):
    """A member of an .npz: memory-mapped if stored uncompressed, else loaded (with a
    warning)."""
    try:
        archive = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile) as exc:
        raise RadiosimError(f"{path} is not a readable .npz archive: {exc}") from exc
    with archive:
        names = [n[:-4] for n in archive.namelist() if n.endswith(".npy")]
        if key is None:
            if len(names) != 1:
                raise RadiosimError(f"{path} holds arrays {names}; say which with key=")
            key = names[0]
        if key not in names:
            raise RadiosimError(f"{path} has no array {key!r}; it holds {names}")
        info = archive.getinfo(key + ".npy")
        if info.compress_type == zipfile.ZIP_STORED:
            with archive.open(info) as member:
                try:
                    version = np.lib.format.read_magic(member)
                    read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                                   else np.lib.format.read_array_header_2_0)
                    shape, fortran, dtype = read_header(member)
                except Exception as exc:  # tokenize, ast or numpy on a damaged header
                    first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                    raise RadiosimError(f"{path}: the header of its array {key!r} is "
                                        f"damaged ({first})") from None
                header_length = member.tell()
            with open(path, "rb") as raw:  # the member's data start in the archive
                raw.seek(info.header_offset + 26)
                name_length, extra_length = np.frombuffer(raw.read(4), dtype="<u2")
            start = info.header_offset + 30 + int(name_length) + int(extra_length)
            return np.memmap(path, dtype=dtype, mode="r", offset=start + header_length,
                             shape=shape, order="F" if fortran else "C")
    warnings.warn(f"{path}: array {key!r} is compressed and is loaded whole into memory; save "
                  "with np.savez (not savez_compressed) to have it memory-mapped",
                  RadiosimWarning, stacklevel=3)
    with np.load(path) as data:
        return data[key]


def _npy(path: Path) -> np.ndarray:
    """A ``.npy`` file, memory-mapped, or an error that says what the file is instead."""
    try:
        with open(path, "rb") as handle:
            start = handle.read(6)
    except OSError as exc:
        raise RadiosimError(f"cannot read {path}: {exc.strerror or exc}") from None
    if not start:
        raise RadiosimError(f"{path} is empty (0 bytes); expected a NumPy .npy stack")
    if start != b"\x93NUMPY":
        raise RadiosimError(f"{path} is not a NumPy .npy file (it starts with {start!r}, not the "
                            "NumPy magic '\\x93NUMPY'); save the stack with numpy.save")
    _check_length(path)
    try:
        stack = np.load(path, mmap_mode="r")
    except ValueError as exc:
        if "pickle" in str(exc).lower() or "object" in str(exc).lower():
            raise RadiosimError(f"{path} holds Python objects, not numbers; expected a numeric "
                                "(frames, rows, columns) stack") from None
        raise RadiosimError(f"{path} is truncated or damaged: {exc}") from None
    except (OSError, EOFError) as exc:
        raise RadiosimError(f"{path} is truncated or damaged: {exc}") from None
    return stack


def _check_length(path: Path) -> None:
    """A ``.npy`` file at least as long as its header says (its header's length plus rows ×
    columns × frames × item size): a shorter one raises, naming both byte counts, before it is
    memory-mapped (reading past a mapped file's end kills the process with SIGBUS)."""
    try:
        with open(path, "rb") as handle:
            version = np.lib.format.read_magic(handle)
            read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                           else np.lib.format.read_array_header_2_0)
            shape, _, dtype = read_header(handle)
            start = handle.tell()
    except (OSError, EOFError) as exc:
        raise RadiosimError(f"{path} is truncated or damaged: {exc}") from None
    except Exception as exc:  # numpy parses the header with tokenize and ast: any error
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise RadiosimError(f"{path}: its .npy header is damaged ({first}); save the stack "
                            "again with numpy.save") from None
    if dtype.hasobject:
        return
    expected = start + int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    actual = path.stat().st_size
    if actual < expected:
        raise RadiosimError(f"{path} is truncated: its header describes a {shape} {dtype} "
                            f"stack of {expected} bytes, the file has {actual} bytes")


def _natural_key(path: Path):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", path.name)]


#: Formats whose frame interval is a number of seconds with no time axis of its own: a
#: time unit (the command's --time-unit, for FEA files) means nothing for them.
NO_TIME_UNIT = (*FrameStack.SUFFIXES, *ExrSequence.SUFFIXES)


def read_frames(path, dt=None, dx=None, units=None, key=None, channel=None, emissivity=1.0,
                event_time=None, time_unit=None, length_unit=None) -> Scene:
    """
    A scene from a NumPy stack or an EXR frame sequence.

    Parameters
    ----------
    path
        ``.npy`` (frames, rows, columns), ``.npz`` (one array, or name it with ``key``), a
        folder of ``.exr`` files, or a glob pattern of them (``"run/frame_*.exr"``); EXR files
        are ordered by the numbers in their names.
    dt, dx
        Frame interval [s] and sample pitch [m]; required for NumPy files, optional for EXR
        (header attributes ``dt_s``, ``dx_m``).
    units
        ``"K"`` or ``"C"``: required for NumPy files, optional for EXR (header attribute
        ``temperature_unit``).
    key, channel
        The array in an ``.npz``; the temperature channel of the EXR files.
    emissivity, event_time
        As for :class:`~radiosim.FrameStack`.
    time_unit, length_unit
        The command's ``--time-unit`` and ``--length-unit``, if the user gave them: these
        formats have no time or length axis whose unit could be stated (``dt`` and ``dx`` are
        in seconds and metres), so anything but ``None`` raises, naming the option.

    Returns
    -------
    Scene
        Frames are read one at a time (NumPy files are memory-mapped).
    """
    text = str(path)
    path = Path(path)
    for value, flag, axis, instead in ((time_unit, "--time-unit", "time", "--dt 0.2us"),
                                       (length_unit, "--length-unit", "length", "--dx 0.5um")):
        if value is not None:
            kind = ("a NumPy stack" if path.suffix.lower() in FrameStack.SUFFIXES
                    else "EXR frames")
            raise RadiosimError(f"{text}: {flag} {value} means nothing for {kind}: it has no "
                                f"{axis} axis whose unit could be stated; drop {flag} and give "
                                f"{instead.split()[0]} with its unit (e.g. {instead})")
    if path.suffix.lower() in FrameStack.SUFFIXES:
        why = why_not_a_file(path)
        if why is not None:
            raise RadiosimError(f"{path} is a folder, not a {path.suffix} file" if path.is_dir()
                                else f"{path} {why}")
        if units is None:
            raise RadiosimError(f"{path}: NumPy files carry no unit; give --units K or C "
                                "(units='K' or 'C' in Python)")
        units = temperature_unit(units, path)
        if dt is None or dx is None:
            raise RadiosimError(f"{path}: a NumPy stack carries no grid; give the frame interval "
                                "and sample pitch (--dt 0.2us --dx 0.5um; dt=, dx= [s, m] in "
                                "Python; dt_us, dx_um in a study)")
        if path.suffix.lower() == ".npy":
            stack = _npy(path)
        else:
            stack = _npz_member(path, key)
        try:
            return FrameStack(stack, dt, dx, emissivity=emissivity, event_time=event_time,
                              units=units, description={"source": str(path)})
        except RadiosimError as exc:
            raise RadiosimError(f"{path}: {exc}") from None
    if path.is_dir():
        files = sorted((f for suffix in ExrSequence.SUFFIXES for f in path.glob(f"*{suffix}")),
                       key=_natural_key)
    else:
        files = sorted((Path(p) for p in glob.glob(text)), key=_natural_key)
    if not files:
        raise RadiosimError(f"no frames found at {text} (expected .npy, .npz, a folder of .exr "
                            "files or a glob pattern)")
    if any(f.suffix.lower() not in ExrSequence.SUFFIXES for f in files):
        raise RadiosimError(f"{text}: mixed file types; expected only .exr frames")
    return ExrSequence(files, dt=dt, dx=dx, units=units, channel=channel, emissivity=emissivity,
                       event_time=event_time)

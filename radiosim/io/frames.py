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
from radiosim.scenes.base import Region, Scene, check_emissivity, check_positive
from radiosim.scenes.framestack import TEMPERATURE_OFFSETS, FrameStack

__all__ = ["read_frames", "ExrSequence", "EXR_TEMPERATURE_CHANNELS"]

#: Channel names read as temperature from EXR frames, in order of preference.
EXR_TEMPERATURE_CHANNELS = ("temperature", "T", "Y")
#: Header attributes that state the temperature unit of an EXR frame.
EXR_UNIT_ATTRIBUTES = ("temperature_unit", "units")


def _units(value, path) -> str:
    aliases = {"k": "K", "kelvin": "K", "c": "C", "°c": "C", "celsius": "C", "degc": "C"}
    unit = aliases.get(str(value).strip().lower())
    if unit is None:
        raise RadiosimError(f"{path}: temperature unit {value!r} is not K or C")
    return unit


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
                version = np.lib.format.read_magic(member)
                read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                               else np.lib.format.read_array_header_2_0)
                shape, fortran, dtype = read_header(member)
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


class ExrSequence(Scene):
    """
    Temperature frames from a sequence of EXR files, one per frame, read one at a time.

    Parameters
    ----------
    paths
        The frame files in time order.
    dt, dx
        Frame interval [s] and sample pitch [m]; ``None``: from the first file's header
        attributes ``dt_s`` and ``dx_m``.
    units
        ``"K"`` or ``"C"``; ``None``: from the header attribute ``temperature_unit`` (or
        ``units``).
    channel
        Temperature channel; ``None``: the first of :data:`EXR_TEMPERATURE_CHANNELS` present.
    emissivity
        As for :class:`~radiosim.FrameStack`.
    """

    def __init__(self, paths, dt=None, dx=None, units=None, channel=None, emissivity=1.0,
                 event_time=None):
        import OpenEXR  # optional at import time of radiosim; required here

        self._exr = OpenEXR
        self.paths = [Path(p) for p in paths]
        if not self.paths:
            raise RadiosimError("no EXR frames given")
        header, channels = self._open(0)
        if channel is None:
            channel = next((c for c in EXR_TEMPERATURE_CHANNELS if c in channels), None)
            if channel is None:
                raise RadiosimError(f"{self.paths[0]}: no temperature channel (looked for "
                                    f"{', '.join(EXR_TEMPERATURE_CHANNELS)}; it has "
                                    f"{', '.join(channels)})")
        self.channel = channel
        if units is None:
            stated = next((header[a] for a in EXR_UNIT_ATTRIBUTES if a in header), None)
            if stated is None:
                raise RadiosimError(f"{self.paths[0]}: the header states no temperature unit "
                                    "(attribute temperature_unit); pass units='K' or 'C'")
            units = stated
        self.units = _units(units, self.paths[0])
        self.dt = check_positive(dt if dt is not None else header.get("dt_s"), "dt", "s")
        self.dx = check_positive(dx if dx is not None else header.get("dx_m"), "dx", "m")
        self.shape = self._pixels(0, channels).shape
        self.n_frames = len(self.paths)
        self.emissivity = check_emissivity(emissivity, self.shape)
        self.event_time = event_time

    def _open(self, k):
        path = self.paths[k]
        try:
            with self._exr.File(str(path)) as exr:
                # The bindings release the pixels when the file closes: copy them out.
                return dict(exr.header()), {name: np.array(channel.pixels)
                                            for name, channel in exr.channels().items()}
        except Exception as exc:  # the bindings raise RuntimeError for unreadable files
            raise RadiosimError(f"frame {k}: cannot read EXR file {path}: {exc}") from None

    def _pixels(self, k, channels):
        if self.channel not in channels:
            raise RadiosimError(f"frame {k}: {self.paths[k]} has no channel {self.channel!r}")
        pixels = channels[self.channel]
        if pixels.ndim != 2:
            raise RadiosimError(f"frame {k}: channel {self.channel!r} of {self.paths[k]} is not "
                                f"a single-component image (shape {pixels.shape})")
        return pixels

    def _read(self, k: int, region: Region) -> np.ndarray:
        pixels = self._pixels(k, self._open(k)[1])
        if pixels.shape != self.shape:
            raise RadiosimError(f"frame {k}: {self.paths[k]} is {pixels.shape}, the first frame "
                                f"is {self.shape}")
        return pixels[region[0], region[1]].astype(np.float64) + TEMPERATURE_OFFSETS[self.units]

    def describe(self) -> dict:
        return super().describe() | {"source": str(self.paths[0].parent),
                                     "source_units": self.units, "channel": self.channel}


def _natural_key(path: Path):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", path.name)]


def read_frames(path, dt=None, dx=None, units=None, key=None, channel=None, emissivity=1.0,
                event_time=None) -> Scene:
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

    Returns
    -------
    Scene
        Frames are read one at a time (NumPy files are memory-mapped).
    """
    text = str(path)
    path = Path(path)
    if path.suffix.lower() in (".npy", ".npz"):
        if not path.is_file():
            raise RadiosimError(f"{path} does not exist")
        if units is None:
            raise RadiosimError(f"{path}: NumPy files carry no unit; pass units='K' or 'C'")
        units = _units(units, path)
        if dt is None or dx is None:
            raise RadiosimError(f"{path}: pass dt [s] and dx [m] for a NumPy stack")
        if path.suffix.lower() == ".npy":
            try:
                stack = np.load(path, mmap_mode="r")
            except (OSError, ValueError) as exc:
                raise RadiosimError(f"{path} is not a readable .npy file: {exc}") from exc
        else:
            stack = _npz_member(path, key)
        return FrameStack(stack, dt, dx, emissivity=emissivity, event_time=event_time,
                          units=units, description={"source": str(path)})
    if path.is_dir():
        files = sorted(path.glob("*.exr"), key=_natural_key)
    else:
        files = sorted((Path(p) for p in glob.glob(text)), key=_natural_key)
    if not files:
        raise RadiosimError(f"no frames found at {text} (expected .npy, .npz, a folder of .exr "
                            "files or a glob pattern)")
    if any(f.suffix.lower() != ".exr" for f in files):
        raise RadiosimError(f"{text}: mixed file types; expected only .exr frames")
    return ExrSequence(files, dt=dt, dx=dx, units=units, channel=channel, emissivity=emissivity,
                       event_time=event_time)

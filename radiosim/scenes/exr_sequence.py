"""
A scene from a sequence of EXR files, one temperature frame per file, read one at a time.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.files import native_output_silenced
from radiosim.scenes.base import Region, Scene, check_emissivity, check_grid
from radiosim.units import to_kelvin

__all__ = ["ExrSequence", "EXR_TEMPERATURE_CHANNELS", "EXR_UNIT_ATTRIBUTES", "temperature_unit",
           "check_numbering"]

#: Channel names read as temperature from EXR frames, in order of preference.
EXR_TEMPERATURE_CHANNELS = ("temperature", "T", "Y")
#: Header attributes that state the temperature unit of an EXR frame.
EXR_UNIT_ATTRIBUTES = ("temperature_unit", "units")
#: Relative difference within which two header values (or a header's and the caller's) agree:
#: a float attribute holds 32 bits (a relative rounding of 6e-8).
_AGREE = 1e-6


def temperature_unit(value, path) -> str:
    aliases = {"k": "K", "kelvin": "K", "c": "C", "°c": "C", "celsius": "C", "degc": "C"}
    unit = aliases.get(str(value).strip().lower())
    if unit is None:
        raise RadiosimError(f"{path}: temperature unit {value!r} is not K or C")
    return unit



def _stated_unit(header: dict, path):
    """The temperature unit a header states (K or C), ``None`` if none; two attributes
    that disagree raise."""
    found = [(a, temperature_unit(header[a], f"{path}: attribute {a!r}"))
             for a in EXR_UNIT_ATTRIBUTES if a in header]
    if len(found) == 2 and found[0][1] != found[1][1]:
        raise RadiosimError(f"{path}: header attributes {found[0][0]!r} = {found[0][1]!r} and "
                            f"{found[1][0]!r} = {found[1][1]!r} disagree")
    return found[0][1] if found else None


def _number(header: dict, name: str, path):
    """A numeric header attribute as a float, ``None`` if absent."""
    value = header.get(name)
    if isinstance(value, np.ndarray) and value.size == 1:
        value = value.item()
    if value is None:
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        raise RadiosimError(f"{path}: header attribute {name!r} is {value!r}, not a "
                            "number") from None


def _agree(paths, headers, key: str, value_of) -> None:
    """Every frame's ``key`` (by ``value_of(header, path)``) equals the first frame's; the
    first that differs raises, naming both files and both values. Unreadable headers
    (``None``) are skipped here: reading that frame names the file."""
    first = value_of(headers[0], paths[0])
    for k in range(1, len(paths)):
        if headers[k] is None:
            continue
        value = value_of(headers[k], paths[k])
        same = (value == first if not isinstance(first, float) or not isinstance(value, float)
                else abs(value - first) <= _AGREE * max(abs(value), abs(first)))
        if not same:
            raise RadiosimError(f"{paths[k]}: {key} is {_shown(value)}, but {paths[0]} has "
                                f"{_shown(first)}; the frames of one sequence must agree")


def _shown(value) -> str:
    return "not stated" if value is None else repr(value)


_NUMBER = re.compile(r"(\d+)(?!.*\d)")


def check_numbering(paths) -> None:
    """
    The frame numbers in the files' names (the last number in each name) are distinct and
    evenly spaced: a duplicate (``frame_1.exr``, ``frame_01.exr``) or a missing number raises,
    naming the files. Names without a number are not checked.
    """
    numbered = []
    for path in paths:
        match = _NUMBER.search(Path(path).stem)
        if match is None:
            return
        numbered.append((int(match.group(1)), Path(path)))
    seen = {}
    for number, path in numbered:
        if number in seen:
            raise RadiosimError(f"{path}: frame number {number} is also that of {seen[number]}; "
                                "one file per frame number")
        seen[number] = path
    ordered = sorted(numbered, key=lambda item: item[0])
    if len(ordered) < 3:
        return
    step = min(b[0] - a[0] for a, b in zip(ordered, ordered[1:]))
    for (a, path_a), (b, path_b) in zip(ordered, ordered[1:]):
        if b - a != step:
            raise RadiosimError(f"{path_b}: frame number {a + step} is missing between "
                                f"{path_a.name} and {path_b.name} (the frames are numbered in "
                                f"steps of {step})")


def _attribute(header: dict, name: str, given, flag: str, path) -> float:
    """A grid attribute: the caller's value (which must agree with the header's, if it states
    one), else the header's (float or double), else an error naming the attribute, the file
    and the flag that supplies it."""
    value = _number(header, name, path)
    if given is not None:
        try:
            mine = float(given)
        except (TypeError, ValueError):
            return given  # check_grid names it
        if value is not None and abs(mine - value) > _AGREE * max(abs(mine), abs(value)):
            raise RadiosimError(f"{path}: {flag.split(' / ')[1]}{mine:g} ({flag.split(' / ')[0]}) "
                                f"contradicts the header's {name} = {value:g}; drop "
                                f"{flag.split(' / ')[0]} or correct the files")
        return given
    if value is None:
        raise RadiosimError(f"{path}: the header has no attribute {name!r}; give it with "
                            f"{flag} (e.g. {flag.split(' / ')[0]} "
                            f"{'0.2us' if name == 'dt_s' else '0.5um'})")
    return value


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

    #: The files it is read from (:func:`radiosim.io.read_frames`: a folder or glob of them).
    SUFFIXES = (".exr",)

    def __init__(self, paths, dt=None, dx=None, units=None, channel=None, emissivity=1.0,
                 event_time=None):
        import OpenEXR  # optional at import time of radiosim; required here

        self._exr = OpenEXR
        self.paths = [Path(p) for p in paths]
        if not self.paths:
            raise RadiosimError("no EXR frames given")
        check_numbering(self.paths)
        header, channels = self._open(0)
        headers = [header] + [self._header(k) for k in range(1, len(self.paths))]
        if channel is None:
            channel = next((c for c in EXR_TEMPERATURE_CHANNELS if c in channels), None)
            if channel is None:
                raise RadiosimError(f"{self.paths[0]}: no temperature channel (looked for "
                                    f"{', '.join(EXR_TEMPERATURE_CHANNELS)}; it has "
                                    f"{', '.join(channels)})")
        self.channel = channel
        stated = _stated_unit(headers[0], self.paths[0])
        _agree(self.paths, headers, "temperature unit",
               lambda h, path: _stated_unit(h, path))
        for name in ("dt_s", "dx_m"):
            _agree(self.paths, headers, name, lambda h, path, name=name: _number(h, name, path))
        if units is not None:
            units = temperature_unit(units, "units")
            if stated is not None and stated != units:
                raise RadiosimError(f"{self.paths[0]}: units={units!r} (--units) contradicts "
                                    f"the header's temperature_unit {stated!r}; drop --units "
                                    "or correct the files")
        elif stated is None:
            raise RadiosimError(f"{self.paths[0]}: the header states no temperature unit "
                                "(attribute temperature_unit); give --units K or C "
                                "(units='K' or 'C' in Python)")
        self.units = units or stated
        self.dx, self.dt = check_grid(
            _attribute(header, "dx_m", dx, "--dx / dx=", self.paths[0]),
            _attribute(header, "dt_s", dt, "--dt / dt=", self.paths[0]))
        self.shape = self._pixels(0, channels).shape
        self.n_frames = len(self.paths)
        self.emissivity = check_emissivity(emissivity, self.shape)
        self.event_time = event_time

    def _header(self, k) -> dict | None:
        """The header of frame ``k``, without its pixels; ``None`` if unreadable (reading the
        frame then raises, naming the file)."""
        try:
            with native_output_silenced(), self._exr.File(str(self.paths[k]),
                                                          header_only=True) as exr:
                return dict(exr.header())
        except Exception:  # the bindings raise RuntimeError for unreadable files
            return None

    def _open(self, k):
        path = self.paths[k]
        try:
            with native_output_silenced(), self._exr.File(str(path)) as exr:
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
        return to_kelvin(pixels[region[0], region[1]].astype(np.float64), self.units)

    def describe(self) -> dict:
        return super().describe() | {"source": str(self.paths[0].parent),
                                     "source_units": self.units, "channel": self.channel}



"""
A scene from a sequence of EXR files, one temperature frame per file, read one at a time.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.files import native_output_silenced
from radiosim.scenes.base import Region, Scene, check_emissivity, check_grid
from radiosim.units import to_kelvin

__all__ = ["ExrSequence", "EXR_TEMPERATURE_CHANNELS", "EXR_UNIT_ATTRIBUTES", "temperature_unit"]

#: Channel names read as temperature from EXR frames, in order of preference.
EXR_TEMPERATURE_CHANNELS = ("temperature", "T", "Y")
#: Header attributes that state the temperature unit of an EXR frame.
EXR_UNIT_ATTRIBUTES = ("temperature_unit", "units")


def temperature_unit(value, path) -> str:
    aliases = {"k": "K", "kelvin": "K", "c": "C", "°c": "C", "celsius": "C", "degc": "C"}
    unit = aliases.get(str(value).strip().lower())
    if unit is None:
        raise RadiosimError(f"{path}: temperature unit {value!r} is not K or C")
    return unit



def _attribute(header: dict, name: str, given, flag: str, path) -> float:
    """A grid attribute: the caller's value, else the header's (float or double), else an
    error naming the attribute, the file and the flag that supplies it."""
    if given is not None:
        return given
    value = header.get(name)
    if isinstance(value, np.ndarray) and value.size == 1:  # a double, as radiosim writes them
        value = value.item()
    if value is None:
        raise RadiosimError(f"{path}: the header has no attribute {name!r}; give it with "
                            f"{flag} (e.g. {flag.split(' / ')[0]} "
                            f"{'0.2us' if name == 'dt_s' else '0.5um'})")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise RadiosimError(f"{path}: header attribute {name!r} is {value!r}, not a "
                            "number") from None


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
                                    "(attribute temperature_unit); give --units K or C "
                                    "(units='K' or 'C' in Python)")
            units = stated
        self.units = temperature_unit(units, self.paths[0])
        self.dx, self.dt = check_grid(
            _attribute(header, "dx_m", dx, "--dx / dx=", self.paths[0]),
            _attribute(header, "dt_s", dt, "--dt / dt=", self.paths[0]))
        self.shape = self._pixels(0, channels).shape
        self.n_frames = len(self.paths)
        self.emissivity = check_emissivity(emissivity, self.shape)
        self.event_time = event_time

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



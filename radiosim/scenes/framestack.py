"""
A scene from an array of temperature frames, in memory or memory-mapped.
"""

from __future__ import annotations

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.units import TEMPERATURE_OFFSETS, UNITS, to_kelvin
from radiosim.checks import check_non_negative
from radiosim.scenes.base import Region, Scene, check_emissivity, check_grid

__all__ = ["FrameStack"]


class FrameStack(Scene):
    """
    Temperature frames from an array shaped (frames, rows, columns) [K].

    The array may be a :func:`numpy.memmap` or ``np.load(..., mmap_mode="r")``: frames are read
    (and converted to float64) one at a time, over the region the camera sees, so the stack is
    never loaded whole. Values are checked as they are read: a NaN or a temperature ≤ 0 K raises
    an error naming the frame, row and column.

    Parameters
    ----------
    temperature
        Array (frames, rows, columns) of temperatures [K], any real dtype.
    dt
        Frame interval [s]; frame k holds over [k·dt, (k+1)·dt).
    dx
        Sample pitch in object space [m].
    emissivity
        Grey scalar in [0, 1], grey map (rows, columns), spectral curve, shipped curve name or
        CSV path.
    event_time
        Time [s] on which a measurement without a start time is centred; ``None``: windows
        without a start begin at t = 0.
    units
        ``"K"`` (default) or ``"C"``: the unit of the array's values, converted to kelvin as
        frames are read.
    description
        Extra metadata (str/int/float values) for :meth:`describe`, e.g. the source file.

    Examples
    --------
    >>> stack = FrameStack(np.full((10, 4, 6), 300.0), dt=0.2e-6, dx=1e-6)
    >>> stack.shape, stack.n_frames, stack.duration
    ((4, 6), 10, 2e-06)
    """

    def __init__(self, temperature, dt, dx, emissivity=1.0, event_time=None, units="K",
                 description=None):
        if not hasattr(temperature, "ndim") or not hasattr(temperature, "dtype"):
            temperature = np.asarray(temperature)
        if temperature.ndim != 3:
            raise RadiosimError(
                f"temperature must be a 3-D array (frames, rows, columns), got {temperature.ndim}"
                f"-D with shape {temperature.shape}"
            )
        if temperature.dtype.kind not in "fiu":  # floats and integers; no complex, bool,
            # timedelta, datetime, strings or objects
            raise RadiosimError(f"temperature must be real numbers, got dtype {temperature.dtype}")
        if min(temperature.shape) == 0:
            raise RadiosimError(f"temperature array is empty: shape {temperature.shape}")
        self._stack = temperature
        self.dx, self.dt = check_grid(dx, dt)
        self.n_frames = int(temperature.shape[0])
        self.shape = (int(temperature.shape[1]), int(temperature.shape[2]))
        self.emissivity = check_emissivity(emissivity, self.shape)
        if event_time is not None:
            event_time = check_non_negative(event_time, "event_time", "s")
            if not 0 <= event_time <= self.n_frames * self.dt:
                raise RadiosimError(
                    f"event_time {event_time:g} s is outside the stack (0 to "
                    f"{self.n_frames * self.dt:g} s)"
                )
        self.event_time = event_time
        if units not in TEMPERATURE_OFFSETS:
            raise RadiosimError(f"units must be one of {', '.join(TEMPERATURE_OFFSETS)}, "
                                f"got {units!r}")
        self.units = units
        self._extra = dict(description or {})

    def _read(self, k: int, region: Region) -> np.ndarray:
        values = self._stack[k, region[0], region[1]]
        if self.units == "K" and values.dtype in (np.float32, np.float64):
            return values  # as stored (a memory-mapped view): the consumer converts or checks
        return to_kelvin(np.asarray(values, dtype=np.float64), self.units)

    def block_unchecked(self, start: int, stop: int,
                        region: Region | None = None) -> np.ndarray | None:
        stack = self._stack
        if (self.units != "K" or not isinstance(stack, np.ndarray)
                or stack.dtype not in (np.float32, np.float64)
                or type(self)._read is not FrameStack._read
                or type(self)._sample is not Scene._sample):
            return None  # converted, lazily loaded, or frames a subclass makes its own way
        start, region = self._where(start, region)
        stop = int(stop)
        if not start < stop <= self.n_frames:
            raise RadiosimError(f"frames {start} to {stop - 1} are not a range of the scene's "
                                f"frames 0 to {self.n_frames - 1}")
        return stack[start:stop, region[0], region[1]]

    def describe(self) -> dict:
        return super().describe() | {"source_units": self.units} | self._extra

    @classmethod
    def from_xarray(cls, variable, dt: float | None = None, dx: float | None = None,
                    units: str | None = None, emissivity=1.0, event_time=None) -> FrameStack:
        """
        A stack from an xarray variable of dimensions (time, y, x) — lazily loaded from a
        NetCDF file or a zarr store (``xr.open_dataset(..., chunks=…)``, ``xr.open_zarr``):
        frames are read one at a time over the region the camera sees, never the whole.

        ``dt`` [s] and ``dx`` [m] default to the spacing of the ``time`` and ``x``
        coordinates (in seconds and metres, or with a ``units`` attribute of s/ms/us/ns,
        m/mm/um), ``units`` (K or C) to the variable's ``units`` attribute.
        """
        if getattr(variable, "ndim", None) != 3 or not hasattr(variable, "dims"):
            raise RadiosimError(f"need an xarray variable with 3 dimensions (time, y, x), got "
                                f"{type(variable).__name__}")

        def spacing(dim, given, kind):
            if given is not None:
                return given
            if dim not in variable.coords or variable.sizes[dim] < 2:
                raise RadiosimError(f"the variable has no {dim!r} coordinate to read d{dim} "
                                    f"from; pass {'dt' if kind == 'time' else 'dx'}")
            values = np.asarray(variable[dim].values, dtype=float)
            step = np.diff(values)
            if np.any(np.abs(step - step.mean()) > 1e-6 * abs(step.mean())):
                raise RadiosimError(f"the {dim!r} coordinate is not evenly spaced")
            unit = variable[dim].attrs.get("units", "s" if kind == "time" else "m")
            table = UNITS[kind]
            if unit.replace("µ", "u") not in table:
                raise RadiosimError(f"the {dim!r} coordinate's unit {unit!r} is not one of "
                                    f"{', '.join(table)}")
            return float(step.mean()) * 10.0 ** table[unit.replace("µ", "u")][0]

        time, y, x = variable.dims
        unit = units or variable.attrs.get("units", "K")
        unit = {"degC": "C", "°C": "C", "celsius": "C", "kelvin": "K"}.get(unit, unit)
        return cls(_LazyFrames(variable), spacing(time, dt, "time"), spacing(x, dx, "length"),
                   emissivity=emissivity, event_time=event_time, units=unit,
                   description={"source": f"xarray variable {variable.name!r}"})

    def __reduce__(self):
        """Pickled as a recipe where the frames are a file (a memory map: its path, offset,
        dtype and shape; another process maps the same file), else with its array."""
        stack = self._stack
        if isinstance(stack, np.memmap) and getattr(stack, "filename", None):
            frames = (_MappedFrames, (str(stack.filename), stack.offset, stack.dtype.str,
                                      stack.shape, "F" if stack.flags.f_contiguous
                                      and not stack.flags.c_contiguous else "C"))
        else:
            frames = (np.asarray, (stack,))
        state = {k: v for k, v in self.__dict__.items() if k != "_stack"}
        return (_rebuild_stack, (frames, state))


class _LazyFrames:
    """An xarray variable seen as an array of frames: indexing loads only what it asks for."""

    def __init__(self, variable):
        self.variable = variable
        self.ndim = 3
        self.shape = tuple(int(n) for n in variable.shape)
        self.dtype = np.dtype(variable.dtype)

    def __getitem__(self, key):
        return np.asarray(self.variable[key].values)


class _MappedFrames:
    """Re-opens a memory-mapped stack read-only from its recipe."""

    def __new__(cls, path, offset, dtype, shape, order):
        return np.memmap(path, dtype=np.dtype(dtype), mode="r", offset=offset, shape=shape,
                         order=order)


def _rebuild_stack(frames, state) -> FrameStack:
    build, arguments = frames
    out = FrameStack.__new__(FrameStack)
    out.__dict__.update(state)
    out._stack = build(*arguments)
    return out

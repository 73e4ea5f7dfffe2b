"""
A scene from an array of temperature frames, in memory or memory-mapped.
"""

from __future__ import annotations

import os

import numpy as np

from radiosim.errors import RadiosimError, RadiosimIOError
from radiosim.units import TEMPERATURE_OFFSETS, UNITS, readable_time, to_kelvin, CELSIUS_OFFSET
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

    #: The files it is read from (:func:`radiosim.io.read_frames`): NumPy stacks.
    SUFFIXES = (".npy", ".npz")

    def __init__(self, temperature, dt, dx, emissivity=1.0, event_time=None, units="K",
                 description=None):
        if not hasattr(temperature, "ndim") or not hasattr(temperature, "dtype"):
            try:
                temperature = np.asarray(temperature)
            except ValueError:  # numpy's "inhomogeneous shape": say where
                raise RadiosimError(f"temperature is a ragged nested list: {_ragged(temperature)}"
                                    "; expected equal-length frames, rows and columns") from None
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
                    f"event_time {readable_time(event_time)} is outside the stack (0 to "
                    f"{readable_time(self.n_frames * self.dt)})"
                )
        self.event_time = event_time
        if units not in TEMPERATURE_OFFSETS:
            raise RadiosimError(f"units must be one of {', '.join(TEMPERATURE_OFFSETS)}, "
                                f"got {units!r}")
        self.units = units
        self._extra = dict(description or {})

    def _check_mapped(self) -> None:
        """A memory-mapped stack's file still holds the whole stack: a file cut short while
        a run reads it raises :class:`~radiosim.errors.RadiosimIOError` naming it (and both
        byte counts), instead of the process dying of SIGBUS on the missing pages. One
        ``stat`` per read; a file cut between this check and the copy can still end the
        process."""
        stack = self._stack
        name = getattr(stack, "filename", None) if isinstance(stack, np.memmap) else None
        if name is None:
            return
        try:
            size = os.stat(name).st_size
        except OSError:
            return  # removed: the mapping keeps the pages
        needed = int(stack.offset) + int(stack.nbytes)
        if size < needed:
            raise RadiosimIOError(f"{name} was cut short while being read: it has {size} bytes, "
                                  f"the stack needs {needed}")

    def _read(self, k: int, region: Region) -> np.ndarray:
        self._check_mapped()
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
        self._check_mapped()
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
        frames are read over the region the camera sees, never the whole; a Dask-backed
        variable a time chunk at a time, in the reading thread (never through a cluster's
        scheduler), and the scene pickles as its variable's recipe (its file), so it can
        travel to a cluster's workers.

        Dimensions named ``time``/``t``, ``y``/``row``/``rows`` and ``x``/``column``/``columns``
        (or a time dimension with datetime64/timedelta64 values) are put in the order (time, y,
        x) by name, whatever their order in the variable; other names are read in the order
        (time, y, x).

        ``dt`` [s] and ``dx`` [m] default to the spacing of the time and x coordinates (in
        seconds and metres, or with a ``units`` attribute of s/ms/us/ns, m/mm/um; datetime64
        and timedelta64 times are converted to seconds), ``units`` (K or C) to the variable's
        ``units`` attribute, any CF unit of temperature (``K``, ``Kelvin``, ``degC``,
        ``degree_Celsius``…, by cf-units) read as kelvin or degrees Celsius. Coordinates must
        be evenly spaced (y increasing or decreasing: images often count rows from the top),
        the x and y spacings equal, and a given ``dt``/``dx`` must agree with the coordinates.
        """
        if getattr(variable, "ndim", None) != 3 or not hasattr(variable, "dims"):
            raise RadiosimError(f"need an xarray variable with 3 dimensions (time, y, x), got "
                                f"{type(variable).__name__}")
        name = f"xarray variable {variable.name!r}"
        variable = _time_y_x(variable, name)

        def coordinate(dim, kind, either_way=False):
            """The spacing of coordinate ``dim`` [s or m], or None if it has none
            (``either_way``: decreasing values too)."""
            if dim not in variable.coords or variable.sizes[dim] < 2:
                return None
            raw = np.asarray(variable[dim].values)
            if raw.dtype.kind in "mM":
                if kind != "time":
                    raise RadiosimError(f"{name}: the {dim!r} coordinate holds "
                                        f"{raw.dtype} values; expected lengths")
                values, unit = (raw - raw[0]) / np.timedelta64(1, "ns") * 1e-9, "s"
            else:
                try:
                    values = raw.astype(float)
                except (TypeError, ValueError):
                    raise RadiosimError(f"{name}: the {dim!r} coordinate holds {raw.dtype} "
                                        "values, not numbers") from None
                unit = str(variable[dim].attrs.get("units", "s" if kind == "time" else "m"))
            table = UNITS[kind]
            unit = unit.replace("\u00b5", "u").replace("\u03bc", "u")
            if unit not in table:
                raise RadiosimError(f"{name}: the {dim!r} coordinate's unit {unit!r} is not one "
                                    f"of {', '.join(table)}")
            step = np.diff(values) * 10.0 ** table[unit][0]
            if either_way and step[0] < 0:
                step = -step
            uneven = np.abs(step - step[0]) > 1e-6 * abs(step[0])
            if step[0] <= 0 or uneven.any():
                k = int(np.argmax(uneven)) if uneven.any() else 0
                raise RadiosimError(f"{name}: the {dim!r} coordinate is not evenly spaced and "
                                    f"increasing (from {dim}[0] to {dim}[1] it steps "
                                    f"{step[0]:g}, from {dim}[{k}] to {dim}[{k + 1}] {step[k]:g} "
                                    f"{'s' if kind == 'time' else 'm'})")
            return float(step.mean())

        def spacing(dim, given, kind, flag):
            found = coordinate(dim, kind)
            if given is None:
                if found is None:
                    raise RadiosimError(f"{name} has no {dim!r} coordinate to read d{dim} "
                                        f"from; pass {flag}")
                return found
            try:
                mine = float(given)
            except (TypeError, ValueError):
                return given  # the constructor names it
            if found is not None and abs(mine - found) > 1e-6 * abs(found):
                raise RadiosimError(f"{name}: {flag}={mine:g} contradicts its {dim!r} "
                                    f"coordinate's spacing {found:g} "
                                    f"{'s' if kind == 'time' else 'm'}")
            return given

        time, y, x = variable.dims
        dx = spacing(x, dx, "length", "dx")
        dy = coordinate(y, "length", either_way=True)
        if dy is not None and isinstance(dx, (int, float)) and abs(dy - dx) > 1e-6 * abs(dx):
            raise RadiosimError(f"{name}: its {y!r} spacing {dy:g} m differs from its {x!r} "
                                f"spacing {dx:g} m; a scene's samples are square (dx = dy)")
        unit = units or _temperature_unit(variable.attrs.get("units", "K"), name)
        return cls(_LazyFrames(variable), spacing(time, dt, "time", "dt"), dx,
                   emissivity=emissivity, event_time=event_time, units=unit,
                   description={"source": name})

    def __reduce__(self):
        """Pickled as a recipe where the frames are a file (a memory map: its path, offset,
        dtype and shape; another process maps the same file) or an xarray variable (which
        travels with the graph that reads its file), else with its array."""
        stack = self._stack
        if isinstance(stack, np.memmap) and getattr(stack, "filename", None):
            frames = (_MappedFrames, (str(stack.filename), stack.offset, stack.dtype.str,
                                      stack.shape, "F" if stack.flags.f_contiguous
                                      and not stack.flags.c_contiguous else "C"))
        elif isinstance(stack, _LazyFrames):  # the variable, not a 0-d object array of it
            frames = (_LazyFrames, (stack.variable,))
        else:
            frames = (np.asarray, (stack,))
        state = {k: v for k, v in self.__dict__.items() if k != "_stack"}
        return (_rebuild_stack, (frames, state))


_NAMES = {"time": ("time", "t"), "y": ("y", "row", "rows"), "x": ("x", "column", "columns",
                                                             "col", "cols")}


def _time_y_x(variable, name):
    """The variable with its dimensions in the order (time, y, x), found by name (or the time
    by its datetime values); unrecognised names keep their order."""
    role = {}
    for dim in variable.dims:
        kinds = [k for k, names in _NAMES.items() if str(dim).lower() in names]
        if not kinds and dim in variable.coords and \
                np.asarray(variable[dim].values).dtype.kind in "mM":
            kinds = ["time"]
        if kinds:
            if kinds[0] in role:
                raise RadiosimError(f"{name}: dimensions {role[kinds[0]]!r} and {dim!r} both "
                                    f"read as {kinds[0]}; expected (time, y, x)")
            role[kinds[0]] = dim
    if len(role) < 3:
        if role and any(variable.dims.index(d) != ("time", "y", "x").index(k)
                        for k, d in role.items()):
            raise RadiosimError(f"{name}: dimensions {variable.dims} are not in the order "
                                "(time, y, x) and cannot all be told apart by name; transpose "
                                "it (variable.transpose(time, y, x))")
        return variable
    order = (role["time"], role["y"], role["x"])
    return variable if tuple(variable.dims) == order else variable.transpose(*order)


def _ragged(nested) -> str:
    """Where a nested list stops being rectangular: the index path and the two lengths."""
    def walk(item, path):
        if not isinstance(item, (list, tuple)):
            return None
        lengths = [len(e) if isinstance(e, (list, tuple)) else None for e in item]
        first = lengths[0] if lengths else None
        for i, n in enumerate(lengths):
            if n != first:
                where = "".join(f"[{p}]" for p in path)
                show = lambda v: "a number" if v is None else f"{v} values"
                return (f"temperature{where}[0] has {show(first)}, temperature{where}[{i}] has "
                        f"{show(n)}")
        for i, e in enumerate(item):
            found = walk(e, path + [i])
            if found:
                return found
        return None

    return walk(nested, []) or "its elements have different shapes"


def _temperature_unit(stated, name: str) -> str:
    """``"K"`` or ``"C"`` for a variable's CF ``units`` of temperature (``K``, ``Kelvin``,
    ``degC``, ``degree_Celsius``, …: cf-units, UDUNITS-2 as CF prescribes); another unit, or
    none CF knows, is refused naming it."""
    text = str(stated)
    if text in ("K", "C"):
        return text
    import cf_units

    try:
        unit = cf_units.Unit(text)
        if unit.is_convertible("K"):
            offset = float(unit.convert(0.0, "K"))
            scale = float(unit.convert(1.0, "K")) - offset
            if scale == 1.0 and offset in (0.0, CELSIUS_OFFSET):
                return "K" if offset == 0.0 else "C"
    except ValueError:
        pass
    raise RadiosimError(f"{name}: its units {text!r} are neither kelvin nor degrees Celsius "
                        "(K, Kelvin, degC, degree_Celsius, …); convert it, or pass units='K' "
                        "or 'C'")


class _LazyFrames:
    """
    An xarray variable seen as an array of frames: indexing loads only what it asks for.

    A Dask-backed variable (``xr.open_dataset(..., chunks=…)``, ``xr.open_zarr``) is read a
    time chunk at a time: the first frame asked of a chunk loads the chunk's frames over the
    region asked (one read, not one a frame) and the next frames of that chunk come from it;
    memory holds one chunk over one region. The reads run on Dask's synchronous scheduler, in
    the calling thread: inside a cluster's worker they never submit work to the cluster (a
    single-thread worker waiting on itself). Pickled with its variable (a file-backed
    variable travels as its file's path and the graph that reads it).
    """

    def __init__(self, variable):
        self.variable = variable
        self.ndim = 3
        self.shape = tuple(int(n) for n in variable.shape)
        self.dtype = np.dtype(variable.dtype)
        chunks = getattr(variable, "chunks", None)
        self._starts = (np.cumsum((0,) + tuple(chunks[0])) if chunks else None)
        self._kept = None  # (time chunk, region key, its frames)

    def __getstate__(self):
        return {"variable": self.variable}

    def __setstate__(self, state):
        self.__init__(state["variable"])

    def _load(self, key) -> np.ndarray:
        part = self.variable[key]
        data = part.data
        if hasattr(data, "compute") and not isinstance(data, np.ndarray):
            return np.asarray(data.compute(scheduler="synchronous"))
        return np.asarray(part.values)

    def __getitem__(self, key):
        if self._starts is None or not isinstance(key, tuple) or isinstance(key[0], slice):
            return self._load(key)
        k, rest = int(key[0]), key[1:]
        chunk = int(np.searchsorted(self._starts, k, side="right")) - 1
        region = tuple((r.start, r.stop, r.step) if isinstance(r, slice) else r for r in rest)
        kept = self._kept
        if kept is None or kept[0] != chunk or kept[1] != region:
            first, stop = int(self._starts[chunk]), int(self._starts[chunk + 1])
            kept = self._kept = (chunk, region, self._load((slice(first, stop), *rest)))
        return kept[2][k - int(self._starts[chunk])]


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

"""
The scene interface: temperature frames on a regular grid, streamed frame by frame.

A scene holds temperature samples T[k, i, j] [K] on a grid of pitch ``dx`` [m] (object space;
sample (i, j) covers the square [j·dx, (j+1)·dx) × [i·dx, (i+1)·dx), row 0 at the top), in
frames of interval ``dt`` [s]: frame k holds over [k·dt, (k+1)·dt). Consumers ask for one frame
(or a rectangular region of it) at a time, so nothing requires the whole stack in memory.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Iterator

import numpy as np
from colour import SpectralDistribution

from radiosim.errors import RadiosimError
from radiosim.spectral import as_spectrum

__all__ = ["Region", "Scene", "CroppedScene", "check_frame", "check_positive", "check_emissivity"]

#: A rectangular region of a frame: (row slice, column slice), both with explicit bounds.
Region = tuple[slice, slice]


def check_positive(value, name: str, unit: str) -> float:
    """``value`` as a finite float > 0, or a :class:`RadiosimError` naming it."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise RadiosimError(f"{name} must be a number [{unit}], got {value!r}") from None
    if not math.isfinite(number) or number <= 0:
        raise RadiosimError(f"{name} must be finite and > 0 [{unit}], got {value!r}")
    return number


def check_frame(frame: np.ndarray, k: int, origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """
    Check that a temperature frame is usable: finite and > 0 K everywhere.

    Parameters
    ----------
    frame
        Temperature [K], 2-D.
    k
        Frame index, for the error message.
    origin
        (row, column) of ``frame[0, 0]`` in the full frame, for the error message.
    """
    if frame.size and frame.min() > 0:  # NaN compares false, so NaN frames fall through
        return frame
    bad = ~(frame > 0)
    i, j = (int(v) for v in np.argwhere(bad)[0])
    value = frame[i, j]
    what = "NaN" if np.isnan(value) else f"{value:g} K"
    expected = "finite" if np.isnan(value) else "> 0 K (°C passed as kelvin?)"
    raise RadiosimError(
        f"frame {k}: temperature at row {i + origin[0]}, column {j + origin[1]} is {what}; "
        f"temperatures must be {expected} ({int(bad.sum())} bad sample(s) in this frame)"
    )


def check_emissivity(emissivity, shape: tuple[int, int]):
    """
    Validate a scene emissivity: a scalar or curve (via :func:`~radiosim.spectral.as_spectrum`)
    or a grey map of shape ``shape`` with values in [0, 1].
    """
    if isinstance(emissivity, np.ndarray) and emissivity.ndim == 2:
        if emissivity.shape != tuple(shape):
            raise RadiosimError(
                f"emissivity map has shape {emissivity.shape}, expected the frame shape {shape}"
            )
        values = np.asarray(emissivity, dtype=float)
        if not np.all((values >= 0) & (values <= 1)):
            raise RadiosimError("emissivity map values must lie in [0, 1] (and not be NaN)")
        return values
    return as_spectrum(emissivity, "emissivity")


class Scene(ABC):
    """
    Temperature frames [K] on a regular grid, streamed one frame at a time.

    Attributes
    ----------
    dx : float
        Sample pitch in object space [m].
    dt : float
        Frame interval [s]; frame k holds over [k·dt, (k+1)·dt).
    shape : tuple of int
        Frame shape (rows, columns).
    n_frames : int or None
        Number of frames, or ``None`` for a scene defined at all times ≥ 0.
    emissivity : float, numpy.ndarray or SpectralDistribution
        Grey scalar, grey map shaped like a frame, or spectral curve (domain [m]).
    event_time : float or None
        Time [s] a measurement window is centred on when no start is given, if any.
    """

    dx: float
    dt: float
    shape: tuple[int, int]
    n_frames: int | None = None
    emissivity: float | np.ndarray | SpectralDistribution = 1.0
    event_time: float | None = None

    @property
    def duration(self) -> float | None:
        """Time covered by the frames [s], or ``None`` if unbounded."""
        return None if self.n_frames is None else self.n_frames * self.dt

    @abstractmethod
    def _read(self, k: int, region: Region) -> np.ndarray:
        """Frame ``k`` over ``region`` as float64 [K], unchecked."""

    def frame(self, k: int, region: Region | None = None) -> np.ndarray:
        """
        Temperature of frame ``k`` [K], float64, optionally restricted to ``region``.

        Raises :class:`~radiosim.errors.RadiosimError` if ``k`` is outside the scene or the frame
        holds NaN or non-positive temperatures.
        """
        k = int(k)
        if k < 0 or (self.n_frames is not None and k >= self.n_frames):
            last = "∞" if self.n_frames is None else self.n_frames - 1
            raise RadiosimError(f"frame {k} is outside the scene (frames 0 to {last})")
        if region is None:
            region = (slice(0, self.shape[0]), slice(0, self.shape[1]))
        values = np.asarray(self._read(k, region), dtype=np.float64)
        expected = tuple(s.stop - s.start for s in region)
        if values.shape != expected:
            raise RadiosimError(
                f"frame {k} has shape {values.shape}, expected {expected} from the scene's "
                f"shape {self.shape}"
            )
        return check_frame(values, k, (region[0].start, region[1].start))

    def frames(self, start: int, stop: int, region: Region | None = None) -> Iterator[np.ndarray]:
        """Frames ``start`` to ``stop - 1`` [K], one at a time."""
        for k in range(start, stop):
            yield self.frame(k, region)

    def emissivity_map(self, k: int, region: Region):
        """
        Emissivity of frame ``k`` over ``region`` when it changes with time, as
        (integer region codes, {code: emissivity}); ``None`` when :attr:`emissivity` holds.
        """
        return None

    def crop(self, rows: tuple[int, int], cols: tuple[int, int]) -> "CroppedScene":
        """The window (row start, stop) × (column start, stop) of this scene, as a scene."""
        return CroppedScene(self, rows, cols)

    def describe(self) -> dict:
        """Plain metadata (str, int, float) describing the scene, with units in the keys."""
        emissivity = self.emissivity
        if isinstance(emissivity, SpectralDistribution):
            emissivity = f"spectral: {emissivity.name}"
        elif isinstance(emissivity, np.ndarray):
            emissivity = f"map: {emissivity.min():.3g}–{emissivity.max():.3g}"
        return {
            "type": type(self).__name__,
            "rows": self.shape[0],
            "columns": self.shape[1],
            "dx_m": self.dx,
            "dt_s": self.dt,
            "n_frames": -1 if self.n_frames is None else self.n_frames,
            "emissivity": emissivity,
        }


class CroppedScene(Scene):
    """
    A rectangular window of another scene, itself a scene (same dx, dt, frames, event).

    Parameters
    ----------
    scene
        The scene to crop.
    rows, cols
        (start, stop) sample indices of the window; it must lie inside the scene.

    Examples
    --------
    >>> from radiosim.scenes import UniformBlackbody
    >>> CroppedScene(UniformBlackbody(500.0, shape=(40, 50)), (10, 30), (0, 25)).shape
    (20, 25)
    """

    def __init__(self, scene: Scene, rows: tuple[int, int], cols: tuple[int, int]):
        bounds = []
        for (start, stop), size, axis in ((rows, scene.shape[0], "rows"),
                                          (cols, scene.shape[1], "columns")):
            start, stop = int(start), int(stop)
            if not 0 <= start < stop <= size:
                raise RadiosimError(f"crop {axis} {start}–{stop} is outside the scene's "
                                    f"0–{size} {axis}")
            bounds.append((start, stop))
        self.parent = scene
        self.offset = (bounds[0][0], bounds[1][0])
        self.shape = (bounds[0][1] - bounds[0][0], bounds[1][1] - bounds[1][0])
        self.dx, self.dt, self.n_frames = scene.dx, scene.dt, scene.n_frames
        self.event_time = scene.event_time
        emissivity = scene.emissivity
        if isinstance(emissivity, np.ndarray):
            emissivity = emissivity[bounds[0][0]:bounds[0][1], bounds[1][0]:bounds[1][1]]
        self.emissivity = emissivity

    def _shift(self, region: Region) -> Region:
        (r0, c0), (rs, cs) = self.offset, region
        return (slice(rs.start + r0, rs.stop + r0), slice(cs.start + c0, cs.stop + c0))

    def _read(self, k: int, region: Region) -> np.ndarray:
        return self.parent._read(k, self._shift(region))

    def emissivity_map(self, k: int, region: Region):
        return self.parent.emissivity_map(k, self._shift(region))

    def describe(self) -> dict:
        return self.parent.describe() | {
            "crop_rows": f"{self.offset[0]}-{self.offset[0] + self.shape[0]}",
            "crop_columns": f"{self.offset[1]}-{self.offset[1] + self.shape[1]}",
            "rows": self.shape[0], "columns": self.shape[1],
        }

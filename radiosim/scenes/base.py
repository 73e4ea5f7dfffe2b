"""
The scene interface: temperature frames on a regular grid, streamed frame by frame.

A scene holds temperature samples T[k, i, j] [K] on a grid of pitch ``dx`` [m] (object space;
sample (i, j) covers the square [j·dx, (j+1)·dx) × [i·dx, (i+1)·dx), row 0 at the top), in
frames of interval ``dt`` [s]: frame k holds over [o + k·dt, o + (k+1)·dt), o the scene's
``frame_origin`` (0, but for a scene whose frames are aligned to a file's own time stamps:
:mod:`radiosim.scenes.fea_nodes`); :func:`frame_weights` gives a window's exact weights on
that grid. Consumers ask for one frame
(or a rectangular region of it) at a time, so nothing requires the whole stack in memory.
"""

from __future__ import annotations

import dataclasses
import math
from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from radiosim.checks import check_frame, check_positive
from radiosim.errors import RadiosimError
from radiosim.spectral import as_spectrum, is_spectrum
# AMBIENT_TEMPERATURE is defined in radiosim.units; importable from here, as before.
from radiosim.units import AMBIENT_TEMPERATURE, readable_time, readable_times

if TYPE_CHECKING:  # colour-science is imported when a curve is built
    from colour import SpectralDistribution

__all__ = ["Region", "SceneFrame", "Scene", "CroppedScene", "frame_weights", "check_frame",
           "check_positive", "check_emissivity", "check_grid", "AMBIENT_TEMPERATURE"]

#: A rectangular region of a frame: (row slice, column slice), both with explicit bounds.
Region = tuple[slice, slice]
_SNAP = 1e-9  # times within this many frame intervals of a frame edge are on it


def _snap(value: float) -> float:
    nearest = round(value)
    return float(nearest) if abs(value - nearest) <= _SNAP * max(1.0, abs(value)) else value


def frame_weights(
    t_start: float, duration: float, dt: float, n_frames: int | None = None,
    origin: float = 0.0,
) -> tuple[int, np.ndarray]:
    """
    Exact time weights of the frames overlapping the window [t_start, t_start + duration],
    frame k covering [origin + k·dt, origin + (k+1)·dt).

    Parameters
    ----------
    t_start
        Window start [s], ≥ 0.
    duration
        Integration time [s], > 0.
    dt
        Frame interval [s].
    n_frames
        Frames in the scene (``None``: unbounded); the window must lie inside them.
    origin
        Start of frame 0 [s] (:attr:`radiosim.scenes.base.Scene.frame_origin`: 0 but for a
        scene whose frames are aligned to a file's own time stamps).

    Returns
    -------
    first : int
        Index of the first frame overlapping the window.
    weights : numpy.ndarray
        Overlap of each frame from ``first`` on with the window, over ``duration``; they sum
        to 1 and are all > 0.

    Examples
    --------
    The paper's 1 µs window over 0.2 µs frames is exactly five frames:

    >>> frame_weights(0.0, 1e-6, 0.2e-6)
    (0, array([0.2, 0.2, 0.2, 0.2, 0.2]))
    >>> frame_weights(0.1e-6, 0.4e-6, 0.2e-6)
    (0, array([0.25, 0.5 , 0.25]))
    """
    if not (math.isfinite(duration) and duration > 0):
        raise RadiosimError(f"integration time must be finite and > 0 [s], got {duration!r}")
    a = _snap((t_start - origin) / dt) if math.isfinite(t_start) else math.nan
    if not a >= 0:
        raise RadiosimError(
            f"integration window starts at {readable_time(t_start) if math.isfinite(t_start) else t_start}, "
            f"before the scene's first frame (t = {readable_time(origin) if origin else 0})"
        )
    b = _snap((t_start + duration - origin) / dt)
    if n_frames is not None and b > n_frames:
        (start, end, low, covered), unit = readable_times(
            t_start, t_start + duration, origin, origin + n_frames * dt)
        raise RadiosimError(
            f"integration window {start}–{end} {unit} runs past the scene's last frame (the "
            f"scene covers {low}–{covered} {unit}, {n_frames} frames)")
    first, stop = math.floor(a), math.ceil(b)
    k = np.arange(first, stop)
    overlap = np.minimum(b, k + 1) - np.maximum(a, k)
    keep = overlap > 0
    if not keep[0]:
        first += 1
    return first, overlap[keep] / (b - a)


@dataclass(frozen=True, eq=False)
class SceneFrame:
    """
    One frame of a scene over a region, as the response needs it: temperature and emissivity of
    every sample, from one evaluation of the scene.

    Attributes
    ----------
    temperature : numpy.ndarray
        Temperature of each sample [K], 2-D.
    emissivity : float, SpectralDistribution or numpy.ndarray
        Emissivity of every sample (a grey scalar or a spectral curve), or a grey map shaped like
        ``temperature`` (dimensionless).
    regions : numpy.ndarray of int or None
        Region code of each sample, when the emissivity is given per region.
    region_emissivity : dict or None
        Region code → grey scalar or spectral curve; with ``regions``, it overrides
        ``emissivity``.
    index : int
        Frame index k.
    reflected_temperature : float, numpy.ndarray or None
        Temperature [K] of what each sample reflects (a scalar or a map shaped like
        ``temperature``); ``None``: a black room, nothing reflected.
    """

    temperature: np.ndarray
    emissivity: float | SpectralDistribution | np.ndarray = 1.0
    regions: np.ndarray | None = None
    region_emissivity: dict | None = None
    index: int = 0
    reflected_temperature: float | np.ndarray | None = None


def check_grid(dx: float, dt: float) -> tuple[float, float]:
    """A scene's sample pitch [m] and frame interval [s], each finite and > 0 (whether they
    suit a camera is the integrator's check: :func:`radiosim.integrator.check_scale`)."""
    return check_positive(dx, "dx", "m"), check_positive(dt, "dt", "s")


def check_emissivity(emissivity, shape: tuple[int, int]):
    """
    Validate a scene emissivity: a scalar or curve (via :func:`~radiosim.spectral.as_spectrum`)
    or a grey map of shape ``shape`` with values in [0, 1].
    """
    if isinstance(emissivity, (bool, np.bool_)):
        raise RadiosimError(f"emissivity is {emissivity!r} (a bool); expected a number in "
                            "[0, 1], a map, a spectral curve or a curve's name")
    if isinstance(emissivity, np.ndarray) and emissivity.dtype == bool:
        raise RadiosimError("emissivity map holds booleans; expected numbers in [0, 1]")
    if isinstance(emissivity, np.ndarray) and emissivity.ndim == 2:
        if emissivity.shape != tuple(shape):
            raise RadiosimError(
                f"emissivity map has shape {emissivity.shape}, expected the frame shape {shape}"
            )
        values = np.asarray(emissivity, dtype=float)
        if not np.all((values >= 0) & (values <= 1)):
            bad = ~((values >= 0) & (values <= 1))
            i, j = (int(v) for v in np.argwhere(bad)[0])
            raise RadiosimError(f"emissivity map values must lie in [0, 1] (and not be NaN); "
                                f"got {values[i, j]:g} at row {i}, column {j} "
                                f"({int(bad.sum())} value(s) outside)")
        return values
    return as_spectrum(emissivity, "emissivity")


def _check_temperature_field(value, what: str) -> np.ndarray:
    values = np.asarray(value, dtype=float)
    bad = ~(np.isfinite(values) & (values > 0))
    if bad.any():
        raise RadiosimError(f"{what} must be finite temperatures > 0 K, got "
                            f"{float(values[bad].flat[0]):g} K")
    return values


class Scene(ABC):
    """
    Temperature frames [K] on a regular grid, streamed one frame at a time.

    Attributes
    ----------
    dx : float
        Sample pitch in object space [m].
    dt : float
        Frame interval [s]; frame k holds over [o + k·dt, o + (k+1)·dt) of the scene's own
        time, o the ``frame_origin``.
    frame_origin : float
        Start of frame 0 [s]: 0, but for a scene that keeps a file's own time (an FEA scene:
        its frames are aligned to the file's time stamps, its first time stamp is its
        ``t0``, frames before it are refused, and a window's ``t_start`` is stated in that
        time).
    first_frame : int
        The first frame holding data (0 but for such a scene).
    shape : tuple of int
        Frame shape (rows, columns).
    n_frames : int or None
        Number of frames, or ``None`` for a scene defined at all times ≥ 0.
    emissivity : float, numpy.ndarray or SpectralDistribution
        Grey scalar, grey map shaped like a frame, or spectral curve (domain [m]).
    event_time : float or None
        Time [s] a measurement window is centred on when no start is given, if any.
    reflected_temperature : float, numpy.ndarray or None
        Temperature [K] of what the surfaces reflect: a scalar, a map shaped like a frame, or
        one value per frame (1-D, ``n_frames`` long); ``None``: nothing (a black room).
    path_transmission, path_temperature : float, float or None
        A grey path between the scene and the camera (an atmosphere, a window in the
        set-up): transmission [1] and temperature [K]; by default none (1, ``None``).
    surroundings_temperature : float
        Temperature [K] of the blackbody surroundings beyond the frame's edges, whose light a
        point-spread function's wings carry into the image (default
        :data:`~radiosim.units.AMBIENT_TEMPERATURE`, 293.15 K).

    Notes
    -----
    Set the last four with :meth:`set_environment`.
    """

    dx: float
    dt: float
    frame_origin: float = 0.0
    first_frame: int = 0
    shape: tuple[int, int]
    n_frames: int | None = None
    emissivity: float | np.ndarray | SpectralDistribution = 1.0
    event_time: float | None = None
    reflected_temperature: float | np.ndarray | None = None
    path_transmission: float = 1.0
    path_temperature: float | None = None
    surroundings_temperature: float = AMBIENT_TEMPERATURE

    def set_environment(self, reflected_temperature=None, path_transmission: float = 1.0,
                        path_temperature: float | None = None,
                        surroundings_temperature: float = AMBIENT_TEMPERATURE):
        """
        State what the scene's surfaces reflect, the path to the camera and the surroundings
        (see the class attributes); returns the scene.

        Examples
        --------
        >>> from radiosim.scenes import UniformBlackbody
        >>> scene = UniformBlackbody(800.0).set_environment(reflected_temperature=293.15)
        >>> scene.reflected_temperature
        293.15
        """
        if reflected_temperature is not None:
            values = _check_temperature_field(reflected_temperature, "reflected_temperature")
            if values.ndim == 0:
                reflected_temperature = float(values)
            elif values.ndim == 2 and values.shape != tuple(self.shape):
                raise RadiosimError(f"reflected_temperature map has shape {values.shape}, "
                                    f"expected the frame shape {tuple(self.shape)}")
            elif values.ndim == 1 and (self.n_frames is None or values.size != self.n_frames):
                raise RadiosimError(f"reflected_temperature per frame has {values.size} values, "
                                    f"expected one per frame ({self.n_frames})")
            elif values.ndim > 2:
                raise RadiosimError("reflected_temperature must be a scalar, a frame-shaped map "
                                    f"or one value per frame, got shape {values.shape}")
            else:
                reflected_temperature = values
        self.reflected_temperature = reflected_temperature
        tau = float(path_transmission)
        if not 0 < tau <= 1:
            raise RadiosimError(f"path_transmission must be in (0, 1], got {path_transmission!r}")
        self.path_transmission = tau
        self.path_temperature = (None if path_temperature is None else float(
            _check_temperature_field(path_temperature, "path_temperature")))
        if tau < 1 and self.path_temperature is None:
            raise RadiosimError("a path with transmission < 1 needs its path_temperature [K]")
        self.surroundings_temperature = float(_check_temperature_field(
            surroundings_temperature, "surroundings_temperature"))
        return self

    def _reflected(self, k: int, region: Region):
        """The reflected temperature of frame ``k`` over ``region`` [K] (scalar, map or None)."""
        value = self.reflected_temperature
        if isinstance(value, np.ndarray):
            return float(value[k]) if value.ndim == 1 else value[region[0], region[1]]
        return value

    def with_emissivity(self, emissivity) -> Scene:
        """A copy of the scene with another emissivity (grey scalar, map or curve)."""
        import copy

        out = copy.copy(self)
        out.emissivity = check_emissivity(emissivity, self.shape)
        return out

    @property
    def environment(self) -> dict:
        """The environment as :meth:`set_environment`'s keyword arguments."""
        return dict(reflected_temperature=self.reflected_temperature,
                    path_transmission=self.path_transmission,
                    path_temperature=self.path_temperature,
                    surroundings_temperature=self.surroundings_temperature)

    @property
    def duration(self) -> float | None:
        """End of the last frame in the scene's time [s] (the time the frames cover, from
        t = 0 when ``frame_origin`` is 0), or ``None`` if unbounded."""
        return None if self.n_frames is None else self.frame_start(self.n_frames)

    def frame_start(self, k: int) -> float:
        """Start of frame ``k`` in the scene's time [s]: ``frame_origin + k·dt``."""
        return self.frame_origin + k * self.dt

    def window_frames(self, window) -> tuple[int, np.ndarray]:
        """The first frame a window (``start``, ``duration`` [s]) overlaps and each frame's
        exact weight from it on (:func:`frame_weights` on this scene's frames); a window
        outside the frames raises. A window's part (its ``frames`` = (first, stop)) keeps
        those frames' weights in the whole window."""
        first, weights = frame_weights(window.start, window.duration, self.dt, self.n_frames,
                                       self.frame_origin)
        part = getattr(window, "frames", None)
        if part is None:
            return first, weights
        start, stop = part
        if not first <= start < stop <= first + weights.size:
            raise RadiosimError(f"frames {start}–{stop - 1} are not within the window's "
                                f"frames {first}–{first + weights.size - 1}")
        return start, weights[start - first:stop - first]

    @abstractmethod
    def _read(self, k: int, region: Region) -> np.ndarray:
        """Frame ``k`` over ``region`` as float64 [K], unchecked."""

    def _sample(self, k: int, region: Region) -> SceneFrame:
        """Frame ``k`` over ``region`` with its emissivity, unchecked (scenes whose emissivity
        changes with time override this)."""
        emissivity = self.emissivity
        if isinstance(emissivity, np.ndarray):
            emissivity = emissivity[region[0], region[1]]
        return SceneFrame(self._read(k, region), emissivity, index=k)

    def _where(self, k, region: Region | None) -> tuple[int, Region]:
        k = int(k)
        if k < 0 or (self.n_frames is not None and k >= self.n_frames):
            last = "∞" if self.n_frames is None else self.n_frames - 1
            raise RadiosimError(f"frame {k} is outside the scene (frames 0 to {last})")
        if region is None:
            region = (slice(0, self.shape[0]), slice(0, self.shape[1]))
        return k, region

    def _checked(self, values, k: int, region: Region) -> np.ndarray:
        values = np.asarray(values, dtype=np.float64)
        expected = tuple(s.stop - s.start for s in region)
        if values.shape != expected:
            raise RadiosimError(
                f"frame {k} has shape {values.shape}, expected {expected} from the scene's "
                f"shape {self.shape}"
            )
        return check_frame(values, k, (region[0].start, region[1].start))

    def frame(self, k: int, region: Region | None = None) -> np.ndarray:
        """
        Temperature of frame ``k`` [K], float64, optionally restricted to ``region``.

        Raises :class:`~radiosim.errors.RadiosimError` if ``k`` is outside the scene or the frame
        holds NaN, infinite or non-positive temperatures.
        """
        k, region = self._where(k, region)
        return self._checked(self._read(k, region), k, region)

    def sample(self, k: int, region: Region | None = None) -> SceneFrame:
        """
        Frame ``k`` over ``region``: temperature [K] and emissivity of every sample, as one
        checked :class:`SceneFrame` (an emissivity map is cropped to the region).
        """
        k, region = self._where(k, region)
        frame = self._sample(k, region)
        return dataclasses.replace(frame, temperature=self._checked(frame.temperature, k, region),
                                   reflected_temperature=self._reflected(k, region))

    def sample_unchecked(self, k: int, region: Region | None = None) -> SceneFrame:
        """
        :meth:`sample` without the conversion to float64 and the sample check: the temperature
        as the scene holds it (a float32 memory-mapped view stays one). For consumers that
        check every sample themselves, in the same pass (the compiled kernels).
        """
        k, region = self._where(k, region)
        frame = self._sample(k, region)
        expected = tuple(s.stop - s.start for s in region)
        if np.shape(frame.temperature) != expected:
            raise RadiosimError(f"frame {k} has shape {np.shape(frame.temperature)}, expected "
                                f"{expected} from the scene's shape {self.shape}")
        if self.reflected_temperature is None:
            return frame
        return dataclasses.replace(frame, reflected_temperature=self._reflected(k, region))

    def block_unchecked(self, start: int, stop: int,
                        region: Region | None = None) -> np.ndarray | None:
        """
        Frames ``start`` to ``stop - 1`` over ``region`` as one 3-D array (frames, rows,
        columns), unchecked and as the scene holds them (a view of a stored stack), if the scene
        holds its frames so and their emissivity does not change with time (:meth:`sample_unchecked`
        of ``start`` then gives it); ``None`` otherwise. The compiled kernels then take several
        frames per call.
        """
        return None

    def frames(self, start: int, stop: int, region: Region | None = None) -> Iterator[np.ndarray]:
        """Frames ``start`` to ``stop - 1`` [K], one at a time."""
        for k in range(start, stop):
            yield self.frame(k, region)

    def crop(self, rows: tuple[int, int], cols: tuple[int, int]) -> "CroppedScene":
        """The window (row start, stop) × (column start, stop) of this scene, as a scene."""
        return CroppedScene(self, rows, cols)

    def __repr__(self) -> str:
        """One line: type, grid, frames and emissivity (:meth:`describe` has the rest)."""
        d = self.describe()
        frames = (f"frames of {self.dt * 1e6:.4g} µs without end" if self.n_frames is None
                  else f"{self.n_frames} frames of {self.dt * 1e6:.4g} µs")
        return (f"{d['type']}({d['rows']} × {d['columns']} samples of {self.dx * 1e6:.4g} µm, "
                f"{frames}, emissivity {d['emissivity']})")

    def describe(self) -> dict:
        """Plain metadata (str, int, float) describing the scene, with units in the keys."""
        emissivity = self.emissivity
        if is_spectrum(emissivity):
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
        } | self._describe_environment()

    def _describe_environment(self) -> dict:
        """The environment, where it differs from a black room with no path."""
        out = {}
        reflected = self.reflected_temperature
        if isinstance(reflected, np.ndarray):
            out["reflected_temperature_K"] = (f"{'per frame' if reflected.ndim == 1 else 'map'}:"
                                              f" {reflected.min():.6g}-{reflected.max():.6g}")
        elif reflected is not None:
            out["reflected_temperature_K"] = float(reflected)
        if self.path_transmission < 1:
            out["path_transmission"] = self.path_transmission
            out["path_temperature_K"] = self.path_temperature
        if self.surroundings_temperature != AMBIENT_TEMPERATURE:
            out["surroundings_temperature_K"] = self.surroundings_temperature
        return out


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
        self.frame_origin, self.first_frame = scene.frame_origin, scene.first_frame
        self.event_time = scene.event_time
        emissivity = scene.emissivity
        if isinstance(emissivity, np.ndarray):
            emissivity = emissivity[bounds[0][0]:bounds[0][1], bounds[1][0]:bounds[1][1]]
        self.emissivity = emissivity
        environment = scene.environment
        reflected = environment["reflected_temperature"]
        if isinstance(reflected, np.ndarray) and reflected.ndim == 2:
            environment["reflected_temperature"] = reflected[bounds[0][0]:bounds[0][1],
                                                             bounds[1][0]:bounds[1][1]]
        self.set_environment(**environment)

    def _shift(self, region: Region) -> Region:
        (r0, c0), (rs, cs) = self.offset, region
        return (slice(rs.start + r0, rs.stop + r0), slice(cs.start + c0, cs.stop + c0))

    def _read(self, k: int, region: Region) -> np.ndarray:
        return self.parent._read(k, self._shift(region))

    def _sample(self, k: int, region: Region) -> SceneFrame:
        return self.parent._sample(k, self._shift(region))

    def describe(self) -> dict:
        return self.parent.describe() | {
            "crop_rows": f"{self.offset[0]}-{self.offset[0] + self.shape[0]}",
            "crop_columns": f"{self.offset[1]}-{self.offset[1] + self.shape[1]}",
            "rows": self.shape[0], "columns": self.shape[1],
        }

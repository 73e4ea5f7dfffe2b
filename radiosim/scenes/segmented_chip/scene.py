"""
The built-in segmented-chip scene, :class:`SegmentedChip`: a kinematic thermal model of
orthogonal cutting with a segmented chip, periodic in time with the segmentation period,
evaluated at any time on any grid (the model: :mod:`radiosim.scenes.segmented_chip`).

The scene builds its grid's static fields once (:class:`~.geometry.Geometry`), each region's
index sets once (:class:`~.geometry.RegionData`), and per frame evaluates the moving terms through the
engine (:mod:`radiosim.kernels.engines`): with the compiled kernel (:mod:`.compiled`,
:mod:`.kernel`, :func:`moving_terms_compiled`) or the numpy reference (:mod:`.reference`,
:func:`moving_terms_reference`), the two registered with the engines here.

References
----------
-   Whitenton, E. P., Heigel, J. C. & Ivester, R. W. (2009). ASME MSEC2009-84319.
"""

from __future__ import annotations

import math
import threading
import weakref
from pathlib import Path

import numpy as np

from radiosim.checks import check_positive
from radiosim.errors import RadiosimError
from radiosim.kernels.engines import get_engine, register_scene_terms
from radiosim.scenes.base import Region, Scene, SceneFrame, check_emissivity, check_grid
from radiosim.scenes.segmented_chip.compiled import KernelLayout, evaluate_compiled
from radiosim.scenes.segmented_chip.geometry import COLUMNS, REGIONS, Geometry, RegionData
from radiosim.scenes.segmented_chip.parameters import ChipParameters
from radiosim.scenes.segmented_chip.reference import evaluate_reference, forming_base, phase

__all__ = ["SegmentedChip"]


class SegmentedChip(Scene):
    """
    The kinematic segmented-chip scene of orthogonal cutting, periodic in time.

    Parameters
    ----------
    params
        :class:`ChipParameters` (default: the calibrated ones), or a path to a TOML file.
    dx
        Sample pitch [m] (default 960/1440 µm, the paper's movie).
    dt
        Frame interval [s] (default 0.2 µs, the paper's movie).
    emissivity
        A grey scalar, a spectral curve, or a dict of region name → scalar or curve
        (``{"chip": 0.3, "tool": 0.5, "workpiece": 0.3, "air": 1.0}``, missing regions 1).
    cycles
        Frames are defined for ``cycles`` segmentation periods (``None``: unbounded).

    Attributes
    ----------
    event_time : float
        Mid-time of the frame that holds the fully developed shear band at the end of the tenth
        cycle [s], so that windows up to 1.8 ms centred on it start after t = 0.

    Examples
    --------
    >>> scene = SegmentedChip(dx=4e-6, dt=1e-6)
    >>> scene.shape
    (186, 240)
    >>> t = scene.temperature(scene.event_time)
    >>> 900 < float(t.max()) < 1100
    True
    """

    def __init__(self, params: ChipParameters | str | Path | None = None, dx: float = 960e-6 / 1440,
                 dt: float = 0.2e-6, emissivity=1.0, cycles: int | None = None):
        given_emissivity = emissivity
        if params is None:
            params = ChipParameters()
        elif isinstance(params, (str, Path)):
            params = ChipParameters.from_toml(params)
        elif not isinstance(params, ChipParameters):
            raise RadiosimError(f"params must be ChipParameters or a TOML path, got "
                                f"{type(params).__name__}")
        self.params = params
        self.dx, self.dt = check_grid(dx, dt)
        self.shape = (int(round(params.field_height / self.dx)),
                      int(round(params.field_width / self.dx)))
        if min(self.shape) < 2:
            raise RadiosimError(f"dx = {dx!r} m leaves fewer than 2 samples across the field")
        self.n_frames = None if cycles is None else int(round(cycles * params.period / self.dt))
        frames_per_cycle = params.period / self.dt
        self.event_time = (10 * frames_per_cycle - 0.5) * self.dt
        self._region_emissivity = None
        if isinstance(emissivity, dict):
            unknown = set(emissivity) - set(REGIONS)
            if unknown:
                raise RadiosimError(f"unknown region(s) {sorted(unknown)} in emissivity; "
                                    f"regions are {', '.join(REGIONS)}")
            for name, value in emissivity.items():
                if isinstance(value, np.ndarray) and value.ndim >= 1:
                    raise RadiosimError(f"emissivity of region {name!r} must be a number or a "
                                        "spectral curve, not a map (a grey map is given for "
                                        "the whole scene: emissivity=map)")
            self._region_emissivity = {name: check_emissivity(emissivity.get(name, 1.0),
                                                               self.shape) for name in REGIONS}
            emissivity = 1.0
        self.emissivity = check_emissivity(emissivity, self.shape)
        self._arguments = (params, dx, dt, given_emissivity, cycles)
        self._geometry = None
        self._regions: dict[tuple, RegionData] = {}
        self._lock = threading.RLock()
        self._checked_frames = threading.local()  # .last: weakref to a frame known clean

    @property
    def geometry(self) -> Geometry:
        """Static fields of the grid (built on first use)."""
        with self._lock:
            if self._geometry is None:
                self._geometry = Geometry(self.params, self.shape, self.dx)
            return self._geometry

    # -- time ---------------------------------------------------------------------------------

    def _phase(self, t: float):
        """τ [s], θ and d [m] at t [s] (:func:`~.reference.phase`)."""
        return phase(self.params, t)

    def _forming_base(self, theta: float) -> float:
        """The forming band's growth at phase θ (:func:`~.reference.forming_base`)."""
        return forming_base(self.params, theta)

    # -- evaluation ---------------------------------------------------------------------------

    def _prepared(self, region: Region) -> RegionData:
        key = (region[0].start, region[0].stop, region[1].start, region[1].stop)
        with self._lock:
            data = self._regions.get(key)
            if data is None:
                if len(self._regions) >= 4:
                    self._regions.pop(next(iter(self._regions)))
                data = self._regions[key] = RegionData(self.params, self.geometry, region)
            return data

    def _evaluate(self, t: float, region: Region, want_regions: bool = False,
                  engine=None):
        """Frame at time t over ``region``: temperature [K] (and, with ``want_regions``, the
        region map). The moving terms are the engine's (``engine``: a name or
        :class:`~radiosim.kernels.engines.Engine`, default the chosen one): its
        ``scene_terms["segmented_chip"]`` (:func:`moving_terms_compiled` for the compiled
        engine, :func:`moving_terms_reference` for the numpy one and any engine without them).
        A frame the engine found clean (finite, > 0 K) is remembered, so that :meth:`_checked`
        does not read it again."""
        self._checked_frames.last = None  # only the frame this evaluation makes can be clean
        terms = get_engine(engine).scene_terms.get(SCENE_TERMS, moving_terms_reference)
        temperature, regions, clean = terms(self, t, region, want_regions)
        self._checked_frames.last = weakref.ref(temperature) if clean else None
        if not want_regions:
            return temperature
        return temperature, regions

    def _full(self) -> Region:
        return (slice(0, self.shape[0]), slice(0, self.shape[1]))

    def temperature(self, t: float, region: Region | None = None) -> np.ndarray:
        """Temperature field [K] at time t [s] (any time ≥ 0; the scene is periodic)."""
        if not (math.isfinite(t) and t >= 0):
            raise RadiosimError(f"time must be finite and ≥ 0 [s], got {t!r}")
        return self._evaluate(float(t), region or self._full())

    def regions(self, t: float, region: Region | None = None) -> np.ndarray:
        """Region map at time t [s]: codes of :data:`REGIONS` (air 0, workpiece 1, chip 2,
        tool 3)."""
        return self._evaluate(float(t), region or self._full(), want_regions=True)[1]

    def _read(self, k: int, region: Region) -> np.ndarray:
        return self._evaluate((k + 0.5) * self.dt, region)

    def _checked(self, values, k: int, region: Region) -> np.ndarray:
        """As the scene's check, but the very frame the compiled kernel just made on this
        thread and found clean (finite, > 0 K) is not read again (unless a subclass makes its
        frames another way)."""
        last, self._checked_frames.last = getattr(self._checked_frames, "last", None), None
        if (last is not None and last() is values and type(self)._read is SegmentedChip._read
                and values.dtype == np.float64
                and values.shape == tuple(sl.stop - sl.start for sl in region)):
            return values
        return super()._checked(values, k, region)

    def _sample(self, k: int, region: Region) -> SceneFrame:
        """Temperature and, with an emissivity per region, the region codes of the same
        evaluation."""
        if self._region_emissivity is None:
            return super()._sample(k, region)
        temperature, regions = self._evaluate((k + 0.5) * self.dt, region, want_regions=True)
        return SceneFrame(temperature, 1.0, regions=regions, index=k,
                          region_emissivity={REGIONS[name]: value for name, value
                                             in self._region_emissivity.items()})

    def __reduce__(self):
        """Pickled as its recipe — parameters, grid and environment — never its caches (a
        task on another process rebuilds the geometry it needs)."""
        return (_rebuild_chip, (self._arguments, self.environment))

    def with_emissivity(self, emissivity) -> SegmentedChip:
        """The same chip with grey ``emissivity`` on its metal (workpiece, chip and tool; the
        air keeps its own when the emissivity is given per region)."""
        params, dx, dt, old, cycles = self._arguments
        if isinstance(old, dict):
            emissivity = {**old, **{k: emissivity for k in ("workpiece", "chip", "tool")}}
        return _rebuild_chip((params, dx, dt, emissivity, cycles), self.environment)

    def reflected_field(self, view_length: float = 5e-6,
                        ambient: float | None = None) -> np.ndarray:
        """
        A reflected-temperature map [K] in which chip samples near the rake face see the
        tool's interface temperature (for :meth:`~radiosim.scenes.Scene.set_environment`).

        The approximation: a chip sample at distance n from the rake face and position s along
        it reflects the interface temperature T_face(s) with a weight exp(−n/ℓ), and the
        ambient temperature with the rest, blended in temperature:
        T_refl = T_amb + (T_face(s) − T_amb)·exp(−n/ℓ). A flat side face coplanar with the
        tool's has no view of the rake face at all; the weight stands for the rounded,
        side-flowed edge of a real chip, which does, within a few µm (ℓ) of the contact.
        Everything else reflects the ambient.

        Parameters
        ----------
        view_length
            ℓ [m], the distance from the rake face over which the view of the interface fades.
        ambient
            Ambient temperature [K] (default the chip's ``ambient_temperature``).
        """
        view = check_positive(view_length, "view_length", "m")
        p, g = self.params, self.geometry
        amb = p.ambient_temperature if ambient is None else check_positive(ambient, "ambient",
                                                                           "K")
        face = np.interp(np.clip(g.s, 0.0, None), g.face_s, g.face_temperature)
        weight = np.where(g.chip_max, np.exp(-np.clip(g.n, 0.0, None) / view), 0.0)
        return amb + (face - amb) * weight

    # -- reference locations -----------------------------------------------------------------

    def column_x(self, name: str) -> float:
        """x position [m] of reference Column "I", "II" or "III" (where it crosses L0)."""
        if name not in COLUMNS:
            raise RadiosimError(f"unknown column {name!r}; columns are {', '.join(COLUMNS)}")
        p = self.params
        along = COLUMNS[name] / math.cos(p.shear_angle + p.clearance_angle)
        return p.tool_tip_x - along * math.cos(p.shear_angle)

    def shear_plane(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """End points (x, y) [m] of L0: the tool tip and the elbow on the uncut surface."""
        p = self.params
        length = p.uncut_thickness / math.sin(p.shear_angle)
        return ((p.tool_tip_x, p.tool_tip_y),
                (p.tool_tip_x - length * math.cos(p.shear_angle), p.tool_tip_y
                 + p.uncut_thickness))

    def describe(self) -> dict:
        out = super().describe()
        out.update({f"chip_{k}": v for k, v in self.params.to_dict().items()})
        out["event_time_s"] = self.event_time
        if self._region_emissivity is not None:
            out["emissivity"] = ", ".join(
                f"{k}: {v.name if hasattr(v, 'name') else v}"
                for k, v in self._region_emissivity.items())
        return out


def _rebuild_chip(arguments, environment) -> SegmentedChip:
    chip = SegmentedChip(*arguments)
    chip.set_environment(**environment)
    return chip


#: The name of the chip's moving terms among an engine's ``scene_terms``.
SCENE_TERMS = "segmented_chip"


def moving_terms_reference(scene: SegmentedChip, t: float, region: Region,
                           want_regions: bool = False):
    """The moving terms in numpy, term by term over their index sets: the reference the
    compiled kernel is tested against (:func:`~.reference.evaluate_reference`). Returns the
    frame [K], the region map (or None without ``want_regions``) and False (not checked)."""
    made = evaluate_reference(scene.params, scene._prepared(region), t, want_regions)
    return (*made, False) if want_regions else (made, None, False)


def moving_terms_compiled(scene: SegmentedChip, t: float, region: Region,
                          want_regions: bool = False):
    """The moving terms in one fused, row-parallel pass of the compiled kernel
    (:func:`~.compiled.evaluate_compiled`; same results as :func:`moving_terms_reference` to
    rounding, the region map exactly). Returns the frame [K], the region map (or None) and
    whether every value is finite and > 0 K."""
    p, r = scene.params, scene._prepared(region)
    with scene._lock:
        layout = r.kernel
        if layout is None:
            layout = r.kernel = KernelLayout(p, scene.geometry, region, r)
    return evaluate_compiled(p, r, layout, t, want_regions)


register_scene_terms(SCENE_TERMS, {"compiled": moving_terms_compiled,
                                   "numpy": moving_terms_reference})

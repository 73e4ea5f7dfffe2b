"""
Monte Carlo draws that reuse what does not change between them: the draws of
:func:`radiosim.uncertainty.propagate`.

A budget's inputs (the scene's emissivity and reflected temperature, the optics' blur, the
window's position and length, the registration, the camera's settings and calibration) change
what a measurement does with the scene's radiance, never the scene's temperatures. A sample's
window-mean signal is linear in its emissivity and in the reflected term,

    S̄ = ε Ē + (1 − ε) L(T_refl),    Ē = Σ_k w_k L(T_k)

(Ē at unit emissivity, emission only, per spectral sub-band), so a draw needs no pass over the
frames. :class:`FrameSums` keeps, per sample and sub-band, the running sums
P(j) = Σ L(T_k) for origin ≤ k < j, over the frames any draw's window can touch, and a window with
the frame weights of :func:`radiosim.scenes.base.frame_weights` (a fractional first frame f and
last frame l, equal weights c between) is

    Ē = w_f (P(f+1) − P(f)) + c (P(l) − P(f+1)) + w_l (P(l+1) − P(l)).

A draw then forms its image as :func:`radiosim.imaging.image_signal` does, through
:func:`radiosim.imaging.form_image` (the path, one blur of all sub-bands of the window mean with
the draw's PSFs, the footprints), or, without an image stage, takes the footprint mean of ε Ē,
and reads out (:meth:`radiosim.camera.Camera.read_out`) with its own camera and noise generator.

Exactness. The running sums start at a frame the budget fixes (:attr:`ReusePlan.origin`: the
first frame the inputs' distributions can reach) and P_j depends only on the frames before j,
so a draw gives the same bits whether its sums were kept from earlier draws or made for it
alone from the origin (``reuse=False``: the straightforward draw, one pass over the frames), in
any process and on any scheduler. Against :meth:`Camera.measure
<radiosim.camera.Camera.measure>`, which accumulates ε L(T) frame by frame, a draw differs by
the order of its sums only (rounding: about 1e-14 of the signal; tested).

Memory. The sums hold samples × sub-bands × (frames the windows touch + 1) × 8 bytes (the
chip budget on the paper's grid, whose windows span 20 µs: 1113 × 1440 × 1 × 102 × 8 B =
1.3 GB): it grows with the frames the draws' windows can touch, not with the scene's length,
and not with the number of draws (one set of sums per process, :data:`_KEPT`; the Monte Carlo
streams its moments in batches). Above :data:`IN_MEMORY_BYTES` the sums live in an anonymous
temporary file, memory-mapped: the system keeps the pages that fit in memory (they count in
the process's resident size) and may drop them under pressure, which it cannot do with
anonymous memory.

A budget this module cannot serve (a multi-channel or rolling-shutter camera, an emissivity map,
curve or per region, a reflected-temperature map) is measured draw by draw
(:meth:`ReusePlan.supports`; :func:`draw` returns ``None``).
"""

from __future__ import annotations

import math
import tempfile
import threading
import uuid
from dataclasses import dataclass

import numpy as np

from radiosim.acquisition import check_measurable, is_rolling
from radiosim.imaging import form_image, sample_signals, sub_band_count
from radiosim.integrator import TensorStatistics, Window

__all__ = ["ReusePlan", "FrameSums", "draw", "IN_MEMORY_BYTES", "release"]

#: Running sums larger than this [bytes] are kept in a memory-mapped temporary file.
IN_MEMORY_BYTES = 256 * 2**20


def _grey(value) -> bool:
    return isinstance(value, (int, float, np.floating)) and not isinstance(value, bool)


@dataclass(frozen=True)
class ReusePlan:
    """
    What the draws of one budget share: the nominal camera and scene, and the frames
    [``origin``, ``stop``) that the windows of all draws can touch (a draw outside them is
    made from its own sums, the same arithmetic).

    Attributes
    ----------
    camera, scene
        The nominal camera and scene.
    origin, stop
        Frame indices: the running sums start at ``origin`` and are kept to ``stop``.
    sub_bands : int
        Spectral sub-bands of the nominal optics' blur (:func:`radiosim.imaging.sub_band_count`).
    reuse : bool
        Keep the sums between draws (``False``: each draw makes its own, from ``origin``).
    token : str
        Names the sums kept in each process.
    """

    camera: object
    scene: object
    origin: int
    stop: int
    sub_bands: int
    reuse: bool = True
    token: str = ""

    @staticmethod
    def supports(camera, scene) -> bool:
        """Whether draws on ``camera`` and ``scene`` can be formed from running sums: a
        single-channel snapshot camera, a grey scalar emissivity (not per region) and a
        reflected temperature that is none or one number."""
        if camera.channels is not None or is_rolling(camera):
            return False
        if not _grey(scene.emissivity) or not (scene.reflected_temperature is None
                                                or _grey(scene.reflected_temperature)):
            return False
        corner = scene.sample_unchecked(scene.first_frame,
                                        (slice(0, 1), slice(0, 1)))
        return corner.regions is None

    @classmethod
    def for_budget(cls, camera, scene, earliest: float, latest: float, reuse: bool = True):
        """The plan of a budget whose windows lie within [``earliest``, ``latest``] [s], or
        ``None`` if :meth:`supports` says no."""
        if not cls.supports(camera, scene):
            return None
        dt, zero = scene.dt, scene.frame_origin  # frame k starts at zero + k·dt [s]
        origin = max(0, math.floor((earliest - zero) / dt * (1 + 1e-12)))
        stop = math.ceil((latest - zero) / dt * (1 - 1e-12))
        if scene.n_frames is not None:
            stop = min(scene.n_frames, stop)
        return cls(camera, scene, origin, max(stop, origin + 1),
                   sub_band_count(camera.optics.psf), bool(reuse), uuid.uuid4().hex)


class FrameSums:
    """
    Running sums over frames of each sample's radiance at unit emissivity, emission only, per
    sub-band: ``sums[j - origin]`` = Σ L(T_k) over origin ≤ k < j [signal unit], for
    j = origin … stop (module docstring).

    Parameters
    ----------
    plan
        The budget's :class:`ReusePlan`.
    origin, stop
        The frames summed (default the plan's).
    """

    def __init__(self, plan: ReusePlan, origin: int | None = None, stop: int | None = None):
        scene = plan.scene.with_emissivity(1.0)
        if scene.reflected_temperature is not None:  # emission only: reflection added per draw
            scene.set_environment(**{**scene.environment, "reflected_temperature": None})
        self.origin = plan.origin if origin is None else origin
        self.stop = plan.stop if stop is None else stop
        self.scene = scene
        self.bands = plan.camera.response_model.sub_bands(plan.sub_bands)
        responses = [r for r, _ in self.bands]
        shape = (self.stop - self.origin + 1, len(responses), *scene.shape)
        self.sums = _storage(shape)
        self.sums[0] = 0.0
        for j, k in enumerate(range(self.origin, self.stop)):
            frame = sample_signals(scene, Window(scene.frame_start(k), scene.dt), responses)
            np.add(self.sums[j], frame, out=self.sums[j + 1])

    @property
    def nbytes(self) -> int:
        """Memory of the sums [bytes]."""
        return int(self.sums.nbytes)

    def holds(self, first: int, n: int) -> bool:
        """Whether frames ``first`` … ``first + n − 1`` lie within the sums."""
        return self.origin <= first and first + n <= self.stop

    def window_mean(self, window: Window) -> np.ndarray:
        """Ē per sub-band and sample over ``window`` [signal unit], (sub-bands, rows, cols)."""
        first, weights = self.scene.window_frames(window)
        lo, n = first - self.origin, weights.size
        sums = self.sums
        out = weights[0] * (sums[lo + 1] - sums[lo])
        scratch = np.empty_like(out)
        inner = weights[1:-1]
        if inner.size and np.all(inner == inner[0]):
            np.subtract(sums[lo + n - 1], sums[lo + 1], out=scratch)
            scratch *= inner[0]
            out += scratch
        else:
            for j, w in enumerate(inner, start=1):
                np.subtract(sums[lo + j + 1], sums[lo + j], out=scratch)
                scratch *= w
                out += scratch
        if n > 1:
            np.subtract(sums[lo + n], sums[lo + n - 1], out=scratch)
            scratch *= weights[-1]
            out += scratch
        return out


def _storage(shape) -> np.ndarray:
    """A float64 array of ``shape``: in memory, or above :data:`IN_MEMORY_BYTES` in an
    anonymous temporary file (removed when the array goes)."""
    if math.prod(shape) * 8 <= IN_MEMORY_BYTES:
        return np.empty(shape)
    with tempfile.TemporaryFile(prefix="radiosim-sums-") as handle:
        return np.memmap(handle, dtype=np.float64, mode="w+", shape=shape)


#: The running sums kept in this process: one budget's at a time.
_KEPT: dict[str, FrameSums] = {}
_LOCK = threading.Lock()


def _kept(plan: ReusePlan) -> FrameSums:
    with _LOCK:
        sums = _KEPT.get(plan.token)
        if sums is None:
            _KEPT.clear()
            sums = _KEPT[plan.token] = FrameSums(plan)
        return sums


def release(plan: ReusePlan | None = None) -> None:
    """Let go of the running sums kept in this process (of ``plan``, or all)."""
    with _LOCK:
        if plan is None:
            _KEPT.clear()
        else:
            _KEPT.pop(plan.token, None)


def _surface(sub, mean: np.ndarray, emissivity: float, reflected: float | None) -> np.ndarray:
    """A sub-band's window-mean surface signal ε Ē + (1 − ε) L(T_refl) [signal unit] (the
    linear response's: the mean temperature)."""
    if not sub.radiometric:
        return mean
    field = emissivity * mean
    if reflected is not None:
        field += (1.0 - emissivity) * float(sub.grey_signal(reflected))
    return field


def _signal(camera, scene, bands, means: np.ndarray) -> np.ndarray:
    """Mean signal per pixel [signal unit] from the window means, as
    :func:`radiosim.imaging.image_signal` forms it (or the footprint mean without an image)."""
    integrator = camera.integrator(scene)
    rows, cols = integrator.region
    emissivity, reflected = float(scene.emissivity), scene.reflected_temperature
    if not camera.forms_image(scene):
        field = _surface(bands[0][0], means[0], emissivity, None)
        return integrator.pixel_mean(integrator.expand(field[rows, cols]))
    fields = [_surface(sub, mean, emissivity, reflected) for (sub, _), mean in zip(bands, means)]
    optics = camera.optics  # the path, the blur and the footprints as the image stage forms them
    return form_image(scene, integrator, bands, fields, optics.psf, optics.band,
                      optics.object_na(camera.fpa))


def draw(plan: ReusePlan, camera, scene, integration_time: float, t_start: float,
         rng) -> np.ndarray | None:
    """
    One draw's apparent temperature [K] (NaN where flagged) from running sums: ``camera`` and
    ``scene`` the draw's (the plan's, with the inputs applied), its window from ``t_start``
    [s] for ``integration_time`` [s], its noise from ``rng``. ``None`` where the draw changes
    what the sums hold (another response or number of sub-bands, an emissivity that is not
    one number, a camera the plan does not support): the caller measures it.
    """
    nominal = plan.camera
    if (camera.response_model is not nominal.response_model
            or sub_band_count(camera.optics.psf) != plan.sub_bands
            or camera.channels is not None or is_rolling(camera)
            or not _grey(scene.emissivity)
            or not (scene.reflected_temperature is None or _grey(scene.reflected_temperature))):
        return None
    window = camera.window(scene, integration_time, t_start)  # [s], checked
    check_measurable(camera, window.duration)
    first, weights = scene.window_frames(window)
    sums = _kept(plan) if plan.reuse else None
    if sums is None or not sums.holds(first, weights.size):
        # Outside the kept frames (or without reuse): this draw's own sums, the same arithmetic.
        sums = FrameSums(plan, min(plan.origin, first), first + weights.size)
    means = sums.window_mean(window)
    signal = _signal(camera, scene, sums.bands, means)
    unknown = np.full(signal.shape, np.nan)  # the scene truth is the nominal's: not needed
    stats = TensorStatistics(signal, unknown, unknown, unknown, int(weights.size))
    return camera.read_out(stats, window, scene, rng).apparent_temperature.astype(np.float64)

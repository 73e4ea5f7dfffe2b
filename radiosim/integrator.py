"""
The integrator: each detector pixel averages the scene over its active footprint and over the
integration window, in one streaming pass.

Space. Pixel (i, j) of pitch P (object space) owns the cell [o + jP, o + (j+1)P) along each
axis; its *active* footprint is a square of side A = P·√(fill factor) centred in the cell. Each
axis is cut at every sample edge and every footprint edge, so each *piece* lies in one scene
sample and in at most one footprint; its weight is its length over A. The weights of a pixel's
pieces sum to one, and the 2-D weight of a piece is the product of its row and column weights:
the exact area overlap. With an integer number p of samples per pixel, no offset and unit fill
factor the pieces are the samples and each pixel is the paper's p × p block.

Time. Frame k holds over [k·dt, (k+1)·dt); the window [t₀, t₀ + t_int] gives each frame the
weight (overlap with the window) / t_int. A window of n·dt that starts on a frame boundary
covers exactly n frames with weight 1/n.

Statistics. One pass over the window's frames accumulates, per pixel, the weighted mean of the
response signal and of T, the weighted mean of (T − c)² (for the standard deviation, with c a
per-pixel reference taken from the first frame, so no catastrophic cancellation), and the
maximum of T over every piece with positive weight. Memory holds one frame and a few per-pixel
arrays, whatever the number of frames.

References
----------
-   Whitenton, E. P., Heigel, J. C. & Ivester, R. W. (2009). The effects of integration time and
    size-of-source on the temperature measurement of segmented chip formation using infrared
    thermography. Proc. ASME MSEC2009-84319 (the p × p × n tensor method).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from radiosim.checks import check_time
from radiosim.errors import RadiosimError
from radiosim.interrupts import raise_if_interrupted
from radiosim.frame_reading import frame_blocks, prefetched
from radiosim.kernels.engines import get_engine, using_engine
from radiosim.kernels.merging import FootprintGroup, crop
from radiosim.response import Response
from radiosim.scenes.base import Region, Scene, SceneFrame
from radiosim.scenes.base import frame_weights  # noqa: F401 - its former home
from radiosim.units import readable_time

__all__ = [
    "EnginePass",
    "Window",
    "integration_window",
    "AxisFootprints",
    "axis_footprints",
    "FootprintIntegrator",
    "TensorStatistics",
    "integrate",
    "integrate_many",
    "Job",
    "check_scale",
]

_SNAP = 1e-9  # positions within this many samples of an integer are that integer
_UNBOUNDED = 2**31 - 1  # pixels along an axis of an array without a stated size
#: A pixel narrower than this fraction of a scene sample, or a window shorter than this fraction
#: of a frame, is a unit slip (µm given as metres, µs as seconds), not a measurement.
IMPLAUSIBLE_RATIO = 1e-3


def check_scale(scene: Scene, pixel_pitch: float | None = None, duration: float | None = None):
    """
    Refuse a pixel far smaller than a scene sample, or a window far shorter than a frame
    (ratio below :data:`IMPLAUSIBLE_RATIO`), naming the likely unit slip.
    """
    if pixel_pitch is not None and pixel_pitch / scene.dx < IMPLAUSIBLE_RATIO:
        raise RadiosimError(
            f"the scene's samples are {scene.dx:g} m and the camera's pixels {pixel_pitch:g} m: a "
            f"pixel would see {pixel_pitch / scene.dx:.2g} of one sample. Was dx given in µm as "
            f"metres? (dx = {scene.dx:g} µm is {scene.dx * 1e-6:g} m)")
    if duration is not None and duration / scene.dt < IMPLAUSIBLE_RATIO:
        raise RadiosimError(
            f"the scene's frames last {scene.dt:g} s and the integration {duration:g} s: the "
            f"window would see {duration / scene.dt:.2g} of one frame. Was dt given in µs as "
            f"seconds? (dt = {scene.dt:g} µs is {scene.dt * 1e-6:g} s)")


@dataclass(frozen=True)
class Window:
    """
    The integration window [start, start + duration].

    Attributes
    ----------
    start : float
        Start [s].
    duration : float
        Integration time [s].
    alignment : str
        How the start was chosen: ``"given"``, ``"centred"`` on the scene's event, or
        ``"scene start"`` (no start given and the scene has no event).
    frames : tuple of int or None
        Frames [first, stop) of the window's, with their weights in the whole window, that
        this window stands for: a part of a window, integrated into partial sums
        (:func:`radiosim.acquisition.frame_ranges`); ``None``: all of them.
    """

    start: float
    duration: float
    alignment: str = "given"
    frames: tuple[int, int] | None = None

    @property
    def stop(self) -> float:
        """End of the window [s]."""
        return self.start + self.duration


def integration_window(scene: Scene, duration: float, t_start: float | None = None,
                       inside: bool = True) -> Window:
    """
    The window of one integration: from ``t_start`` [s] if given, else centred on the scene's
    ``event_time``, else from the scene's first frame (t = 0, or the first frame holding data
    for a scene that keeps a file's own time origin, such as an FEA export starting at 5 µs).
    The one place a window is checked: ``duration`` a time > 0 (and not far shorter than a
    frame: a unit slip), ``t_start`` a time ≥ 0, and (unless not ``inside``: a start only) the
    window inside the scene's frames (:func:`frame_weights`).

    Examples
    --------
    >>> from radiosim.scenes import UniformBlackbody
    >>> integration_window(UniformBlackbody(300.0), 1e-6)
    Window(start=0.0, duration=1e-06, alignment='scene start', frames=None)
    """
    duration = check_time(duration, "integration_time")
    check_scale(scene, duration=duration)
    if t_start is not None:
        start = check_time(t_start, "t_start", positive=False)
        first = scene.frame_start(scene.first_frame)  # [s] where the scene's data start
        if start < 0 or (start < first and _snap(start / scene.dt) < _snap(first / scene.dt)):
            data = ("the scene's first frame (t = 0)" if first == 0 else
                    f"the scene's data, which start at {readable_time(first)} (the first time "
                    f"stamp of {scene.describe().get('source', 'its file')})")
            raise RadiosimError(f"t_start = {readable_time(start)} is before {data}")
        window = Window(start, duration, "given")
    elif scene.event_time is None:
        window = Window(scene.frame_start(scene.first_frame), duration,
                        "scene start")
    else:
        start = scene.event_time - 0.5 * duration
        if start < 0:
            raise RadiosimError(
                f"a {readable_time(duration)} window centred on the scene's event at "
                f"{readable_time(scene.event_time)} "
                "would start before the first frame; give t_start"
            )
        window = Window(start, duration, "centred")
    if inside:
        scene.window_frames(window)
    return window


def _snap(value: float) -> float:
    nearest = round(value)
    return float(nearest) if abs(value - nearest) <= _SNAP * max(1.0, abs(value)) else value


@dataclass(frozen=True)
class AxisFootprints:
    """
    The pieces of one axis and the pixels they belong to.

    Attributes
    ----------
    source : numpy.ndarray of int
        Scene sample index of each piece.
    weight : numpy.ndarray of float
        Piece length over the active width (dimensionless; sums to 1 per pixel).
    starts : numpy.ndarray of int
        Index of each pixel's first piece (pieces of a pixel are contiguous).
    """

    source: np.ndarray
    weight: np.ndarray
    starts: np.ndarray

    @property
    def n_pixels(self) -> int:
        return int(self.starts.size)

    @property
    def counts(self) -> np.ndarray:
        """Number of pieces of each pixel."""
        return np.diff(np.append(self.starts, self.source.size))

    @property
    def span(self) -> slice:
        """The scene samples the pieces touch, as a slice."""
        return slice(int(self.source[0]), int(self.source[-1]) + 1)

    @property
    def is_identity(self) -> bool:
        """True if the pieces are the samples of :attr:`span`, in order, each once."""
        return bool(np.array_equal(self.source, np.arange(self.span.start, self.span.stop)))

    @property
    def uniform_weights(self) -> bool:
        """True if all pieces of every pixel weigh the same (pixel = whole samples)."""
        first = self.weight[self.starts]
        return bool(np.all(self.weight == np.repeat(first, self.counts)))


def axis_footprints(
    n_samples: int, sample_pitch: float, pixel_pitch: float, fill_factor: float,
    max_pixels: int, origin: float = 0.0, axis: str = "x",
) -> AxisFootprints:
    """
    Pieces of one axis for pixels of pitch ``pixel_pitch`` over ``n_samples`` samples.

    Pixels whose whole cell lies inside the scene are kept, up to ``max_pixels``.

    Parameters
    ----------
    n_samples
        Scene samples along the axis.
    sample_pitch
        Scene sample pitch [m].
    pixel_pitch
        Detector pixel pitch in object space [m].
    fill_factor
        Active area over cell area, in (0, 1]; the active width is pitch × √fill factor.
    max_pixels
        Pixels of the array along this axis.
    origin
        Offset of the first pixel cell from the scene's first sample edge [m], ≥ 0.
    axis
        Name of the axis, for error messages.

    Examples
    --------
    >>> ax = axis_footprints(10, 1.0, 2.5, 1.0, max_pixels=8)
    >>> ax.n_pixels, ax.source.tolist(), ax.weight.tolist()
    (4, [0, 1, 2, 2, 3, 4, 5, 6, 7, 7, 8, 9], [0.4, 0.4, 0.2, 0.2, 0.4, 0.4, 0.4, 0.4, 0.2, 0.2, 0.4, 0.4])
    """
    if not 0 < fill_factor <= 1:
        raise RadiosimError(f"fill factor must be in (0, 1], got {fill_factor!r}")
    if origin < 0 or not math.isfinite(origin):
        raise RadiosimError(f"{axis} origin must be finite and ≥ 0 [m], got {origin!r}")
    if int(n_samples) != n_samples:
        raise RadiosimError(f"{axis}: the number of samples must be a whole number, got "
                            f"{n_samples!r}")
    return _axis_footprints(int(n_samples), float(sample_pitch), float(pixel_pitch),
                            float(fill_factor), int(max_pixels), float(origin), str(axis))


@functools.lru_cache(maxsize=64)
def _axis_footprints(n_samples: int, sample_pitch: float, pixel_pitch: float,
                     fill_factor: float, max_pixels: int, origin: float,
                     axis: str) -> AxisFootprints:
    """:func:`axis_footprints`, once per set of arguments (a study measures the same array
    many times): its arrays are read-only."""
    pitch = pixel_pitch / sample_pitch  # in samples
    active = pitch * math.sqrt(fill_factor)
    first = origin / sample_pitch
    n_fit = math.floor(_snap((n_samples - first) / pitch)) if n_samples > first else 0
    n_pixels = min(int(max_pixels), n_fit)
    if n_pixels < 1:
        raise RadiosimError(
            f"no whole pixel fits along {axis}: the scene spans {n_samples * sample_pitch:.4g} m "
            f"from the origin {origin:.4g} m, the pixel pitch is {pixel_pitch:.4g} m (the footprint "
            "is larger than the frame)"
        )
    source, weight, starts = [], [], []
    for j in range(n_pixels):
        a = _snap(first + j * pitch + 0.5 * (pitch - active))
        b = _snap(a + active)
        cuts = [a, *range(math.floor(a) + 1, math.ceil(b)), b]
        starts.append(len(source))
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            if hi > lo:
                source.append(min(math.floor(lo), n_samples - 1))
                weight.append((hi - lo) / active)
    arrays = (np.array(source, dtype=np.intp), np.array(weight), np.array(starts, dtype=np.intp))
    for array in arrays:
        array.flags.writeable = False
    return AxisFootprints(*arrays)


@dataclass(frozen=True)
class TensorStatistics:
    """
    Per-pixel statistics of the scene over each pixel's footprint × window ("tensor").

    Attributes
    ----------
    signal_mean : numpy.ndarray
        Weighted mean of the response signal [response unit: K or photons s⁻¹ m⁻² sr⁻¹].
    mean : numpy.ndarray
        Weighted mean of T [K].
    std : numpy.ndarray
        Weighted population standard deviation of T [K] (ddof = 0).
    max : numpy.ndarray
        Maximum of T over samples with positive weight [K].
    n_frames : int
        Frames that contributed.
    """

    signal_mean: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    max: np.ndarray
    n_frames: int


class FootprintIntegrator:
    """
    Exact area weights of a pixel array over a scene grid, applied frame by frame.

    Parameters
    ----------
    rows, cols
        The :class:`AxisFootprints` of the y (row) and x (column) axes.
    pixel_pitch
        Pixel pitch in object space [m], for the unit-slip check (:func:`check_scale`).
    """

    def __init__(self, rows: AxisFootprints, cols: AxisFootprints,
                 pixel_pitch: float = math.inf):
        self.rows, self.cols = rows, cols
        self.shape = (rows.n_pixels, cols.n_pixels)
        #: Pixel pitch in object space [m] (∞ when unknown: no scale check).
        self.pixel_pitch = pixel_pitch
        #: The region of the scene the pieces touch; frames are read over it only.
        self.region: Region = (rows.span, cols.span)
        self._row_index = None if rows.is_identity else rows.source - rows.span.start
        self._col_index = None if cols.is_identity else cols.source - cols.span.start
        self._row_weight = rows.weight[:, None]
        self._col_weight = cols.weight[None, :]
        self._uniform = rows.uniform_weights and cols.uniform_weights
        if self._uniform:
            # Each pixel's pieces weigh the same: sum first, scale once per pixel.
            self._pixel_weight = np.outer(rows.weight[rows.starts], cols.weight[cols.starts])

    @classmethod
    def for_scene(cls, scene: Scene, pixel_pitch: float, fill_factor: float,
                  array_shape: tuple[int, int] | None, origin=(0.0, 0.0)) -> FootprintIntegrator:
        """The integrator of a pixel array [m] laid on ``scene``, anchored at its top-left
        (``array_shape`` ``None``: as many pixels as the scene holds)."""
        array_shape = array_shape or (_UNBOUNDED, _UNBOUNDED)
        check_scale(scene, pixel_pitch)
        rows = axis_footprints(scene.shape[0], scene.dx, pixel_pitch, fill_factor,
                               array_shape[0], origin[0], axis="y (rows)")
        cols = axis_footprints(scene.shape[1], scene.dx, pixel_pitch, fill_factor,
                               array_shape[1], origin[1], axis="x (columns)")
        return cls(rows, cols, pixel_pitch)

    def expand(self, field: np.ndarray) -> np.ndarray:
        """Values of a field over :attr:`region` on the piece grid (a view when possible)."""
        if self._row_index is not None:
            field = field[self._row_index]
        if self._col_index is not None:
            field = field[:, self._col_index]
        return field

    def pixel_sum(self, pieces: np.ndarray, ufunc=np.add) -> np.ndarray:
        """Reduce piece values to pixels with ``ufunc`` (unweighted)."""
        partial = ufunc.reduceat(pieces, self.rows.starts, axis=0)
        return ufunc.reduceat(partial, self.cols.starts, axis=1)

    def pixel_mean(self, pieces: np.ndarray) -> np.ndarray:
        """Area-weighted mean of piece values over each pixel's active footprint."""
        if self._uniform:
            return self.pixel_sum(pieces) * self._pixel_weight
        weighted = np.add.reduceat(pieces * self._row_weight, self.rows.starts, axis=0)
        return np.add.reduceat(weighted * self._col_weight, self.cols.starts, axis=1)

    def pixel_max(self, pieces: np.ndarray) -> np.ndarray:
        """Maximum of piece values over each pixel's active footprint."""
        return self.pixel_sum(pieces, np.maximum)

    def broadcast(self, per_pixel: np.ndarray) -> np.ndarray:
        """A per-pixel array repeated onto the piece grid."""
        return np.repeat(np.repeat(per_pixel, self.rows.counts, axis=0), self.cols.counts, axis=1)

    def pixel_rows(self, start: int, stop: int) -> FootprintIntegrator:
        """The integrator of pixel rows ``start`` to ``stop − 1`` alone (same columns)."""
        rows = self.rows
        ends = np.append(rows.starts, rows.source.size)
        first, last = int(ends[start]), int(ends[stop])
        part = AxisFootprints(rows.source[first:last], rows.weight[first:last],
                              rows.starts[start:stop] - first)
        return FootprintIntegrator(part, self.cols, self.pixel_pitch)


def stack_rows(parts: list[TensorStatistics]) -> TensorStatistics:
    """The statistics of consecutive pixel rows, stacked into one array's (``n_frames``: the
    most any row's window touched)."""
    return TensorStatistics(
        *(np.vstack([getattr(p, name) for p in parts])
          for name in ("signal_mean", "mean", "std", "max")),
        n_frames=max(p.n_frames for p in parts))


@dataclass(frozen=True, eq=False)
class Job:
    """
    One measurement's integration: footprints, window and response.

    Attributes
    ----------
    integrator : FootprintIntegrator
        The pixel array's footprints on the scene.
    window : Window
        Integration window [s].
    response : Response
        Signal per sample.
    """

    integrator: FootprintIntegrator
    window: Window
    response: Response


class _Accumulator:
    """The running sums of one job (see :func:`integrate_many`)."""

    def __init__(self, job: Job, scene: Scene):
        self.job = job
        self.first, self.weights = scene.window_frames(job.window)
        self.stop = self.first + self.weights.size
        self.reference = None
        self.signal_is_temperature = True

    def add(self, frame: SceneFrame, k: int, signal: np.ndarray):
        integrator = self.job.integrator
        weight = self.weights[k - self.first]
        t = integrator.expand(frame.temperature)  # [K], on the piece grid
        if self.reference is None:
            self.reference = integrator.pixel_mean(t)
            self.reference_pieces = integrator.broadcast(self.reference)
            self.mean_dev = np.zeros(integrator.shape)
            self.mean_sq = np.zeros(integrator.shape)
            self.signal_mean = np.zeros(integrator.shape)
            self.t_max = np.full(integrator.shape, -np.inf)
        deviation = t - self.reference_pieces  # [K]
        self.mean_dev += weight * integrator.pixel_mean(deviation)
        self.mean_sq += weight * integrator.pixel_mean(deviation * deviation)
        np.maximum(self.t_max, integrator.pixel_max(t), out=self.t_max)
        if signal is not frame.temperature:  # the linear response's signal is T: mean below
            self.signal_is_temperature = False
            self.signal_mean += weight * integrator.pixel_mean(integrator.expand(signal))

    def statistics(self) -> TensorStatistics:
        mean_dev, mean_sq = self.mean_dev, self.mean_sq
        if self.job.window.frames is not None:  # a part: its weights sum to less than 1
            total = float(np.sum(self.weights))
            mean_dev, mean_sq = mean_dev / total, mean_sq / total
        mean = self.reference + mean_dev
        variance = np.clip(mean_sq - mean_dev * mean_dev, 0.0, None)
        return TensorStatistics(
            signal_mean=mean if self.signal_is_temperature else self.signal_mean,
            mean=mean, std=np.sqrt(variance), max=self.t_max, n_frames=int(self.weights.size))


def _union(regions: list[Region]) -> Region:
    return (slice(min(r[0].start for r in regions), max(r[0].stop for r in regions)),
            slice(min(r[1].start for r in regions), max(r[1].stop for r in regions)))


def _within(frame: SceneFrame, outer: Region, inner: Region) -> SceneFrame:
    """The part of a frame read over ``outer`` that covers ``inner`` (views, no copies)."""
    if inner == outer:
        return frame
    rows = slice(inner[0].start - outer[0].start, inner[0].stop - outer[0].start)
    cols = slice(inner[1].start - outer[1].start, inner[1].stop - outer[1].start)

    def cut(values):
        return values[rows, cols] if isinstance(values, np.ndarray) else values

    return SceneFrame(cut(frame.temperature), cut(frame.emissivity), cut(frame.regions),
                      frame.region_emissivity, frame.index, cut(frame.reflected_temperature))


def integrate_many(scene: Scene, jobs: list[Job], progress=None,
                   engine: str | None = None, emission_only: bool = False
                   ) -> list[TensorStatistics]:
    """
    Integrate several measurements of one scene in one pass: each frame any window touches is
    read (or generated) once, over the union of the jobs' regions, and feeds every job whose
    window holds it.

    Jobs with the same footprints share one engine pass per frame and response
    (:class:`EnginePass`): the frame's per-pixel sums (of T − c, (T − c)², the signal, and the
    maximum) are formed once at unit weight, and each job adds them with its own time weight.
    The reference c is then the group's (the pixel means of its first frame), so results
    equal a job integrated alone to rounding (1e-12 relative), not bit for bit. A response
    without a signal table, or a scene that reflects (without ``emission_only``), takes every
    job on its own in numpy.

    Parameters
    ----------
    scene
        The scene.
    jobs
        The measurements (:class:`Job`).
    progress
        Called as ``progress(done, total)`` after each block of frames (``done`` frames of
        ``total``).
    engine
        An engine's name (:data:`radiosim.kernels.engines.ENGINES`) or
        :class:`~radiosim.kernels.engines.Engine`;
        ``None``: the chosen one (:func:`radiosim.kernels.engines.get_engine`: ``set_engine``,
        ``RADIOSIM_ENGINE``, else compiled).
    emission_only
        The signal need hold each sample's own emission only (the caller adds reflections), so
        a reflecting scene may take the engine's pass.
    """
    if not jobs:
        return []
    # The engines integrate each sample's own emission from the responses' signal tables; a
    # scene that reflects, or a response without a table, is integrated job by job in numpy,
    # whose Planck signal adds (1 − ε)·L(T_refl) — unless the caller forms the reflected light
    # itself (the camera's image stage: ``emission_only``).
    reflects = not emission_only and scene.reflected_temperature is not None and any(
        job.response.radiometric for job in jobs)
    if not reflects and all(job.response.has_table for job in jobs):
        engine_pass = EnginePass(scene, jobs, engine)
        frames, region = engine_pass.frames, engine_pass.region
        done = 0
        with using_engine(engine_pass.engine):  # a scene's own terms too
            # Blocks of consecutive frames, one engine call each (frame_reading.frame_blocks).
            for sample, temperature, n in frame_blocks(scene, frames, region):
                raise_if_interrupted()  # a swallowed interrupt: raised again, block by block
                engine_pass.add(temperature, sample, region)
                done += n
                if progress is not None:
                    progress(done, len(frames))
        return engine_pass.statistics()
    accumulators = [_Accumulator(job, scene) for job in jobs]
    frames = sorted(set().union(*(range(a.first, a.stop) for a in accumulators)))
    region = _union([a.job.integrator.region for a in accumulators])
    with using_engine(engine):  # a scene's own terms follow the engine argument
        for done, frame in enumerate(prefetched(scene, frames, region), start=1):
            raise_if_interrupted()  # a swallowed interrupt: raised again, frame by frame
            k = frame.index
            signals = {}
            for acc in accumulators:
                if not acc.first <= k < acc.stop:
                    continue
                inner = acc.job.integrator.region
                mine = _within(frame, region, inner)
                key = (id(acc.job.response), inner[0].start, inner[0].stop, inner[1].start,
                       inner[1].stop)
                if key not in signals:
                    signals[key] = (mine, acc.job.response.signal(mine))  # [unit] per sample
                mine, signal = signals[key]
                acc.add(mine, k, signal)
            if progress is not None:
                progress(done, len(frames))
    return [acc.statistics() for acc in accumulators]


class EnginePass:
    """
    Jobs integrated through the engine from the blocks of frames the caller feeds it
    (:meth:`add`), in frame order: :func:`integrate_many`'s pass, and the image stage's
    (:func:`radiosim.imaging.image_statistics`, which feeds the same blocks to its sub-band
    sums). Per block and footprint group, one engine pass (the engine's
    ``accumulate_merged``) gives each pixel's frame mean m_k and within-frame variance v_k
    (about the previous frame's means, so the deviations are small) and merges them into each
    job with its time weight w_k by the parallel update of Chan, Golub & LeVeque (1979):
    δ = m_k − mean, mean += δ·w_k/n', M2 += w_k·v_k + δ²·n·w_k/n'. A pixel that does not
    change keeps an exactly zero spread. Each sample's own emission only: the jobs' responses
    must have signal tables, and what a scene reflects is the caller's (the image stage's).

    Attributes
    ----------
    frames : list of int
        The frames any job's window holds, sorted.
    region : Region
        The union of the jobs' regions.
    """

    def __init__(self, scene: Scene, jobs: list[Job], engine=None):
        #: The engine of the pass (the scene's own terms follow it: :func:`using_engine`).
        self.engine = engine = get_engine(engine)
        tableless = [job.response.name for job in jobs if not job.response.has_table]
        if tableless:
            raise RadiosimError(f"an engine pass takes responses with signal tables, got "
                                f"{', '.join(tableless)} (integrate_many integrates those)")
        self._merged = [_Merged(_Accumulator(job, scene)) for job in jobs]
        groups: dict[int, FootprintGroup] = {}
        for m in self._merged:
            groups.setdefault(id(m.job.integrator),
                             FootprintGroup(m.job.integrator, engine)).members.append(m)
        for group in groups.values():
            group.start()
        self._groups = list(groups.values())
        self.frames = sorted(set().union(*(range(m.first, m.stop) for m in self._merged)))
        self.region = _union([m.job.integrator.region for m in self._merged])

    def add(self, temperature: np.ndarray, sample: SceneFrame, region: Region) -> None:
        """Frames ``sample.index``, … (``temperature``: one 2-D frame or a 3-D block of
        consecutive frames sharing their maps, read over ``region``, which holds
        :attr:`region`; ``sample``: the first one's scene frame over ``region``)."""
        start = sample.index
        stop = start + (temperature.shape[0] if temperature.ndim == 3 else 1)
        for group in self._groups:
            first, last = max(start, group.first), min(stop, group.stop)
            if first < last:
                inner = group.integrator.region
                mine = crop(temperature, region, inner)
                if mine.ndim == 3:
                    mine = mine[first - start:last - start]
                group.merge(mine, _within(sample, region, inner), first)

    def statistics(self) -> list[TensorStatistics]:
        """Each job's tensor statistics, in the order of the jobs (the pass is spent: its
        groups and jobs let go of each other, so its sums are freed at once, not by the
        cycle collector — a window's parts run one pass each)."""
        out = [m.statistics() for m in self._merged]
        for group in self._groups:
            group.members.clear()
        for m in self._merged:
            m.group = None
        return out


class _Merged:
    """One job's moments merged frame by frame (Chan et al. 1979) by the engine, in its
    group's stacked accumulators."""

    def __init__(self, acc: _Accumulator):
        self.job, self.first, self.stop, self.weights = acc.job, acc.first, acc.stop, acc.weights
        self.group, self.slot = None, 0
        self.has_signal = False  # stays False while the signal is the temperature

    def statistics(self) -> TensorStatistics:
        state, b = self.group.state, self.slot
        mean = state.mean[b].copy()
        return TensorStatistics(
            signal_mean=state.signal[b].copy() if self.has_signal else mean,
            mean=mean, std=np.sqrt(state.m2[b] / state.count[b]), max=state.max[b].copy(),
            n_frames=int(self.weights.size))


def integrate(
    scene: Scene,
    integrator: FootprintIntegrator,
    window: Window,
    response: Response,
    engine: str | None = None,
    emission_only: bool = False,
) -> TensorStatistics:
    """
    Stream the window's frames through the response and the integrator, and accumulate tensor
    statistics.

    Frames that are slow to produce (scene evaluation, disk reads) are read ahead on a worker
    thread (:mod:`radiosim.frame_reading`), so producing them overlaps with integrating the
    previous ones; small ones (:data:`~radiosim.frame_reading.INLINE_BYTES`) are made here.

    Parameters
    ----------
    scene
        The scene.
    integrator
        The pixel array's footprints on the scene.
    window
        Integration window [s].
    response
        Signal per sample (:class:`~radiosim.response.Response`).
    engine
        As for :func:`integrate_many`.
    emission_only
        As for :func:`integrate_many`.

    Returns
    -------
    TensorStatistics
    """
    return integrate_many(scene, [Job(integrator, window, response)], engine=engine,
                          emission_only=emission_only)[0]

"""
Acquisition: how a camera takes its frames — the stages of one measurement after the scene, and
the modes that chain measurements in time.

The stages take what they need as data, never the camera (:meth:`Camera.measure
<radiosim.camera.Camera.measure>` and :func:`measure_many` call them in order and they
return):

1. :func:`tensor_statistics`: the noise-free part — from each camera's :class:`Exposure` (its
   footprints, window, response, image and rows' timing), each pixel's mean signal over its
   footprint × window with the scene-truth statistics of the same tensor (one pass over the
   scene's frames for every snapshot camera; a rolling shutter's rows in a pass of their own,
   one window per row; the optics' image where the camera forms one);
2. :func:`read_out`: from a camera's :class:`ReadOut` (its calibration, electronics, fixed
   pattern, NUC, étendue and the optics' own emission), the optics (:func:`photoelectrons`),
   the electronics and the calibration turn those statistics into a
   :class:`~radiosim.measurement.Measurement`.

Timing and modes, functions taking the camera first (as pvlib keeps its models beside
``ModelChain``): :func:`readout_shape`, :func:`frame_period`, :func:`record` (frames spaced by
the real frame period) and :func:`superframe` (cycled integration times merged per pixel).
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from radiosim.checks import check_positive, check_rng
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim import integrator as _integrator  # its integrate_many looked up per call
from radiosim.imaging import image_statistics
from radiosim.integrator import (FootprintIntegrator, Job, TensorStatistics, Window,
                                 integration_window, stack_rows)
from radiosim.measurement import Measurement
from radiosim.optics import collect
from radiosim.scenes.base import Scene
from radiosim.units import readable_time

__all__ = ["readout_shape", "frame_period", "check_frame_period", "check_readout_fits",
           "check_measurable", "frame_dtype", "is_rolling", "instrument_signal", "Exposure",
           "ReadOut", "photoelectrons", "tensor_statistics", "rolling_statistics",
           "FRAME_CHUNK", "PART_SAMPLES", "part_frames", "frame_ranges", "merge_statistics",
           "shared_statistics", "split_statistics", "read_out",
           "measure_many", "measure_many_statistics", "ChannelStatistics", "channel_cases",
           "record", "superframe"]


# -- timing -------------------------------------------------------------------------------------


def readout_shape(camera) -> tuple[int, int]:
    """The window ``camera``'s array reads, as its number of rows and columns: the array's
    shape, or one pixel if it has none."""
    return tuple(camera.fpa.shape) if camera.fpa.shape is not None else (1, 1)


def frame_period(camera, integration_time: float) -> float:
    """
    ``camera``'s frame period [s] at ``integration_time`` [s]: the array's own (integration
    and readout, :meth:`~radiosim.fpa.FocalPlaneArray.frame_period`), or the frame rate's if
    that is slower. A camera with neither a frame rate nor a readout time has none.
    """
    own = camera.fpa.frame_period(integration_time, readout_shape(camera))
    if camera.frame_rate is not None:
        return max(1.0 / camera.frame_rate, own)
    if camera.fpa.readout_time(readout_shape(camera)) == 0:
        raise RadiosimError(f"{camera.name} has no frame rate nor readout time; set "
                            "frame_rate_hz or the [fpa] readout times")
    return own


def check_frame_period(camera, integration_time: float, what: str | None = None):
    """
    Refuse (:class:`RadiosimError`) an ``integration_time`` [s] that, with its readout, does not
    fit in ``camera``'s frame period (a camera without a frame rate takes any). ``what``: how
    the caller names the integration time in the message (e.g. a command's option and the
    value as typed); default ``integration time … s``.
    """
    if camera.frame_rate is None:
        return
    needed = camera.fpa.frame_period(integration_time, readout_shape(camera))  # [s]
    period = 1.0 / camera.frame_rate  # [s]
    if needed > period * (1 + 1e-12):
        raise RadiosimError(
            (what or f"integration time {readable_time(integration_time)}")
            + (f" with its readout ({needed * 1e6:g} µs)" if needed != integration_time else "")
            + f" exceeds the frame period of {camera.name} ({period * 1e6:g} µs at "
            f"{camera.frame_rate:g} Hz); expected at most "
            f"{(period - (needed - integration_time)) * 1e6:g} µs")


def check_readout_fits(camera):
    """
    Refuse (:class:`RadiosimError`) a ``camera`` whose array's readout leaves no integration
    time within its frame period: integrate-then-read (``itr``) needs readout < period,
    integrate-while-read (``iwr``) readout ≤ period. A camera without a frame rate takes any.
    """
    if camera.frame_rate is None:
        return
    fpa, (rows, cols) = camera.fpa, readout_shape(camera)
    readout = fpa.readout_time((rows, cols))  # [s]
    period = 1.0 / camera.frame_rate  # [s]
    if readout < period or (fpa.readout == "iwr" and readout <= period * (1 + 1e-12)):
        return
    raise RadiosimError(
        f"camera {camera.name!r}: reading its {rows} × {cols} pixels takes "
        f"{readout * 1e6:g} µs ({rows} rows × row_time_us = {fpa.row_time * 1e6:g}, "
        f"{rows * cols} pixels × pixel_time_us = {fpa.pixel_time * 1e6:g}, readout_overhead_us "
        f"= {fpa.readout_overhead * 1e6:g}), which leaves no integration time in a frame at "
        f"frame_rate_hz = {camera.frame_rate:g} ({period * 1e6:g} µs); expected a readout "
        f"{'at most' if fpa.readout == 'iwr' else 'under'} {period * 1e6:g} µs (fewer rows in "
        f"[fpa] shape, shorter row or pixel times, or a lower frame rate)")


def check_measurable(camera, integration_time: float):
    """Refuse (:class:`RadiosimError`, naming the camera, the integration time and the
    limits) an integration time [s] at which no temperature of ``camera``'s calibration range
    gives a reading (:meth:`~radiosim.calibration.Calibration.check_measurable`)."""
    camera.calibration(integration_time).check_measurable(camera.name)


def frame_dtype(scene: Scene):
    """The dtype in which the kernels read ``scene``'s frames (float32 stays float32; a
    scene that makes its frames: float64)."""
    try:
        block = scene.block_unchecked(0, 1, tuple(slice(0, n) for n in scene.shape))
    except Exception:  # noqa: BLE001 — a scene that makes its frames has no stored block
        block = None
    return "float64" if block is None else block.dtype


def is_rolling(camera) -> bool:
    """Whether ``camera``'s rows integrate over staggered windows (a rolling shutter)."""
    return camera.fpa.shutter == "rolling" and camera.fpa.row_time > 0


# -- the optics: signal → photo-electrons -------------------------------------------------------


def instrument_signal(camera, temperature: float | None = None) -> float:
    """The optics' own emission into one of ``camera``'s pixels [signal unit] at
    ``temperature`` [K] (default the optics' instrument temperature); 0 for the linear
    response."""
    if not camera.response_model.radiometric:
        return 0.0
    return camera.optics.emitted_radiance(camera.fpa.quantum_efficiency, temperature)


@dataclasses.dataclass(frozen=True)
class Exposure:
    """
    One camera's window on a scene, as the noise-free stage needs it
    (:meth:`Camera.exposure <radiosim.camera.Camera.exposure>`).

    Attributes
    ----------
    name : str
        The camera's name (for messages).
    footprints : tuple
        The pixels' footprints: pixel pitch [m], fill factor [1], array shape (rows, columns)
        or ``None`` (as many as the scene holds) and origin (y, x) [m]
        (:meth:`FootprintIntegrator.for_scene <radiosim.integrator.FootprintIntegrator.for_scene>`).
    window : Window
        The integration window [s].
    response : Response
        The response model.
    image : tuple or None
        Where the camera forms an image: its PSFs, band (λ1, λ2) [m] and object-side numerical
        aperture [1] (:func:`radiosim.imaging.image_statistics`); else ``None``.
    row_time : float or None
        A rolling shutter's row time [s]: pixel row i's window starts i·row_time after the
        first's; ``None`` for a snapshot.
    """

    name: str
    footprints: tuple
    window: Window
    response: object
    image: tuple | None = None
    row_time: float | None = None


@dataclasses.dataclass(frozen=True)
class ReadOut:
    """
    What the stages after the integrator need of one camera at one integration time
    (:meth:`Camera.readout <radiosim.camera.Camera.readout>`).

    Attributes
    ----------
    camera
        The camera the measurement records (not called).
    calibration : Calibration
        DN → apparent temperature at this integration time.
    fpa : FocalPlaneArray
        Its fixed pattern.
    electronics : Electronics
        Dark charge, noise, full well, ADC.
    nuc : NonUniformityCorrection or None
        The correction applied to counts.
    rate_per_signal : float
        Electron rate per unit of response signal [e⁻ s⁻¹ per signal unit] (the étendue).
    instrument_signal : float
        The optics' own emission into a pixel [signal unit].
    unit : str
        The response signal's unit.
    """

    camera: object
    calibration: object
    fpa: object
    electronics: object
    nuc: object
    rate_per_signal: float
    instrument_signal: float
    unit: str


def photoelectrons(readout: ReadOut, signal_mean, integration_time: float):
    """Mean photo-electrons [e⁻] of a camera's pixels from their mean signal ``signal_mean``
    [signal unit] over ``integration_time`` [s]: the signal plus the optics' own emission,
    through the étendue (:func:`radiosim.optics.collect`), as ``readout`` states them."""
    return collect(signal_mean + readout.instrument_signal, readout.rate_per_signal,
                   integration_time)


# -- the noise-free stage: tensor statistics ----------------------------------------------------


def _passes(progress, n: int):
    """Per-pass callbacks reporting ``progress(done, total)`` over ``n`` passes of about the
    same number of frames each (pass k's frame j counts as k·total + j of n·total)."""
    if progress is None:
        return [None] * n
    return [lambda done, total, k=k: progress(k * total + done, n * total) for k in range(n)]


def rolling_statistics(scene: Scene, exposure: Exposure, integrator, progress=None
                       ) -> TensorStatistics:
    """A rolling shutter's statistics: pixel row i of ``integrator`` integrates over the
    exposure's window delayed by i·row_time, all rows in one pass over the frames
    (``progress(done, total)`` after each)."""
    if exposure.image is not None:
        raise RadiosimError(
            f"{exposure.name}: a rolling shutter with a PSF, reflections or a path would need "
            "one image per row; measure with shutter = 'snapshot' or without them")
    window = exposure.window
    delays = np.arange(integrator.shape[0]) * exposure.row_time  # [s]
    last = window.start + window.duration + delays[-1]
    if scene.duration is not None and last > scene.duration * (1 + 1e-12):
        raise RadiosimError(
            f"the rolling shutter's last row integrates until {readable_time(last)}, past the "
            f"scene's end at {readable_time(scene.duration)} (row time "
            f"{readable_time(exposure.row_time)} × "
            f"{integrator.shape[0] - 1} rows)")
    jobs = [Job(integrator.pixel_rows(i, i + 1),
                Window(window.start + delay, window.duration, window.alignment),
                exposure.response) for i, delay in enumerate(delays)]
    return stack_rows(_integrator.integrate_many(scene, jobs, progress))


def tensor_statistics(scene: Scene, exposures, progress=None) -> list[TensorStatistics]:
    """
    The noise-free stage of each :class:`Exposure` of ``exposures`` on ``scene``: the scene
    frames (T [K], ε) → the response's signal per sample → its mean per pixel over
    footprint × window [signal unit], with the tensor's T statistics [K].

    Snapshot exposures share one pass over the frames (those with the same footprints share
    them); a rolling shutter takes a pass of its own (:func:`rolling_statistics`). Where the
    camera forms an image, the statistics stay scene truth and the signal is the image's, both
    from one pass of its own (:func:`radiosim.imaging.image_statistics`).

    Parameters
    ----------
    scene
        The scene.
    exposures
        The :class:`Exposure` of each camera's window.
    progress
        Called as ``progress(done, total)`` after each frame of each pass, counted over all
        passes (frame j of pass k of n as k·total + j of n·total).

    Returns
    -------
    list of TensorStatistics
        In the order of ``exposures``.
    """
    exposures = list(exposures)
    integrators = {}  # the footprints' integrators, shared by equal footprints

    def integrator(exposure):
        key = exposure.footprints
        if key not in integrators:
            integrators[key] = FootprintIntegrator.for_scene(scene, *key)
        return integrators[key]

    rolling = [i for i, e in enumerate(exposures) if e.row_time is not None]
    imaged = [i for i, e in enumerate(exposures) if e.row_time is None and e.image is not None]
    plain = [i for i in range(len(exposures)) if i not in rolling and i not in imaged]
    passes = iter(_passes(progress, (1 if plain else 0) + len(rolling) + len(imaged)))
    statistics = {}
    if plain:
        jobs = [Job(integrator(exposures[i]), exposures[i].window, exposures[i].response)
                for i in plain]
        statistics = dict(zip(plain, _integrator.integrate_many(
            scene, jobs, next(passes), emission_only=True)))
    for i in rolling:  # its own pass, one job per row
        statistics[i] = rolling_statistics(scene, exposures[i], integrator(exposures[i]),
                                           next(passes))
    for i in imaged:  # one pass each: the scene truth's statistics and the image together
        e = exposures[i]
        statistics[i] = image_statistics(scene, integrator(e), e.window, e.response, *e.image,
                                         next(passes))
    return [statistics[i] for i in range(len(exposures))]


#: Frames integrated into one partial sum, at least: the frames a pass spans (one window's, or
#: those of a study's windows on one scene together) are split into parts of a multiple of this
#: many frames from the earliest window's first (:func:`part_frames`; the last part shorter),
#: each integrated on its own — in this process one after the other, or on a Dask cluster's
#: workers, any number of them — and each window's parts merged in their order
#: (:func:`merge_statistics`): the same bits wherever the parts ran. A pass over one part's
#: frames or fewer is integrated as it always was.
FRAME_CHUNK = 64

#: Sample-frames [1] a part holds at least: a small scene's parts are longer, so that a part's
#: work (about 0.03 s in this process on 2 cores, 6.6e-10 s a sample-frame) outweighs what a
#: task costs on a cluster (the scene unpickled, the pass set up: a few milliseconds).
PART_SAMPLES = 5e7


def part_frames(samples: int) -> int:
    """Frames of one part on a field of ``samples`` samples: the least multiple of
    :data:`FRAME_CHUNK` holding :data:`PART_SAMPLES` sample-frames (a 1440 × 1113 chip: 64;
    a 9 × 9 pixel's crop: 617 344, its whole windows)."""
    return FRAME_CHUNK * max(1, math.ceil(PART_SAMPLES / (FRAME_CHUNK * max(1, samples))))


def frame_ranges(scene: Scene, *windows: Window) -> list[tuple[int, int]]:
    """The parts [first, stop) of the frames ``windows`` span together on ``scene``,
    :func:`part_frames` frames each from the earliest first frame (the last part shorter)."""
    spans = [scene.window_frames(window) for window in windows]
    low = min(first for first, _ in spans)
    high = max(first + weights.size for first, weights in spans)
    size = part_frames(math.prod(scene.shape))
    return [(a, min(a + size, high)) for a in range(low, high, size)]


def _shared_ranges(scene: Scene, exposures) -> list[tuple[int, int]] | None:
    """:func:`frame_ranges` of the exposures' windows; ``None`` with a rolling shutter's
    exposure (its rows each have a window of their own: one part)."""
    if any(e.row_time is not None for e in exposures):
        return None
    return frame_ranges(scene, *(e.window for e in exposures))


def _range_statistics(scene: Scene, exposures, frames, progress=None) -> list:
    """``(index, statistics, weight)`` of each exposure whose window holds some of the frames
    [first, stop): its statistics over those frames, with their weights in its whole window,
    and the sum of those weights [1] — the exposures sharing one pass over the part
    (``progress`` as :func:`tensor_statistics` reports it)."""
    start, stop = frames
    picked, parts = [], []
    for i, exposure in enumerate(exposures):
        first, weights = scene.window_frames(exposure.window)
        low, high = max(start, first), min(stop, first + weights.size)
        if low < high:
            window = dataclasses.replace(exposure.window, frames=(low, high))
            picked.append(i)
            parts.append(dataclasses.replace(exposure, window=window))
    statistics = tensor_statistics(scene, parts, progress) if parts else []
    return [(i, stats, float(np.sum(scene.window_frames(e.window)[1])))
            for i, stats, e in zip(picked, statistics, parts)]


class _MergedParts:
    """Parts' statistics merged as they come (:func:`merge_statistics`), in their order."""

    def __init__(self):
        self.weight = None

    def add(self, stats: TensorStatistics, weight: float) -> None:
        if self.weight is None:
            self.same = stats.signal_mean is stats.mean  # the linear response's signal: T
            self.mean, self.m2 = stats.mean, weight * stats.std ** 2
            self.signal, self.max, self.n = stats.signal_mean, stats.max, stats.n_frames
            self.weight = weight
            return
        self.same = self.same and stats.signal_mean is stats.mean
        total = self.weight + weight
        delta = stats.mean - self.mean
        self.mean = self.mean + delta * (weight / total)
        self.m2 = self.m2 + weight * stats.std ** 2 + delta * delta * (self.weight * weight
                                                                        / total)
        self.signal = self.signal + stats.signal_mean
        self.max, self.n = np.maximum(self.max, stats.max), self.n + stats.n_frames
        self.weight = total

    def statistics(self) -> TensorStatistics:
        return TensorStatistics(self.mean if self.same else self.signal, self.mean,
                                np.sqrt(np.maximum(self.m2 / self.weight, 0.0)), self.max,
                                self.n)


def merge_statistics(parts) -> TensorStatistics:
    """
    One window's statistics from its parts', ``[(statistics, weight), …]`` in frame order
    (weight: the sum of the part's frame weights [1]): the means weighted by the parts'
    weights and the variances merged by the parallel update of Chan, Golub & LeVeque (1979),
    δ = m_b − m_a, m = m_a + δ·w_b/w, M2 = M2_a + M2_b + δ²·w_a·w_b/w; the signals, each a
    sum over its part's frames with their weights in the whole window, added; the maxima's
    maximum; one part after the other, in their order.
    """
    merged = _MergedParts()
    for stats, weight in parts:
        merged.add(stats, weight)
    return merged.statistics()


def _recorded_part(scene: Scene, exposures, frames=None):
    """A task: :func:`_range_statistics` of ``frames`` (``None``: :func:`tensor_statistics`
    of the whole), and the texts of the RadiosimWarnings it raised (raised again by the
    caller, in its process: never lost on a worker)."""
    from radiosim.scheduling import recorded_call

    if frames is None:
        return recorded_call(tensor_statistics, scene, exposures)
    return recorded_call(_range_statistics, scene, exposures, frames)


def _raise_again(texts) -> None:
    for text in dict.fromkeys(texts):  # once each, in the order raised
        warnings.warn(text, RadiosimWarning, stacklevel=3)


def shared_statistics(scene: Scene, exposures, progress=None, run=None) -> list:
    """
    :func:`tensor_statistics` of ``exposures`` on ``scene``, the frames their windows span
    split into parts (:func:`frame_ranges`; the exposures whose windows hold some of a part's
    frames share one pass over it), each exposure's parts merged in order
    (:func:`merge_statistics`): in this process (``run`` ``None``), or one task a part on a
    Dask engine's ``run`` (:func:`radiosim.scheduling.connect`), with the same bits. A pass
    over one part's frames or fewer in this process is :func:`tensor_statistics`'s.
    """
    exposures = list(exposures)
    ranges = _shared_ranges(scene, exposures)
    if run is None and (ranges is None or len(ranges) == 1):
        return tensor_statistics(scene, exposures, progress)
    # On an engine the scene and the exposures are shared by the tasks, sent to each worker
    # once: a worker unpickles the scene, and builds what it keeps (a chip's geometry), once.
    shared = (scene, exposures)
    if run is not None and ranges is None:
        outcomes = run(_recorded_part, [()], shared=shared)
        _raise_again([t for _, texts in outcomes for t in texts])
        return outcomes[0][0]
    merged = [_MergedParts() for _ in exposures]

    def add(part):
        for i, stats, weight in part:
            merged[i].add(stats, weight)

    if run is not None:
        outcomes = run(_recorded_part, [(r,) for r in ranges], shared=shared)
        _raise_again([t for _, texts in outcomes for t in texts])
        for part, _ in outcomes:  # in frame order
            add(part)
        if progress is not None:
            progress(1, 1)
    else:
        total, done = ranges[-1][1] - ranges[0][0], 0
        for a, b in ranges:  # merged as they come: memory holds one part's sums
            def part_progress(k, n, done=done, frames=b - a):
                progress(done + round(frames * k / max(n, 1)), total)

            add(_range_statistics(scene, exposures, (a, b),
                                  part_progress if progress else None))
            done += b - a
    return [m.statistics() for m in merged]


def split_statistics(scene: Scene, exposure: Exposure, progress=None,
                     scheduler=None) -> TensorStatistics:
    """
    :func:`shared_statistics` of one exposure: its window in parts (:func:`frame_ranges`)
    merged in order, in this process (``scheduler`` ``None``) or one task a part on
    ``scheduler`` (what :func:`radiosim.scheduling.connect` takes: a ``distributed.Client``
    or an address), with the same bits. The scene and the exposure are sent to every worker
    once (a scene that travels should be lazy: its path or its generator, not its frames); a
    worker that dies is replaced and its parts run again elsewhere.
    """
    if scheduler is None:
        return shared_statistics(scene, [exposure], progress)[0]
    from radiosim.scheduling import connect

    run, close = connect(scheduler)
    try:
        return shared_statistics(scene, [exposure], progress, run)[0]
    finally:
        close()


# -- after the integrator: optics, electronics, calibration ------------------------------------


def read_out(readout: ReadOut, stats: TensorStatistics, window: Window, scene: Scene,
             rng=None) -> Measurement:
    """
    The stages after the integrator: the optics, the electronics and the calibration of a
    camera's :class:`ReadOut` turn a window's tensor statistics into a :class:`Measurement`,
    drawing shot and read noise from ``rng`` (seed or :class:`numpy.random.Generator`). (A
    multi-channel camera reads out each channel and combines them:
    :meth:`Camera.read_out <radiosim.camera.Camera.read_out>`.)
    """
    calibration = readout.calibration
    calibration.check_resolution(stacklevel=3)
    # Optics: mean signal and the optics' emission → mean photo-electrons [e⁻] through the
    # étendue.
    photo = photoelectrons(readout, stats.signal_mean, window.duration)
    # Electronics: the fixed pattern, dark charge, shot noise, full well, non-linearity,
    # read noise, ADC → counts [DN].
    pattern = readout.fpa.pattern(photo.shape)
    exposure = readout.electronics.expose(photo, window.duration, rng, pattern)
    nuc = readout.nuc
    if nuc is not None:  # the NUC: counts [DN] → corrected counts [DN]; its bad pixels take
        # their neighbours' values, and their own flags no longer apply
        good = ~nuc.bad[:exposure.counts.shape[0], :exposure.counts.shape[1]]
        exposure = dataclasses.replace(
            exposure, counts=nuc.apply(exposure.counts),
            saturated=exposure.saturated & good, adc_floor=exposure.adc_floor & good)
    # Calibration: counts [DN] → apparent temperature [K] and flags.
    reading = calibration.read(exposure)
    if reading.saturated.any():
        warnings.warn(
            f"{readout.camera.name}: {int(reading.saturated.sum())} of {reading.saturated.size} "
            f"pixels saturated at {readable_time(window.duration)} integration; their apparent "
            "temperature is NaN", RadiosimWarning, stacklevel=3)
    return Measurement(
        apparent_temperature=reading.apparent_temperature, counts=exposure.counts,
        electrons=exposure.electrons, saturated=reading.saturated,
        under_range=reading.under_range, over_range=reading.over_range,
        tensor_max=stats.max, tensor_mean=stats.mean,
        tensor_std=stats.std, signal_mean=stats.signal_mean,
        signal_unit=readout.unit, camera=readout.camera,
        integration_time=window.duration, t_start=window.start, n_frames=stats.n_frames,
        scene=scene.describe(), alignment=window.alignment,
    )


# -- several measurements of one scene ----------------------------------------------------------


def measure_many(scene: Scene, cases, rng=None, progress=None) -> list[Measurement]:
    """
    Several measurements of one scene in one pass over its frames.

    Each frame any window touches is read (or generated) once and feeds every measurement
    (:func:`~radiosim.integrator.integrate_many`); the read-outs then follow in the order of
    ``cases``, drawing their noise from one generator, so the result equals calling
    :meth:`Camera.measure <radiosim.camera.Camera.measure>` on each case in turn with that
    generator, bit for bit.

    Parameters
    ----------
    scene
        The scene.
    cases
        ``(camera, integration_time [s], t_start [s] or None)`` triples.
    rng
        Seed or :class:`numpy.random.Generator`.
    progress
        Called as ``progress(done, total)`` after each frame (:func:`tensor_statistics`).
    """
    rng = check_rng(rng)
    cases = list(cases)
    return [camera.read_out(stats, window, scene, rng)
            for (camera, _, _), (window, stats) in zip(
                cases, measure_many_statistics(scene, cases, progress))]


def measure_many_statistics(scene: Scene, cases, progress=None, run=None) -> list:
    """
    The noise-free part of :func:`measure_many`: each case's window, checked
    (:func:`check_measurable`), and tensor statistics from one pass over the scene's frames
    in parts (:func:`shared_statistics`: in this process, or one task a part on a Dask
    engine's ``run``, the same bits). A read-out (:meth:`Camera.read_out
    <radiosim.camera.Camera.read_out>`) with any generator turns each into a measurement, so
    callers can give each case its own seed.

    Returns
    -------
    list of (Window, TensorStatistics)
        In the order of ``cases``.
    """
    cases = list(cases)
    # A multi-channel camera's case is its channels' cases (:func:`channel_cases`); their
    # statistics come back grouped as the camera's.
    expanded, spans = [], []
    for camera, t_int, t_start in cases:
        own = channel_cases(camera, scene, t_int, t_start)
        spans.append((len(expanded), len(own), camera.channels is not None))
        expanded += own
    windows = [camera.window(scene, t_int, t_start) for camera, t_int, t_start in expanded]
    for (camera, _, _), window in zip(expanded, windows):
        check_measurable(camera, window.duration)
    statistics = list(zip(windows, shared_statistics(
        scene, [camera.exposure(scene, window) for (camera, _, _), window in zip(expanded,
                                                                                   windows)],
        progress, run)))
    return [statistics[i] if not multi else (statistics[i][0], ChannelStatistics(
        tuple(statistics[i:i + n]))) for i, n, multi in spans]


@dataclasses.dataclass(frozen=True)
class ChannelStatistics:
    """The noise-free stage of a multi-channel camera: each channel's ``(Window,
    TensorStatistics)``, in the camera's order (:func:`measure_many_statistics`)."""

    channels: tuple


def channel_cases(camera, scene: Scene, integration_time: float,
                  t_start: float | None) -> list:
    """
    The ``(camera, integration time [s], t_start [s] or None)`` cases of ``camera``'s
    channel cameras (:attr:`Camera.channel_cameras <radiosim.camera.Camera.channel_cameras>`):
    the camera's own case without channels.
    Channel k integrates for its own integration time (default ``integration_time``) from
    the measurement's window start plus its time offset; a channel with neither keeps
    ``t_start`` as given (and so the window's alignment).
    """
    if camera.channels is None:
        return [(camera, integration_time, t_start)]
    # The measurement's start only: each channel's own window is made and checked after.
    base = integration_window(scene, integration_time, t_start, inside=False)
    cases = []
    for channel, own in zip(camera.channels, camera.channel_cameras):
        t_int = integration_time if channel.integration_time is None else \
            channel.integration_time
        same = channel.time_offset == 0 and channel.integration_time is None
        cases.append((own, t_int, t_start if same else base.start + channel.time_offset))
    return cases


# -- modes: frames in time ----------------------------------------------------------------------


def record(camera, scene: Scene, integration_time: float, n_frames: int,
           t_start: float | None = None, rng=None) -> list[Measurement]:
    """
    Record ``n_frames`` frames of ``scene`` with ``camera``'s real timing.

    Frame i integrates over [t_start + i·P, … + integration_time] with P the frame period
    (:func:`frame_period`: the readout's, or the frame rate's if slower); ``t_start``
    defaults to the start that centres the first frame's window on the scene's event.
    One generator drives the noise of all frames.
    """
    if isinstance(n_frames, bool) or int(n_frames) != n_frames or n_frames < 1:
        raise RadiosimError(f"n_frames must be a whole number ≥ 1, got {n_frames!r}")
    period = frame_period(camera, integration_time)
    rng = check_rng(rng)
    first = camera.window(scene, integration_time, t_start)
    return [camera.measure(scene, integration_time, first.start + i * period, rng)
            for i in range(int(n_frames))]


def superframe(camera, scene: Scene, integration_times, t_start: float | None = None,
               rng=None) -> Measurement:
    """
    Superframing: integrate subframes of ``integration_times`` [s] in sequence with
    ``camera``'s real timing (each starts one frame period after the previous one's start),
    calibrate each with its own calibration, and merge them per pixel: the longest subframe
    whose reading is valid (neither saturated, under nor over range); a pixel with no valid
    subframe keeps the flags of its shortest subframe if any is saturated, else of its
    longest. The scene moves between subframes, and the merged frame shows it.

    Parameters
    ----------
    camera
        The camera.
    scene
        The scene.
    integration_times
        The subframes' integration times [s], in the order the camera cycles them.
    t_start
        Start of the first subframe [s]; ``None``: as :meth:`Camera.window
        <radiosim.camera.Camera.window>` chooses.
    rng
        Seed or generator; the subframes draw their noise from it in turn.

    Returns
    -------
    Measurement
        Per-pixel fields from each pixel's subframe; ``subframe`` says which;
        ``integration_time`` is the longest subframe's, ``t_start`` the first's.
    """
    times = [check_positive(t, "integration time", "s") for t in integration_times]
    if not times:
        raise RadiosimError("a superframe needs at least one integration time")
    rng = check_rng(rng)
    start = camera.window(scene, times[0], t_start).start
    timed = camera.frame_rate is not None or camera.fpa.readout_time(readout_shape(camera)) > 0
    subframes = []
    for t_int in times:
        subframes.append(camera.measure(scene, t_int, start, rng))
        start += frame_period(camera, t_int) if timed else t_int
    order = np.argsort(times, kind="stable")  # shortest first
    shape = subframes[0].shape
    chosen = np.full(shape, -1)
    for j in order:  # longer valid subframes overwrite shorter ones
        chosen = np.where(subframes[j].valid, j, chosen)
    none = chosen < 0
    any_saturated = np.any([m.saturated for m in subframes], axis=0)
    chosen = np.where(none & any_saturated, order[0], np.where(none, order[-1], chosen))

    def pick(name):
        stack = np.stack([getattr(m, name) for m in subframes])
        return np.take_along_axis(stack, chosen[None], 0)[0]

    first = subframes[0]
    return Measurement(
        **{name: pick(name) for name in (
            "apparent_temperature", "counts", "electrons", "saturated", "under_range",
            "over_range", "tensor_max", "tensor_mean", "tensor_std", "signal_mean")},
        signal_unit=first.signal_unit, camera=camera, integration_time=max(times),
        t_start=first.t_start, n_frames=sum(m.n_frames for m in subframes),
        scene=first.scene, alignment=first.alignment, subframe=chosen,
        subframe_times=tuple(times), subframe_starts=tuple(m.t_start for m in subframes))

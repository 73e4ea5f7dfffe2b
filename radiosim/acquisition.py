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
           "FRAME_CHUNK", "frame_ranges", "merge_statistics", "split_statistics", "read_out",
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


#: Frames of a window integrated into one partial sum: a longer window is split into parts of
#: this many frames from its first (the last part shorter), each integrated on its own — in this
#: process one after the other, or on a Dask cluster's workers, any number of them — and the
#: parts' sums merged in their order (:func:`merge_statistics`): the same bits wherever the
#: parts ran. A window of at most this many frames is one part, integrated as it always was.
FRAME_CHUNK = 64


def frame_ranges(scene: Scene, window: Window) -> list[tuple[int, int]]:
    """The parts [first, stop) of ``window``'s frames on ``scene``, :data:`FRAME_CHUNK` frames
    each from its first (the last part shorter)."""
    first, weights = scene.window_frames(window)
    n = int(weights.size)
    return [(first + a, first + min(a + FRAME_CHUNK, n)) for a in range(0, n, FRAME_CHUNK)]


def _part_statistics(scene: Scene, exposure: Exposure, frames, progress=None):
    """The statistics of ``exposure`` over its window's ``frames`` [first, stop), with their
    weights in the whole window, and the sum of those weights [1]."""
    window = dataclasses.replace(exposure.window, frames=tuple(frames))
    stats, = tensor_statistics(scene, [dataclasses.replace(exposure, window=window)], progress)
    return stats, float(np.sum(scene.window_frames(window)[1]))


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


def split_statistics(scene: Scene, exposure: Exposure, progress=None,
                     scheduler=None) -> TensorStatistics:
    """
    :func:`tensor_statistics` of one exposure, its window split into parts of
    :data:`FRAME_CHUNK` frames (:func:`frame_ranges`) merged in order
    (:func:`merge_statistics`): in this process (``scheduler`` ``None``), or one task a part
    on ``scheduler`` (what :func:`radiosim.scheduling.connect` takes: a
    ``distributed.Client`` or an address), with the same bits. A rolling shutter's rows each
    have a window of their own: its exposure is one part.
    """
    ranges = [None] if exposure.row_time is not None else frame_ranges(scene, exposure.window)
    if scheduler is None:
        if len(ranges) == 1:
            return tensor_statistics(scene, [exposure], progress)[0]
        total, merged, done = ranges[-1][1] - ranges[0][0], _MergedParts(), 0
        for a, b in ranges:  # merged as they come: memory holds one part's sums
            def part_progress(k, n, done=done, frames=b - a):
                progress(done + round(frames * k / max(n, 1)), total)

            merged.add(*_part_statistics(scene, exposure, (a, b),
                                         part_progress if progress else None))
            done += b - a
        return merged.statistics()
    from radiosim.scheduling import connect

    run, close = connect(scheduler)
    try:
        # Each task carries the scene and the exposure (a scene that travels is lazy: its
        # path or its generator, not its frames), so a worker that dies takes nothing with
        # it that another cannot run again.
        if ranges == [None]:
            parts = run(_whole_statistics, [(scene, exposure)])
        else:
            parts = run(_part_statistics, [(scene, exposure, r) for r in ranges])
    finally:
        close()
    if progress is not None:
        progress(1, 1)
    return parts[0][0] if len(parts) == 1 else merge_statistics(parts)


def _whole_statistics(scene: Scene, exposure: Exposure):
    """:func:`tensor_statistics` of one exposure, as a part (its weight unused)."""
    return tensor_statistics(scene, [exposure])[0], 1.0


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


def measure_many_statistics(scene: Scene, cases, progress=None) -> list:
    """
    The noise-free part of :func:`measure_many`: each case's window, checked
    (:func:`check_measurable`), and tensor statistics (:func:`tensor_statistics`) from one
    pass over the scene's frames. A read-out (:meth:`Camera.read_out
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
    statistics = list(zip(windows, tensor_statistics(
        scene, [camera.exposure(scene, window) for (camera, _, _), window in zip(expanded,
                                                                                   windows)],
        progress)))
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

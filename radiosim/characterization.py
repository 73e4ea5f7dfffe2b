"""
Camera characterisation: the laboratory procedures, as functions taking the camera first —
flat fields (:func:`flat_fields`), the non-uniformity correction fitted to them
(:func:`fit_nuc`), the calibration fitted to measured points (:func:`fit_calibration`, from
:mod:`radiosim.calibration`; from a CSV table: :mod:`radiosim.calibration_table`), the NETD
(:func:`netd`) and the measurable range (:func:`measurable_range`); the photon-transfer curve
after EMVA 1288 and what it recovers, and the size-of-source effect of the optics.

A flat field (a uniform blackbody) is recorded twice at each exposure level; the mean of the
pair gives μ_y [DN] and half the variance of their difference gives the temporal variance σ²_y
[DN²] free of fixed-pattern noise. Below saturation σ²_y − σ²_y,dark = K (μ_y − μ_y,dark), so a
line fitted over the linear range (up to 70 % of saturation, as the standard prescribes) gives
the system gain K [DN/e⁻]; the dark variance gives the dark noise σ_d = √(σ²_y,dark − 1/12)/K
[e⁻]; and the saturation capacity is the charge (μ_y − μ_y,dark)/K where the variance peaks.

The spatial non-uniformity follows EMVA 1288's §8: the mean of L frames, dark and at about
half saturation, has a spatial variance s²_y that still holds σ²_y,temporal / L of temporal
noise, which is subtracted; then DSNU = s_y,dark / K [e⁻] and
PRNU = √(s²_y,50 − s²_y,dark) / (μ_y,50 − μ_y,dark) [1]. The linearity error is EMVA 1288's
(Release 3.0, §6.6): a line through the mean signal against exposure between 5 % and 95 % of
its range, and LE = (max δ − min δ)/2 of the deviations δ relative to that range [%].

The size-of-source effect (SSE) is measured as MSL Technical Guide 26 describes: the camera
views uniform discs of increasing diameter d, centred on a pixel, in front of a uniform
background; SSE(d) = (S(d) − S_bg) / (S(d_ref) − S_bg), the centre pixel's signal above the
background relative to that of the largest disc. A scatter halo whose wings fall as r⁻³
(:class:`~radiosim.psf.ScatterHalo`) gives, for a pixel small against the halo,
S(d) − S_bg ∝ 1 − β · a / √((d/2)² + a²), which :func:`fit_scatter_halo` fits to a measured
curve.

References
----------
-   EMVA Standard 1288, Release 4.0 Linear (2021), sections 6 and 8.
-   Saunders, P. (2015). MSL Technical Guide 26: Size-of-source effect. Measurement Standards
    Laboratory of New Zealand.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from radiosim.acquisition import photoelectrons
from radiosim.calibration import NonUniformityCorrection, fit_calibration
from radiosim.checks import check_positive, check_rng
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.integrator import integrate, integration_window
from radiosim.psf import ScatterHalo
from radiosim.ratio import ratio_netd
from radiosim.scenes.analytic import UniformBlackbody
from radiosim.scenes.framestack import FrameStack
from radiosim.units import AMBIENT_TEMPERATURE, CELSIUS_OFFSET

__all__ = ["PhotonTransfer", "photon_transfer", "EmvaResult", "fit_emva1288",
           "SizeOfSource", "size_of_source", "HaloFit", "fit_scatter_halo", "SSE_DIAMETERS",
           "sse_diameters", "fit_curve_halo", "DatasheetPlan", "datasheet_plan",
           "SpatialNonuniformity", "spatial_nonuniformity", "linearity_error",
           "residual_nonuniformity", "Datasheet", "datasheet", "flat_fields", "flat_field",
           "fit_nuc", "fit_calibration", "netd", "measurable_range"]


@dataclass(frozen=True)
class PhotonTransfer:
    """
    A photon-transfer curve.

    Attributes
    ----------
    temperature : numpy.ndarray
        Blackbody temperature of each level [K].
    mean : numpy.ndarray
        Mean digital signal μ_y of each level [DN].
    variance : numpy.ndarray
        Temporal variance σ²_y of each level [DN²].
    dark_mean, dark_variance : float
        The same without light [DN], [DN²].
    saturated : numpy.ndarray or None
        Fraction of the pixels saturated in either frame of each level's pair (the curve's
        levels past the full well; their variance collapses, as EMVA 1288 expects).
    """

    temperature: np.ndarray
    mean: np.ndarray
    variance: np.ndarray
    dark_mean: float
    dark_variance: float
    saturated: np.ndarray | None = None


def photon_transfer(camera, integration_time: float, temperatures, pixels=(64, 64),
                    rng=None, progress=None) -> PhotonTransfer:
    """
    Record flat-field pairs of a camera at blackbody ``temperatures`` [K].

    The dark level is a pair taken with no light (photo-electrons set to zero through the
    electronics alone). Frames go through the full chain (:meth:`Camera.measure`).
    ``progress``, if given, is called as ``progress(level)`` after each level's pair.
    """
    single_band(camera, "photon_transfer")
    rng = np.random.default_rng(rng)
    temperatures = np.asarray(temperatures, dtype=float)
    pitch = camera.fpa.pixel_pitch
    shape = (pixels[0], pixels[1])
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, shape=shape))
    dark_pair = [camera.electronics.expose(np.zeros(shape), integration_time, rng).counts
                 for _ in range(2)]
    means, variances, saturated = [], [], []
    for t in temperatures:
        scene = UniformBlackbody(t, shape=shape, dx=pitch, dt=integration_time)
        # A level past the full well is part of the curve (its variance collapses): its
        # saturation is flagged in the result (``saturated``), not warned about per frame;
        # any other warning reaches the caller.
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RadiosimWarning)
            frames = [camera.measure(scene, integration_time, t_start=0.0, rng=rng)
                      for _ in range(2)]
        for w in caught:
            if not (issubclass(w.category, RadiosimWarning)
                    and " saturated at " in str(w.message)):
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        pair = [m.counts for m in frames]
        saturated.append(float(np.mean(frames[0].saturated | frames[1].saturated)))
        means.append(0.5 * (pair[0].mean() + pair[1].mean()))
        variances.append(np.var(pair[0] - pair[1]) / 2)
        if progress is not None:
            progress(f"flat-field pair at {t:.1f} K")
    return PhotonTransfer(temperatures, np.array(means), np.array(variances),
                          float(0.5 * (dark_pair[0].mean() + dark_pair[1].mean())),
                          float(np.var(dark_pair[0] - dark_pair[1]) / 2), np.array(saturated))


@dataclass(frozen=True)
class EmvaResult:
    """
    What the photon-transfer curve recovers.

    Attributes
    ----------
    gain : float
        System gain K [DN/e⁻].
    dark_noise : float
        Temporal dark noise σ_d [e⁻ rms] (read noise and dark-current shot noise).
    saturation_capacity : float
        Charge at the variance peak [e⁻].
    linear_range : numpy.ndarray of bool
        Levels used for the gain fit.
    """

    gain: float
    dark_noise: float
    saturation_capacity: float
    linear_range: np.ndarray


def fit_emva1288(ptc: PhotonTransfer, linear_fraction: float = 0.7) -> EmvaResult:
    """Gain, dark noise and saturation capacity from a photon-transfer curve."""
    signal = ptc.mean - ptc.dark_mean
    noise = ptc.variance - ptc.dark_variance
    peak = int(np.argmax(ptc.variance))
    if peak == 0 or peak == ptc.mean.size - 1:
        raise RadiosimError("the variance does not peak inside the levels: extend them past "
                            "saturation")
    linear = (signal > 0) & (signal <= linear_fraction * signal[peak])
    linear[peak:] = False
    if linear.sum() < 3:
        raise RadiosimError("fewer than 3 levels in the linear range: add lower levels")
    gain = float(np.sum(signal[linear] * noise[linear]) / np.sum(signal[linear] ** 2))
    dark_noise = float(np.sqrt(max(ptc.dark_variance - 1 / 12, 0.0)) / gain)
    return EmvaResult(gain=gain, dark_noise=dark_noise,
                      saturation_capacity=float(signal[peak] / gain), linear_range=linear)


@dataclass(frozen=True)
class SizeOfSource:
    """
    A camera's size-of-source curve.

    Attributes
    ----------
    diameter : numpy.ndarray
        Disc diameters [m, object space].
    signal : numpy.ndarray
        Centre pixel's mean signal [response unit] with each disc (noise-free).
    background_signal : float
        The same with no disc [response unit].
    sse : numpy.ndarray
        (signal − background) / (signal of the largest disc − background) [1].
    apparent_temperature : numpy.ndarray
        The centre pixel's noise-free reading [K] (NaN outside the calibration).
    """

    diameter: np.ndarray
    signal: np.ndarray
    background_signal: float
    sse: np.ndarray
    apparent_temperature: np.ndarray


#: Samples per pixel pitch, and at most this many samples across a disc scene.
_SSE_SAMPLES_PER_PIXEL = 3
_SSE_MAX_SAMPLES = 768


def _disc_signal(camera, diameter: float, temperature: float, background: float,
                 integration_time: float) -> float:
    """The centre pixel's imaged signal of a disc (0 diameter: the background alone)."""
    pitch = camera.fpa.pixel_pitch
    span = max(diameter, 4 * pitch) * 1.25  # the disc and a margin of background
    dx = max(pitch / _SSE_SAMPLES_PER_PIXEL, span / _SSE_MAX_SAMPLES)
    n = int(np.ceil(span / dx)) | 1  # odd: a sample at the centre
    centre = n * dx / 2  # [m] from the scene's edge
    coordinate = (np.arange(n) + 0.5) * dx - centre
    inside = np.hypot(coordinate[:, None], coordinate[None, :]) < diameter / 2
    frame = np.where(inside, temperature, background)[None]
    scene = FrameStack(frame, dt=integration_time, dx=dx).set_environment(
        surroundings_temperature=background)
    fpa = dataclasses.replace(camera.fpa, shape=(1, 1),
                              origin=(centre - pitch / 2, centre - pitch / 2))
    one_pixel = camera.replace(fpa=fpa)
    window = integration_window(scene, integration_time, 0.0)
    return float(one_pixel.image(scene, window)[0, 0])


def size_of_source(camera, diameters, temperature: float = 1273.15,
                   background: float = AMBIENT_TEMPERATURE, integration_time: float = 10e-6,
                   progress=None) -> SizeOfSource:
    """
    The camera's size-of-source curve: the reading of uniform blackbody discs against their
    diameter (MSL Technical Guide 26), through the optics' PSF and the pixel's footprint.

    Parameters
    ----------
    camera
        The camera (its PSF, response, fill factor and calibration).
    diameters
        Disc diameters [m, object space], increasing; the largest is the reference.
    temperature, background
        Disc and background (and surroundings) temperatures [K].
    integration_time
        Integration time [s] of the readings.
    progress
        Called as ``progress(done, total, label)`` after each disc (the background first).

    Returns
    -------
    SizeOfSource

    Examples
    --------
    >>> from radiosim.camera import Camera
    >>> from radiosim.psf import ScatterHalo
    >>> cam = Camera.linear_ideal(6e-6)
    >>> cam = cam.replace(optics=dataclasses.replace(cam.optics, psf=ScatterHalo(0.1, 60e-6)))
    >>> curve = size_of_source(cam, [60e-6, 240e-6, 960e-6])
    >>> np.round(curve.sse, 3).tolist()
    [0.922, 0.967, 1.0]
    """
    single_band(camera, "size_of_source (the SSE)")
    diameters = np.asarray(diameters, dtype=float)
    if diameters.ndim != 1 or diameters.size < 2 or not np.all(np.isfinite(diameters)) or \
            np.any(diameters <= 0) or np.any(np.diff(diameters) <= 0):
        raise RadiosimError(f"diameters must be at least two increasing lengths > 0 [m], got "
                            f"{diameters.tolist()}")
    temperature = check_positive(temperature, "disc temperature", "K")
    background = check_positive(background, "background temperature", "K")
    t_int = check_positive(integration_time, "integration_time", "s")
    if temperature == background:
        raise RadiosimError("the disc and the background must differ in temperature")
    total = diameters.size + 1

    def disc(k, d):
        value = _disc_signal(camera, d, temperature, background, t_int)
        if progress is not None:
            progress(k + 1, total, f"disc {d * 1e6:g} µm" if d else "background")
        return value

    base = disc(0, 0.0)
    signal = np.array([disc(k + 1, d) for k, d in enumerate(diameters)])
    calibration = camera.calibration(t_int)
    photo = photoelectrons(camera.readout(t_int), signal, t_int)
    apparent = calibration.temperature(camera.electronics.mean_counts(photo, t_int))
    return SizeOfSource(diameters, signal, base, (signal - base) / (signal[-1] - base),
                        apparent)


@dataclass(frozen=True)
class HaloFit:
    """
    A scatter halo fitted to an SSE curve.

    Attributes
    ----------
    halo : ScatterHalo
        The fitted halo (fraction β [1], width a [m]).
    scale : float
        Fitted signal of an infinite disc relative to the curve's normalisation [1].
    residuals : numpy.ndarray
        Measured minus fitted SSE at each diameter [1].
    """

    halo: ScatterHalo
    scale: float
    residuals: np.ndarray


def _halo_sse(diameter, fraction, width, scale):
    radius = np.asarray(diameter) / 2
    return scale * (1.0 - fraction * width / np.sqrt(radius * radius + width * width))


def fit_scatter_halo(diameters, sse) -> HaloFit:
    """
    Fit a :class:`~radiosim.psf.ScatterHalo` to a measured size-of-source curve,
    SSE(d) = c · (1 − β a / √((d/2)² + a²)) with c the curve's normalisation (least squares).

    The model holds for discs much larger than the PSF's core and the pixel: pass diameters
    from a few core widths upward.

    Parameters
    ----------
    diameters
        Disc diameters [m].
    sse
        Signal above background, relative (any normalisation) [1].

    Examples
    --------
    >>> d = np.geomspace(50e-6, 5e-3, 12)
    >>> fit = fit_scatter_halo(d, _halo_sse(d, 0.04, 150e-6, 1.02))
    >>> round(fit.halo.fraction, 6), round(fit.halo.width * 1e6, 3)
    (0.04, 150.0)
    """
    from scipy.optimize import least_squares

    d = np.asarray(diameters, dtype=float)
    y = np.asarray(sse, dtype=float)
    if d.shape != y.shape or d.ndim != 1 or d.size < 4:
        raise RadiosimError(f"need at least 4 (diameter, SSE) pairs of equal length, got "
                            f"{d.size} diameters and {y.size} values")
    if not (np.all(np.isfinite(d)) and np.all(d > 0) and np.all(np.isfinite(y))):
        raise RadiosimError("diameters must be finite and > 0 [m] and SSE values finite")
    start = (0.05, float(np.median(d)) / 2, float(y.max()))
    fit = least_squares(lambda p: _halo_sse(d, *p) - y, start,
                        bounds=([0.0, d.min() * 1e-3, 0.0], [1.0, d.max() * 1e3, np.inf]),
                        x_scale=(0.1, start[1], start[2]), xtol=1e-15, ftol=1e-15, gtol=1e-15)
    fraction, width, scale = fit.x
    return HaloFit(ScatterHalo(float(fraction), float(width)), float(scale), -fit.fun)


#: Default disc diameters of a size-of-source curve [pixel pitches]: 13 from 2 to 200,
#: evenly spaced in log (from discs the PSF's core blurs to discs its wings barely reach).
SSE_DIAMETERS = np.geomspace(2, 200, 13)
#: The halo is fitted to discs at least this many pixel pitches across [1] (the model holds
#: for discs much larger than the PSF's core and the pixel) ...
HALO_FIT_SMALLEST = 10.0
#: ... when at least this many discs qualify and their SSE varies by more than
#: :data:`HALO_FIT_FLAT` [1] (a flat curve has no halo to fit).
HALO_FIT_DISCS = 4
HALO_FIT_FLAT = 1e-9


def sse_diameters(pixel_pitch: float) -> np.ndarray:
    """The default disc diameters [m] of a size-of-source curve for a pixel pitch [m]
    (:data:`SSE_DIAMETERS` pitches)."""
    return check_positive(pixel_pitch, "pixel pitch", "m") * SSE_DIAMETERS


def fit_curve_halo(curve: SizeOfSource, pixel_pitch: float) -> HaloFit | None:
    """
    The scatter halo (:func:`fit_scatter_halo`) fitted to the discs of ``curve`` at least
    :data:`HALO_FIT_SMALLEST` pixel pitches [m] across; ``None`` when fewer than
    :data:`HALO_FIT_DISCS` qualify or their SSE is flat (within :data:`HALO_FIT_FLAT`). The
    effective halo includes diffraction's own r⁻³ wings.
    """
    large = curve.diameter >= HALO_FIT_SMALLEST * pixel_pitch
    if large.sum() < HALO_FIT_DISCS or np.ptp(curve.sse[large]) <= HALO_FIT_FLAT:
        return None
    return fit_scatter_halo(curve.diameter[large], curve.sse[large])


# -- flat fields, the NUC, and the camera's performance -----------------------------------------


def flat_fields(camera, temperature: float | None, integration_time: float, frames: int = 16,
                rng=None):
    """
    ``frames`` read-outs [DN] (frames, rows, columns) of a uniform blackbody filling
    ``camera``'s array at ``temperature`` [K] — or of darkness (no photo-charge) for ``None``
    — and the pixels saturated in any of them.

    The blackbody is imaged once; each frame is a new read-out of the electronics (shot
    and read noise, with the array's fixed pattern), without the NUC.
    """
    single_band(camera, "flat_fields")
    if camera.fpa.shape is None:
        raise RadiosimError(f"{camera.name} has no array shape: a flat field needs one")
    if isinstance(frames, bool) or int(frames) != frames or frames < 1:
        raise RadiosimError(f"frames must be a whole number ≥ 1, got {frames!r}")
    rng = check_rng(rng)
    t_int = check_positive(integration_time, "integration_time", "s")
    if temperature is None:
        photo = np.zeros(camera.fpa.shape)
    else:
        scene = UniformBlackbody(check_positive(temperature, "temperature", "K"),
                                 shape=camera.fpa.shape, dx=camera.fpa.pixel_pitch, dt=t_int)
        at_corner = camera.replace(fpa=dataclasses.replace(camera.fpa, origin=(0.0, 0.0)))
        window = at_corner.window(scene, t_int, 0.0)
        stats = integrate(scene, at_corner.integrator(scene), window, camera.response_model)
        photo = photoelectrons(camera.readout(t_int), stats.signal_mean, t_int)  # [e⁻]
    pattern = camera.fpa.pattern(photo.shape)
    counts = np.empty((int(frames), *photo.shape))
    saturated = np.zeros(photo.shape, dtype=bool)
    for k in range(int(frames)):
        exposure = camera.electronics.expose(photo, t_int, rng, pattern)
        counts[k] = exposure.counts
        saturated |= exposure.saturated
    return counts, saturated


def flat_field(camera, temperature: float | None, integration_time: float, frames: int = 16,
               rng=None):
    """The mean of :func:`flat_fields` [DN] and the pixels saturated in any frame."""
    counts, saturated = flat_fields(camera, temperature, integration_time, frames, rng)
    return counts.mean(axis=0), saturated


def fit_nuc(camera, temperatures, integration_time: float, frames: int = 16, rng=None):
    """
    ``camera`` with a non-uniformity correction computed as cameras do: flat fields of
    uniform blackbodies at ``temperatures`` [K] (two: a two-point NUC; more: multi-point),
    ``frames`` read-outs each, at ``integration_time`` [s]
    (:class:`~radiosim.calibration.NonUniformityCorrection`).
    """
    single_band(camera, "fit_nuc")
    rng = check_rng(rng)
    temperatures = [float(t) for t in temperatures]
    flats, saturated = zip(*(flat_field(camera, t, integration_time, frames, rng)
                             for t in temperatures))
    nuc = NonUniformityCorrection.from_flat_fields(
        np.array(flats), temperatures, integration_time, np.any(saturated, axis=0))
    return camera.replace(nuc=nuc)


def netd(camera, temperature, integration_time: float) -> np.ndarray:
    """
    Noise-equivalent temperature difference [K] of a grey body (``camera``'s assumed
    emissivity and settings) at ``temperature`` [K] and ``integration_time`` [s]: the temporal
    noise [e⁻ rms] over the slope of the mean charge, d e⁻/dT (shot noise of signal,
    background and dark charge; read and quantisation noise). The fixed pattern is not
    temporal noise and is not included. A camera of two or more channels reads the ratio
    temperature: its NETD is the ratio's (:func:`radiosim.ratio.ratio_netd`); a channel's own
    is ``netd(camera.channel_cameras[k], …)``.
    """
    if camera.channels is not None and len(camera.channels) >= 2:
        return ratio_netd(camera, temperature, integration_time)
    return single_band(camera, "netd").calibration(integration_time).netd(temperature)


def measurable_range(camera, integration_time: float) -> tuple[float, float]:
    """
    (lowest measurable temperature, saturation temperature) [K] of a grey body with ``camera``
    at ``integration_time`` [s]: the temperature whose mean counts reach the detection limit
    (blank + k σ, k = the camera's ``detection_sigma``), and the one that fills the well or
    the converter (NaN or ∞ where the calibration range does not hold them). A camera of two
    or more channels reads where every channel does: the highest of its channels' lowest
    temperatures, the lowest of their saturation temperatures (each channel's own range is
    ``measurable_range(camera.channel_cameras[k], …)``).
    """
    if camera.channels is not None:
        ranges = [measurable_range(own, integration_time) for own in camera.channel_cameras]
        return max(low for low, _ in ranges), min(high for _, high in ranges)
    calibration = camera.calibration(integration_time)
    return calibration.lowest_measurable_temperature(), calibration.saturation_temperature


def single_band(camera, what: str):
    """``camera`` if it has one band; a multi-channel camera is refused in one line saying
    ``what`` needs one band and naming its channel cameras."""
    if camera.channels is None:
        return camera
    bands = ", ".join(f"{k}: {lo * 1e6:g}–{hi * 1e6:g} µm"
                      for k, (lo, hi) in enumerate(c.band for c in camera.channels))
    raise RadiosimError(f"{what} measures one band; {camera.name} has {len(camera.channels)} "
                        f"channels ({bands}): give one of its channel cameras, "
                        "camera.channel_cameras[k] (or a file of one channel)")


# -- the spatial model (EMVA 1288 §8), linearity and the NUC's residual ----------------------


@dataclass(frozen=True)
class SpatialNonuniformity:
    """
    EMVA 1288 spatial non-uniformity of an array.

    Attributes
    ----------
    dsnu : float
        Dark-signal non-uniformity [e⁻ rms].
    prnu : float
        Photo-response non-uniformity [1, rms].
    dark_spatial_variance, bright_spatial_variance : float
        s²_y of the mean dark and bright images, temporal part removed [DN²].
    temporal_variance : float
        Mean per-pixel temporal variance of the bright frames [DN²].
    defects : int
        Defect pixels left out (saturated, dead, hot or outlying).
    """

    dsnu: float
    prnu: float
    dark_spatial_variance: float
    bright_spatial_variance: float
    temporal_variance: float
    defects: int = 0


def _spatial_variance(frames: np.ndarray, keep: np.ndarray) -> tuple[float, float]:
    """(s²_y of the frames' mean image over the ``keep`` pixels, less its temporal part; the
    mean temporal variance) [DN²]."""
    n = frames.shape[0]
    temporal = float(np.mean(np.var(frames, axis=0, ddof=1)[keep]))
    return float(np.var(frames.mean(axis=0)[keep], ddof=1)) - temporal / n, temporal


#: A pixel whose dark level or response lies further than this many robust standard deviations
#: from the array's median is a defect pixel, left out of DSNU and PRNU.
DEFECT_SIGMAS = 6.0


def _outliers(image: np.ndarray) -> np.ndarray:
    median = np.median(image)
    robust = 1.4826 * np.median(np.abs(image - median))
    return np.abs(image - median) > DEFECT_SIGMAS * max(robust, 1e-12 * abs(median) + 1e-300)


def spatial_nonuniformity(camera, temperature: float, integration_time: float, gain: float,
                          frames: int = 16, rng=None) -> SpatialNonuniformity:
    """
    DSNU and PRNU of ``camera``'s array from ``frames`` dark and bright (blackbody at
    ``temperature`` [K]) read-outs at ``integration_time`` [s], with the system gain ``gain``
    [DN/e⁻] (from :func:`fit_emva1288`). Defect pixels — saturated in any frame, or with a
    dark level or response beyond 6 robust standard deviations (dead and hot pixels) — are
    left out and counted.
    """
    single_band(camera, "spatial_nonuniformity")
    rng = np.random.default_rng(rng)
    dark, dark_saturated = flat_fields(camera, None, integration_time, frames, rng)
    bright, saturated = flat_fields(camera, temperature, integration_time, frames, rng)
    response = bright.mean(axis=0) - dark.mean(axis=0)
    defects = saturated | dark_saturated | _outliers(dark.mean(axis=0)) | _outliers(response)
    if defects.mean() > 0.01:
        raise RadiosimError(f"{int(defects.sum())} pixels saturate or are defects at "
                            f"{temperature:g} K: choose a level near half saturation")
    keep = ~defects
    s2_dark, _ = _spatial_variance(dark, keep)
    s2_bright, temporal = _spatial_variance(bright, keep)
    signal = float(response[keep].mean())  # [DN]
    return SpatialNonuniformity(
        dsnu=float(np.sqrt(max(s2_dark, 0.0))) / gain,
        prnu=float(np.sqrt(max(s2_bright - s2_dark, 0.0))) / signal,
        dark_spatial_variance=s2_dark, bright_spatial_variance=s2_bright,
        temporal_variance=temporal, defects=int(defects.sum()))


def linearity_error(exposure, mean, dark_mean: float = 0.0, low: float = 0.05,
                    high: float = 0.95) -> float:
    """
    EMVA 1288 linearity error [%] of mean signals ``mean`` [DN] against ``exposure`` (any unit
    proportional to the photo-charge: irradiance × time): a least-squares line through the
    points between ``low`` and ``high`` of the signal range (above ``dark_mean``), deviations
    relative to that range, δ = 100·(y − fit)/((high − low)·y_max), LE = (max δ − min δ)/2.

    Examples
    --------
    >>> h = np.linspace(0.0, 1.0, 21)
    >>> round(linearity_error(h, 100 * h), 9)  # a straight line
    0.0
    >>> round(linearity_error(h, 100 * h * (1 - 0.05 * h)), 3)  # 5 % compression at the top
    0.526
    """
    x = np.asarray(exposure, dtype=float)
    y = np.asarray(mean, dtype=float) - dark_mean
    top = y.max()
    used = (y >= low * top) & (y <= high * top)
    if used.sum() < 3:
        raise RadiosimError("fewer than 3 levels between 5 % and 95 % of the signal range")
    slope, intercept = np.polyfit(x[used], y[used], 1)
    fit = slope * x[used] + intercept
    delta = 100.0 * (y[used] - fit) / ((high - low) * top)  # [%] of the fitted range
    return float((delta.max() - delta.min()) / 2)


def residual_nonuniformity(camera, temperatures, integration_time: float, frames: int = 16,
                           rng=None) -> np.ndarray:
    """
    Spatial noise left after the camera's NUC [DN rms] at each blackbody temperature [K]: the
    spatial standard deviation of the NUC-corrected mean of ``frames`` read-outs, its temporal
    part (σ²_temporal / frames) removed, over the pixels the NUC keeps; NaN where one of them
    saturates. Zero (to the noise of
    the NUC's own flat fields) at the NUC's points, rising away from them where the pixels'
    responses differ in shape (non-linearity spread).
    """
    single_band(camera, "residual_nonuniformity")
    if camera.nuc is None:
        raise RadiosimError(f"{camera.name} has no NUC: fit one first "
                            "(radiosim.characterization.fit_nuc)")
    rng = np.random.default_rng(rng)
    out = []
    for t in temperatures:
        counts, saturated = flat_fields(camera, float(t), integration_time, frames, rng)
        good = ~camera.nuc.bad[:counts.shape[1], :counts.shape[2]]
        if saturated[good].any():  # the NUC's bad pixels are replaced, saturated or not
            out.append(np.nan)
            continue
        corrected = np.stack([camera.nuc.apply(c) for c in counts])
        mean = corrected.mean(axis=0)[good]
        temporal = float(np.mean(np.var(corrected, axis=0, ddof=1)[good]))
        out.append(float(np.sqrt(max(np.var(mean, ddof=1) - temporal / frames, 0.0))))
    return np.array(out)


@dataclass(frozen=True)
class Datasheet:
    """
    A camera's datasheet in the spirit of an EMVA 1288 report.

    Attributes
    ----------
    rows : list of dict
        ``quantity``, ``condition``, ``value``, ``unit`` rows (one CSV).
    ptc : PhotonTransfer
        The photon-transfer curve.
    netd : tuple of numpy.ndarray
        (temperatures [K], NETD [K]) at the datasheet's integration time.
    range : tuple of numpy.ndarray
        (integration times [s], lowest measurable [K], saturation [K]).
    """

    rows: list
    ptc: PhotonTransfer
    netd: tuple
    range: tuple

    def csv_text(self) -> str:
        """The rows as CSV text (quantity, condition, value to 6 significant digits, unit)."""
        import csv
        import io

        text = io.StringIO()
        writer = csv.DictWriter(text, ["quantity", "condition", "value", "unit"],
                                lineterminator="\n")
        writer.writeheader()
        writer.writerows({**r, "value": f"{r['value']:.6g}"} for r in self.rows)
        return text.getvalue()

    def draw(self, axes, name: str, integration_time: float, highest: float = np.inf):
        """Draw the photon-transfer curve, the NETD curve and the measurable range on three
        matplotlib axes; ``name``: the camera's; ``integration_time`` [s]; saturation is drawn
        up to ``highest`` [K] (the calibration's top: +∞ means not within the range)."""
        ptc, (t_range, lowest, top), at = self.ptc, self.range, f"{integration_time * 1e6:g} µs"
        fit = fit_emva1288(ptc)
        signal, variance = ptc.mean - ptc.dark_mean, ptc.variance - ptc.dark_variance
        axes[0].plot(signal, variance, "o", label="measured")
        linear = np.linspace(0.0, signal[fit.linear_range].max(), 2)
        axes[0].plot(linear, fit.gain * linear, "-", label=f"fit: K = {fit.gain:.4g} DN/e⁻")
        peak = int(np.argmax(variance))  # the variance peak: saturation (EMVA 1288)
        axes[0].plot(signal[peak], variance[peak], "s", mfc="none", ms=11,
                     label="saturation (variance peak)")
        axes[0].set(xlabel="μ_y − μ_y,dark [DN]", ylabel="σ²_y − σ²_y,dark [DN²]",
                    title=f"{name}: photon transfer at {at}")
        axes[0].legend()
        axes[1].semilogy(self.netd[0] - CELSIUS_OFFSET, self.netd[1], "o-")
        axes[1].set(xlabel="blackbody temperature [°C]", ylabel="NETD [K]",
                    title=f"{name}: NETD at {at}")
        capped = top > highest
        top = np.minimum(top, highest)
        low_c, top_c = lowest - CELSIUS_OFFSET, top - CELSIUS_OFFSET
        axes[2].fill_between(t_range * 1e6, low_c, top_c, alpha=0.3)
        axes[2].semilogx(t_range * 1e6, low_c, label="lowest measurable (blank + 3σ)")
        axes[2].semilogx(t_range * 1e6, top_c, label="saturation" + (
            " (the calibration's top where dashed)" if capped.any() else ""))
        if capped.any():
            axes[2].semilogx(t_range[capped] * 1e6, top_c[capped], "k--")
        axes[2].set(xlabel="integration time [µs]", ylabel="temperature [°C]",
                    title=f"{name}: measurable range")
        axes[2].legend()


def datasheet(camera, integration_time: float, ptc_temperatures, netd_temperatures,
              range_times, frames: int = 16, rng=None, progress=None) -> Datasheet:
    """
    The camera characterised as an EMVA 1288 report would: gain K, dark noise σ_d and
    saturation capacity from the photon-transfer curve; DSNU and PRNU from the spatial model;
    the linearity error from an exposure sweep; the NETD curve at ``integration_time`` [s]
    over ``netd_temperatures`` [K]; the measurable range over ``range_times`` [s].
    ``progress``, if given, is called as ``progress(done, total, label)`` after each step
    (each photon-transfer level, the flat fields, the NETD curve, each range time).
    """
    single_band(camera, "the datasheet")
    rng = np.random.default_rng(rng)
    total = len(ptc_temperatures) + 2 + len(range_times)
    done = 0

    def step(label):
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total, label)

    ptc = photon_transfer(camera, integration_time, ptc_temperatures, rng=rng, progress=step)
    fit = fit_emva1288(ptc)
    # Half saturation for the PRNU: the PTC level nearest it.
    half = ptc.dark_mean + 0.5 * (ptc.mean.max() - ptc.dark_mean)
    level = float(ptc.temperature[np.argmin(np.abs(ptc.mean - half))])
    spatial = spatial_nonuniformity(camera, level, integration_time, fit.gain, frames, rng)
    step(f"{frames} dark and bright flat fields")
    # Linearity: the PTC's levels below saturation, exposure ∝ the noise-free photo-charge.
    calibration = camera.calibration(integration_time)
    exposure = calibration.photoelectrons(ptc.temperature)
    below = ptc.mean < 0.98 * ptc.mean.max()
    le = linearity_error(exposure[below], ptc.mean[below], ptc.dark_mean)
    t_netd = np.asarray(netd_temperatures, dtype=float)
    netd_curve = netd(camera, t_netd, integration_time)
    step("NETD curve")
    times = np.asarray(range_times, dtype=float)
    limits = []
    for t in times:
        limits.append(measurable_range(camera, t))
        step(f"measurable range at {t * 1e6:.3g} µs")
    limits = np.array(limits)
    condition = f"t_int = {integration_time * 1e6:g} us"
    rows = [
        {"quantity": "system gain K", "condition": condition, "value": fit.gain,
         "unit": "DN/e-"},
        {"quantity": "dark noise", "condition": condition, "value": fit.dark_noise, "unit": "e-"},
        {"quantity": "saturation capacity", "condition": condition,
         "value": fit.saturation_capacity, "unit": "e-"},
        {"quantity": "DSNU", "condition": condition, "value": spatial.dsnu, "unit": "e-"},
        {"quantity": "PRNU", "condition": f"{condition}, {level:g} K",
         "value": 100 * spatial.prnu, "unit": "%"},
        {"quantity": "linearity error", "condition": condition, "value": le, "unit": "%"},
    ]
    rows += [{"quantity": "NETD", "condition": f"{condition}, {t:g} K", "value": float(v),
              "unit": "K"} for t, v in zip(t_netd, netd_curve)]
    for t, (low, sat) in zip(times, limits):
        rows.append({"quantity": "lowest measurable temperature",
                     "condition": f"t_int = {t * 1e6:g} us", "value": float(low), "unit": "K"})
        rows.append({"quantity": "saturation temperature",
                     "condition": f"t_int = {t * 1e6:g} us", "value": float(sat), "unit": "K"})
    return Datasheet(rows, ptc, (t_netd, netd_curve), (times, limits[:, 0], limits[:, 1]))


@dataclass(frozen=True)
class DatasheetPlan:
    """The levels a datasheet measures (:func:`datasheet_plan`): photon-transfer levels [K]
    (25, from the noise floor to 1.2 × saturation, so the variance peaks inside), NETD levels
    [K] (12, from the noise floor up to saturation) and range integration times [s] (13, 1 µs
    to one frame period or 10 ms, evenly in log)."""

    ptc_temperatures: np.ndarray
    netd_temperatures: np.ndarray
    range_times: np.ndarray


#: Datasheet grids (counts), the range's times [s] and the PTC's reach past saturation [1].
PTC_LEVELS, NETD_LEVELS, RANGE_TIMES, RANGE_SHORTEST, RANGE_LONGEST = 25, 12, 13, 1e-6, 10e-3
PTC_PAST_SATURATION = 1.2


def datasheet_plan(camera, integration_time: float) -> DatasheetPlan:
    """
    The levels ``radiosim report`` measures at ``integration_time`` [s] (:class:`DatasheetPlan`),
    between the calibration's lowest measurable temperature (blank + 3σ) and its saturation
    temperature [K], both within the camera's calibration range. Refuses a camera without an
    array shape, or one with no measurable range at that time.
    """
    single_band(camera, "the datasheet")
    if camera.fpa.shape is None:
        raise RadiosimError(f"{camera.name} has no array shape ([fpa] shape): a datasheet "
                            "measures its whole array")
    calibration = camera.calibration(integration_time)
    low = calibration.lowest_measurable_temperature()
    saturation = calibration.saturation_temperature
    if not (np.isfinite(low) and saturation > low):
        raise RadiosimError(f"at {integration_time * 1e6:g} µs {camera.name} has no measurable "
                            f"range within its calibration (floor {low:g} K, saturation "
                            f"{saturation:g} K): choose another --integration-time")
    top = min(saturation * PTC_PAST_SATURATION, camera.calibration_range[1])
    saturation = min(saturation, camera.calibration_range[1])
    longest = 1.0 / camera.frame_rate if camera.frame_rate else RANGE_LONGEST
    return DatasheetPlan(np.linspace(low, top, PTC_LEVELS),
                         np.linspace(low, saturation, NETD_LEVELS, endpoint=False),
                         np.geomspace(RANGE_SHORTEST, longest, RANGE_TIMES))

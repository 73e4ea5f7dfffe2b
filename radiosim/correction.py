"""
Correcting a reading toward the scene: the optics' blur (the size-of-source effect) and a known
uniform motion over the window, removed where the chain is linear — in the calibrated object
signal ε·L(T), not in temperature — with the uncertainty the correction leaves.

The measured object signal of a pixel is the scene's signal blurred by the optics' point-spread
function, averaged over the pixel's footprint and over the window, during which a scene
translating at ``velocity`` moves by v·t_int. On the pixel grid (pitch p in object space) that
is, in frequency, S_meas(f) = F(f) · H(f) · S(f): F the footprint's transfer, kept (the target
is what a perfect lens and an instantaneous exposure would read: the footprint mean), and H
the optics' transfer function — for a polychromatic PSF the sub-bands' OTFs weighted by their
shares of the frame's signal — times sinc(f · v·t_int) for the motion. The correction is the
Wiener filter::

    W(f) = H*(f) / (|H(f)|² + σ² / σ_S² + Σ_b s_b |H_b(f) − H(f)|²),   W(0) = 1 / H(0),

σ² the white noise variance of a pixel's object signal (the camera's temporal noise at the
frame's mean charge, in signal units, and the converter's step), σ_S² the scene's (the frame's
variance less the noise's), and the last term the spread of the sub-bands' transfers H_b
(shares s_b) about H, how far a pixel hotter or colder than the frame's median is blurred
otherwise: where the blur left the signal above the noise and that spread, W inverts it;
where not, W tends to 0 and the frequency is given up rather than invented; the frame's mean
(f = 0), which every pixel's noise averages down, is kept. The filter works on the frame
extended by its mirror image as far as the blur reaches.

A rolling shutter's row r integrates r·row_time after the first: with a velocity, the
corrected rows are brought to the first row's window (the scene a row saw, moved back by
v·r·row_time; resampled by cubic splines).

The uncertainty per pixel has two parts: the noise carried through the (linear) filter,
√(Σ_k w_k² σ²) with w the filter's (real) kernel, and the regularisation's bias, estimated from the
corrected signal as (W·H − 1) applied to it; both are carried to temperature through the
response's slope dS/dT. It covers the camera's temporal noise and the filter's bias; not a PSF
or a velocity other than the camera's and the caller's, not the emissivity, not the
calibration's own error. Pixels are NaN (flagged ``untrusted``) where the measurement has no
reading (saturated, under or over range) or such a pixel's light reaches them, within the
PSF's and the motion's reach of the frame's edge (nearer than the radius beyond which 5 % of
the widest PSF's light lies: the filter sees the frame's mirror image beyond its edge, the
world there being unknown), or where the correction is mostly regularisation (the bias estimate
above 3 × the noise and a tenth of the pixel's signal).

References
----------
Gonzalez, R. C. & Woods, R. E. (2018). *Digital Image Processing*, 4th ed., §5.8 (Wiener
filtering). Saunders, P. et al. (2008). Size-of-source effect correction of radiation
thermometers by deconvolution. Int. J. Thermophys. 29, 1066–1083.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import fft, ndimage

from radiosim.acquisition import is_rolling
from radiosim.calibration import fill_from_nearest
from radiosim.errors import RadiosimError

__all__ = ["Correction", "correct", "MODEL_FLOOR", "REACH_LIGHT"]

#: The least noise-to-signal ratio the filter assumes, even for noise-free electronics: the
#: filter stays finite where the transfer function has zeros (a motion's), and the forward
#: model's own error (a convolution on the pixel grid: the sampling's aliasing left out) is
#: not inverted without bound. Chosen on the closed-loop tests: 1e-4 already blunts the
#: correction of a Gaussian blur of 1.5 pixels (a feature's centre corrected by half, not
#: four-fifths, of its bias).
MODEL_FLOOR = 1e-8


@dataclass(frozen=True)
class Correction:
    """
    A corrected reading.

    Attributes
    ----------
    temperature : numpy.ndarray
        The corrected temperature [K] per pixel; NaN where it cannot be trusted.
    uncertainty : numpy.ndarray
        Its standard uncertainty [K] (noise through the filter and the filter's bias).
    untrusted : numpy.ndarray of bool
        The pixels set to NaN (no reading, the frame's edge, regularisation-dominated).
    noise_uncertainty : numpy.ndarray
        The part of ``uncertainty`` the camera's temporal noise makes, through the filter [K].
    transfer : numpy.ndarray
        H on the frequencies of the frame extended by its mirror image as far as the blur
        reaches (``scipy.fft.rfft2`` order: the half spectrum), for inspection.
    """

    temperature: np.ndarray
    uncertainty: np.ndarray
    untrusted: np.ndarray
    noise_uncertainty: np.ndarray
    transfer: np.ndarray


def _velocity(velocity) -> tuple[float, float] | None:
    if velocity is None:
        return None
    try:
        v = np.asarray(velocity, dtype=float)
    except (TypeError, ValueError):
        raise RadiosimError(f"velocity must be (vx, vy) in m/s, got {velocity!r}") from None
    if v.shape != (2,) or not np.all(np.isfinite(v)):
        raise RadiosimError(f"velocity must be two finite numbers (vx, vy) in m/s, got "
                            f"{velocity!r}")
    if np.max(np.abs(v)) > 1e4:
        raise RadiosimError(f"velocity ({v[0]:g}, {v[1]:g}) m/s is faster than any machined "
                            "chip (10 km/s): is it in µm/s or mm/s? velocity is in m/s")
    return float(v[0]), float(v[1])


#: The share of a PSF's light that may come from beyond the frame's edge for a pixel to be
#: trusted: the world beyond the edge is unknown (the filter sees the frame's mirror image
#: there), so pixels nearer the edge than the radius that holds 1 − this of the light are
#: flagged.
REACH_LIGHT = 0.05


def _reach(camera, velocity, integration_time: float) -> float:
    """How far [pixels] the blur carries light: the radius beyond which less than
    :data:`REACH_LIGHT` of the widest PSF's light lies, at each sub-band's wavelength (their
    convolution reaches a little further), and half the motion over the window."""
    pitch = camera.fpa.pixel_pitch
    reach = 0.0
    psfs = camera.optics.psf or ()
    if psfs:
        from radiosim.imaging import sub_band_count

        na = camera.optics.object_na(camera.fpa)
        lam_mid = 0.5 * sum(camera.optics.band)
        wavelengths = [lam_mid] + [w for _, w in camera.response_model.sub_bands(
            sub_band_count(psfs)) if np.isfinite(w)]
        # the widest PSF's (the union bound over a convolution, Σ of each one's radius at its
        # share, flags the whole of a small frame behind diffraction and a halo)
        reach = max(psf.radius(REACH_LIGHT, lam, na) / pitch for psf in psfs
                    for lam in wavelengths)
    if velocity is not None:
        reach += math.hypot(*velocity) * integration_time / pitch / 2
    return reach


def _transfer(camera, shape, stats_temperature: float, velocity, integration_time: float):
    """H(fy, fx) on the half spectrum (``scipy.fft.rfft2`` order) of a grid of ``shape``
    pixels [1], and the variance of the sub-bands' transfers about it, Σ_b s_b |H_b − H|²
    [1] (s_b each sub-band's share of the signal: how far a pixel whose spectrum is not the
    frame's may be blurred otherwise). A real PSF's transfer is Hermitian, H(−f) = H*(f):
    the half holds all of it."""
    pitch = camera.fpa.pixel_pitch
    fy = np.fft.fftfreq(shape[0], d=pitch)[:, None]  # [cycles/m]
    fx = np.fft.rfftfreq(shape[1], d=pitch)[None, :]
    psfs = camera.optics.psf or ()
    # real where every OTF is (a symmetric PSF's): complex arithmetic only where needed
    h = np.ones((shape[0], fx.size))
    spread = np.zeros(h.shape)
    if psfs:
        from radiosim.imaging import sub_band_count

        na = camera.optics.object_na(camera.fpa)
        lam_mid = 0.5 * sum(camera.optics.band)
        for psf in (p for p in psfs if not p.chromatic):  # one transfer for every sub-band
            h = h * psf.otf(fx, fy, lam_mid, na)
        chromatic = [p for p in psfs if p.chromatic]
        if chromatic:
            bands = camera.response_model.sub_bands(sub_band_count(psfs))
            shares = np.array([float(np.ravel(r.grey_signal(stats_temperature))[0])
                               for r, _ in bands])
            if not (np.all(np.isfinite(shares)) and shares.sum() > 0):
                shares = np.ones(len(bands))
            shares = shares / shares.sum()  # each sub-band's part of the frame's signal
            total, second = 0.0, 0.0
            for (_, wavelength), share in zip(bands, shares):
                lam = wavelength if np.isfinite(wavelength) else lam_mid
                otf = 1.0
                for psf in chromatic:
                    otf = otf * psf.otf(fx, fy, lam, na)
                total = total + share * otf
                second = second + share * (otf * otf if np.isrealobj(otf) else np.abs(otf) ** 2)
            total_power = total * total if np.isrealobj(total) else np.abs(total) ** 2
            h_power = h * h if np.isrealobj(h) else np.abs(h) ** 2
            spread = np.maximum(second - total_power, 0.0) * h_power
            h = h * total
    if velocity is not None:
        dx, dy = (v * integration_time / pitch for v in velocity)  # [pixels] over the window
        motion = np.sinc(fx * pitch * dx) * np.sinc(fy * pitch * dy)
        h, spread = h * motion, spread * motion ** 2
    return h, spread


#: Nodes of the table through which corrected signals are turned into temperatures: linear
#: interpolation in ln S between exact inversions, whose error, h²/8 · d²T/d(ln S)² with h
#: the node spacing, is below 5e-6 K over a span of ln S of 25 (d²T/d(ln S)² < 1e3 K for
#: T < 3000 K in the infrared bands; the span is the frame's signals' within the radiance
#: table's temperatures).
_INVERSION_NODES = 1 << 17


def _signal_temperature(signal: np.ndarray, calibration) -> tuple[np.ndarray, np.ndarray]:
    """Temperature [K] of each object signal (NaN where none), and its slope dT/dS
    [K per signal unit]: the response's exact inversion at :data:`_INVERSION_NODES` signals
    spanning the frame's, interpolated in ln S between them (a frame's million distinct
    signals inverted at the cost of a table's; the slope is the interval's)."""
    response, emissivity = calibration.response, calibration.emissivity
    positive = np.isfinite(signal) & (signal > 0)

    def exactly(where):
        t = response.temperature(np.where(where, signal, np.nan), emissivity)
        finite = np.isfinite(t)
        slope = np.full(signal.shape, np.nan)
        if finite.any():
            slope[finite] = 1.0 / response.slope(t[finite], emissivity)
        return t, slope

    if positive.sum() <= _INVERSION_NODES:
        return exactly(positive)
    log_signal = np.log(np.where(positive, signal, 1.0))
    low, high = log_signal[positive].min(), log_signal[positive].max()
    if hasattr(response, "table"):  # a radiance table: no temperature beyond its ends
        ends = response.table().temperature_range  # [K]
        low, high = (max(low, math.log(float(response.grey_signal(ends[0], emissivity)))),
                     min(high, math.log(float(response.grey_signal(ends[1], emissivity)))))
    if not low < high:
        return exactly(positive)
    # (a ringing pixel's signal far below the table would otherwise spread the nodes thin)
    nodes = np.linspace(low, high, _INVERSION_NODES)
    at_nodes = response.temperature(np.exp(nodes), emissivity)
    inside = np.isfinite(at_nodes)  # contiguous: the inversion is monotonic
    if inside.sum() < 2:
        return exactly(positive)
    first, last = np.flatnonzero(inside)[[0, -1]]
    # the nodes are evenly spaced: each value's interval by arithmetic, not a search
    step = (nodes[-1] - nodes[0]) / (_INVERSION_NODES - 1)
    position = (log_signal - nodes[0]) / step
    k = np.clip(position, first, last - 1).astype(np.intp)
    rise = at_nodes[k + 1] - at_nodes[k]  # [K] over the interval
    temperature = at_nodes[k] + (position - k) * rise
    within = positive & (log_signal >= nodes[first]) & (log_signal <= nodes[last])
    temperature = np.where(within, temperature, np.nan)
    slope = np.where(within, rise / (step * np.where(positive, signal, 1.0)), np.nan)
    rest = positive & ~within  # beyond the nodes' ends: exactly
    if rest.any():
        t, g = exactly(rest)
        temperature = np.where(rest, t, temperature)
        slope = np.where(rest, g, slope)
    return temperature, slope


def correct(measurement, velocity=None, rng=None) -> Correction:
    """
    Correct ``measurement``'s reading for its camera's optical blur and, with ``velocity``
    (vx, vy) [m/s] in object space, a uniform motion over its window (module docstring).

    Parameters
    ----------
    measurement
        A :class:`~radiosim.measurement.Measurement` (its ``camera``, counts, flags and
        window), simulated or a recording converted through a camera.
    velocity
        The scene's uniform velocity (vx, vy) [m/s] in object space, x along the columns and
        y down the rows; ``None``: a static scene.
    rng
        Unused: the correction is deterministic (kept for the interface's stability).

    Returns
    -------
    Correction
    """
    camera = getattr(measurement, "camera", None)
    if camera is None or not hasattr(camera, "calibration"):
        raise RadiosimError("correct needs a Measurement with its camera (measurement.camera)")
    if getattr(camera, "channels", None) is not None:
        raise RadiosimError(f"correct works on one band; {camera.name} has "
                            f"{len(camera.channels)} channels: correct each channel's "
                            "measurement (measurement.channels[k])")
    velocity = _velocity(velocity)
    if not camera.optics.psf and velocity is None:
        raise RadiosimError(f"{camera.name} has a perfect lens (no PSF) and no velocity was "
                            "given: there is nothing to correct (give the camera its measured "
                            "PSF, or velocity=(vx, vy) [m/s])")
    t_int = measurement.integration_time
    calibration = camera.calibration(t_int)
    counts = np.asarray(measurement.counts, dtype=float)
    valid = np.asarray(measurement.valid, dtype=bool) & np.isfinite(counts)
    if valid.sum() < 4:
        raise RadiosimError("correct needs a reading: fewer than 4 pixels of the measurement "
                            "are valid (saturated or under range)")
    signal = calibration.object_signal(counts)  # ε·L(T) [signal unit]
    filled = fill_from_nearest(signal, valid)
    typical = float(np.median(measurement.apparent_temperature[valid][::7]))  # (a sample)
    shape = signal.shape
    reach = _reach(camera, velocity, t_int)
    # The frame extended by its mirror image as far as the blur reaches: the filter's
    # circular convolution then meets no jump where the frame's opposite edges would wrap
    # onto each other (a jump the blur never smoothed, which the filter would invert).
    # (each axis's extension rounded up to a length the FFT takes fast)
    extra = [fft.next_fast_len(n + 2 * min(math.ceil(reach) + 2, n - 1), real=True) - n
             for n in shape]
    widths = tuple((e // 2, e - e // 2) for e in extra)
    inner = tuple(slice(w[0], w[0] + n) for w, n in zip(widths, shape))
    filled = np.pad(filled, widths, mode="symmetric")
    grid = filled.shape
    h, spread = _transfer(camera, grid, typical, velocity, t_int)
    # The noise of one pixel's object signal [signal unit]: temporal noise at the mean charge
    # (shot, read and the converter's step), through the signal's rate.
    electrons = float(np.mean(np.asarray(measurement.electrons)[valid]))
    el = camera.electronics
    per_signal = calibration.rate_per_signal * t_int  # [e⁻ per signal unit]
    sigma = float(el.temporal_noise(electrons)) / per_signal  # with the converter's step
    sigma = max(sigma, 1e-9 * float(np.mean(np.abs(filled))))  # noise-free: a floor
    # The transforms on as many threads as the kernels have (one in a single-thread worker)
    from radiosim.kernels.launch import thread_count

    threads = thread_count()
    spectrum = fft.rfft2(filled, workers=threads)
    h2 = h * h if np.isrealobj(h) else np.abs(h) ** 2
    # The noise-to-signal ratio, one number (the parametric Wiener filter): the noise's
    # variance over the scene's, whose spectrum the blur and the noise leave unknown per
    # frequency (estimated per frequency from the measured one, the noise's own fluctuations
    # would be inverted where H is small).
    ratio = max(sigma ** 2 / max(float(np.var(filled)) - sigma ** 2, sigma ** 2 * 1e-6),
                MODEL_FLOOR)
    # The transfer is known to within the sub-bands' spread about it (a pixel hotter or colder
    # than the frame's median is blurred by its own mixture of sub-bands): a frequency is
    # inverted only where H stands out of that spread as well as out of the noise.
    wiener = (h if np.isrealobj(h) else np.conj(h)) / (h2 + ratio + spread)
    # The frame's mean is measured through the noise of every pixel at once: never damped
    # (a low-contrast frame would otherwise lose its level with its detail).
    wiener[0, 0] = 1.0 / h[0, 0] if abs(h[0, 0]) > 0 else 1.0
    corrected_spectrum = wiener * spectrum
    corrected = fft.irfft2(corrected_spectrum, s=grid, workers=threads)
    # Uncertainty: the noise through the filter, each pixel's own variance σ_j² (shot noise
    # follows the signal) weighted by the filter's kernel: var_i = Σ_j |w_(i−j)|² σ_j²; and the
    # filter's bias, (W·H − 1) applied to the corrected signal.
    variance = np.broadcast_to(el.temporal_noise(np.asarray(measurement.electrons,
                                                            dtype=float)) ** 2,
                               shape) / per_signal ** 2  # [signal unit²]
    variance = np.pad(np.where(valid, variance, sigma ** 2), widths, mode="symmetric")
    kernel = fft.irfft2(wiener, s=grid, workers=threads)  # w on the grid (circular)
    kernel_power = fft.rfft2(kernel * kernel, workers=threads)
    noise = np.sqrt(np.maximum(fft.irfft2(fft.rfft2(variance, workers=threads) * kernel_power,
                                          s=grid, workers=threads), 0.0))
    bias = fft.irfft2((wiener * h - 1.0) * corrected_spectrum, s=grid, workers=threads)
    corrected, noise, bias, filled = (v[inner] for v in (corrected, noise, bias, filled))
    edge = math.ceil(reach)
    near_edge = np.zeros(shape, dtype=bool)
    if edge:
        near_edge[:edge, :] = near_edge[-edge:, :] = True
        near_edge[:, :edge] = near_edge[:, -edge:] = True
    # a pixel whose flagged neighbours fed the filter is no reading either
    reach_of_flags = ~valid
    if not valid.all():
        reach_of_flags = ndimage.maximum_filter(reach_of_flags, size=2 * max(edge, 1) + 1)
    # mostly regularisation: the filter's estimated bias above 3 × the noise and a tenth of
    # the pixel's signal (the filter damped, rather than inverted, what made the pixel)
    regularised = np.abs(bias) > np.maximum(3 * noise, 0.1 * np.abs(filled))
    flagged = reach_of_flags | near_edge | regularised
    if velocity is not None and is_rolling(camera):
        corrected, noise, bias, flagged = _unroll(corrected, noise, bias, flagged, velocity,
                                                  camera.fpa.row_time / camera.fpa.pixel_pitch)
    temperature, per_signal_unit = _signal_temperature(corrected, calibration)  # [K], [K/unit]
    uncertainty = np.hypot(noise, bias) * np.abs(per_signal_unit)  # [K]
    untrusted = flagged | ~np.isfinite(temperature)
    noise_only = noise * np.abs(per_signal_unit)
    return Correction(np.where(untrusted, np.nan, temperature),
                      np.where(untrusted, np.nan, uncertainty), untrusted,
                      np.where(untrusted, np.nan, noise_only), h)


def _unroll(corrected, noise, bias, flagged, velocity, row_time_per_pitch: float):
    """A rolling shutter's rows brought to its first row's window: row r integrates
    r·row_time later, when a scene moving at v has moved by v·r·row_time, so the scene that
    row i saw at the first row's time lies at the row r = i / (1 − v_y·row_time/p) and the
    column c = j + v_x·r·row_time/p of the reading (p the pitch). The corrected signal is
    resampled there by cubic splines (it is band-limited by the filter), its noise and bias
    bilinearly; a pixel is flagged where that falls outside the frame or next to a flagged
    one."""
    vx, vy = (v * row_time_per_pitch for v in velocity)  # [pixels per row of delay]
    if not 0 < 1 - vy:
        raise RadiosimError(f"the scene moves up the rolling shutter's rows as fast as they "
                            f"are read ({velocity[1]:g} m/s): its rows cannot be brought to "
                            "one time")
    rows, cols = corrected.shape
    i, j = np.mgrid[0:rows, 0:cols].astype(float)
    r = i / (1 - vy)
    where = [r, j + vx * r]
    outside = (where[0] > rows - 1) | (where[1] < 0) | (where[1] > cols - 1)
    flagged = ndimage.map_coordinates(ndimage.maximum_filter(flagged, size=3).astype(float),
                                      where, order=1, mode="nearest") > 0
    return (ndimage.map_coordinates(corrected, where, order=3, mode="nearest"),
            *(ndimage.map_coordinates(v, where, order=1, mode="nearest") for v in (noise, bias)),
            flagged | outside)

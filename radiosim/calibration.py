"""
Calibration: the camera's own inversion of digital numbers to apparent temperature, and the
flags of what it cannot invert.

Like a real radiometric camera, the calibration is built for one camera and one integration
time from its noise-free response to a grey body under the camera's *settings*: the assumed
emissivity ε_a, reflected temperature T_r, path (transmission τ_a, temperature T_p) and the
optics' emission at the assumed instrument temperature, I (which may all differ from the
scene's truth). Its forward model is the thermography equation
(:func:`radiosim.response.observed_signal`) through the electronics' own mean-count function::

    S(T)  = τ_a · (ε_a L(T) + (1 − ε_a) L(T_r)) + (1 − τ_a) · L(T_p) + I
    DN(T) = Electronics.mean_counts(S(T) · rate_per_signal · t_int, t_int)
          = K · (S(T) · G · t_int + I_dark · t_int) + offset

with L the response signal of a blackbody (in-band photon radiance for the Planck response; the
linear response's signal is T itself, with no reflection, path or emission) and G the optics'
electron rate per unit of signal (the étendue). The inversion solves it for T: it subtracts the
emission, the path and the reflection, and inverts ε_a L(T) on the response's monotonic curve.

Flags (a flagged pixel has no apparent temperature, NaN):

-   *saturated*: the well is full or the converter is at its top code;
-   *over range*: the reading lies above the calibration range while neither is full (a
    temperature hotter than the calibration covers, or noise on a very short integration);
-   *under range*: the converter is at code 0, or the reading lies below the calibration range,
    or its counts lie below those of the noise floor — the lowest temperature whose
    photo-signal equals its temporal noise (:meth:`Calibration.lowest_measurable_temperature`,
    SNR = 1). A reading there is dominated by noise and would read high, so it is not
    reported. The rule applies to each reading: a scene far below the floor is still reported
    where noise lifts a pixel above it (for noise around the dark level, with the probability
    of a one-σ excursion, about one pixel in six), so readings near the floor are noisy ones.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from radiosim.checks import check_fraction, check_positive
from radiosim.electronics import Electronics, Exposure, apply_nonlinearity
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.response import Response, object_signal, observed_signal

__all__ = ["Calibration", "Reading", "MIN_CALIBRATION_SPAN_DN", "NonUniformityCorrection",
           "replace_bad_pixels"]

#: A quantising camera whose calibration spans fewer counts than this over its temperature
#: range reads in steps of more than 1/this of the range: the calibration warns.
MIN_CALIBRATION_SPAN_DN = 100.0
_ROUNDING = 1e-12  # relative slack of the range's ends for the DN ↔ signal round trip


@dataclass(frozen=True)
class Reading:
    """
    What the calibration makes of one read-out.

    Attributes
    ----------
    apparent_temperature : numpy.ndarray
        Temperature [K]; NaN where flagged.
    saturated : numpy.ndarray of bool
        Full well or converter top code.
    under_range : numpy.ndarray of bool
        Converter code 0, below the calibration range, or below the noise floor.
    over_range : numpy.ndarray of bool
        Above the calibration range although the well and the converter are not full.
    """

    apparent_temperature: np.ndarray
    saturated: np.ndarray
    under_range: np.ndarray
    over_range: np.ndarray


class Calibration:
    """
    DN ↔ apparent temperature for one response, electronics and integration time.

    Parameters
    ----------
    response
        The camera's :class:`~radiosim.response.Response`.
    electronics
        The camera's :class:`~radiosim.electronics.Electronics`.
    rate_per_signal
        Electron rate per unit of signal [e⁻ s⁻¹ per signal unit] (the étendue for the Planck
        response, see :meth:`~radiosim.response.Response.rate_per_signal`).
    integration_time
        Integration time [s].
    assumed_emissivity
        The camera's emissivity setting (dimensionless).
    temperature_range
        Temperatures the calibration covers [K].
    reflected_temperature
        The camera's reflected-temperature setting [K]; ``None``: nothing reflected.
    path_transmission, path_temperature
        The camera's path setting: transmission [1] and temperature [K] (``None`` with τ = 1).
    background_signal
        The optics' own emission at the assumed instrument temperature [signal unit].

    Examples
    --------
    >>> from radiosim.response import LinearResponse
    >>> cal = Calibration(LinearResponse(1e6), Electronics.ideal(), 1e6, 10e-6)
    >>> float(cal.temperature(cal.counts(1012.15)))
    1012.15
    """

    def __init__(self, response: Response, electronics: Electronics, rate_per_signal: float,
                 integration_time: float, assumed_emissivity: float = 1.0,
                 temperature_range=(150.0, 3000.0), reflected_temperature: float | None = None,
                 path_transmission: float = 1.0, path_temperature: float | None = None,
                 background_signal: float = 0.0):
        self.integration_time = check_positive(integration_time, "integration time", "s")
        self.response = response
        self.electronics = electronics
        self.rate_per_signal = check_positive(rate_per_signal, "rate per signal",
                                              "e⁻ s⁻¹ per signal unit")
        self.emissivity = check_fraction(assumed_emissivity, "assumed_emissivity")
        low, high = (float(t) for t in temperature_range)
        if not 0 < low < high:
            raise RadiosimError(f"calibration range must be (T_min, T_max) with 0 < T_min < "
                                f"T_max [K], got {temperature_range!r}")
        self.temperature_range = (low, high)
        if not 0 < path_transmission <= 1 or (path_transmission < 1 and path_temperature is None):
            raise RadiosimError(f"assumed path transmission must be in (0, 1] (with a path "
                                f"temperature below 1), got {path_transmission!r}")
        radiometric = response.radiometric
        self.path_transmission = float(path_transmission) if radiometric else 1.0
        # The terms of the thermography equation that do not depend on T [signal unit].
        self.reflected_signal = (0.0 if reflected_temperature is None or not radiometric else
                                 (1 - self.emissivity) * float(response.grey_signal(
                                     check_positive(reflected_temperature,
                                                    "assumed reflected temperature", "K"))))
        self.path_signal = (0.0 if path_temperature is None or not radiometric else float(
            response.grey_signal(check_positive(path_temperature, "assumed path temperature",
                                                "K"))))
        self.background_signal = float(background_signal) if radiometric else 0.0

    # -- forward model ---------------------------------------------------------------------

    def signal(self, temperature) -> np.ndarray:
        """Noise-free signal [signal unit] from a grey body at ``temperature`` [K] under the
        camera's settings (the thermography equation and the optics' emission)."""
        emitted = self.response.grey_signal(np.asarray(temperature, dtype=float),
                                            self.emissivity)
        return observed_signal(emitted, self.reflected_signal, self.path_transmission,
                               self.path_signal) + self.background_signal

    def photoelectrons(self, temperature) -> np.ndarray:
        """Noise-free photo-charge [e⁻] from a grey body at ``temperature`` [K]."""
        return self.signal(temperature) * self.rate_per_signal * self.integration_time

    @property
    def background_photoelectrons(self) -> float:
        """Photo-charge [e⁻] with no emission from the object (a body at 0 K): reflection,
        path and the optics' emission."""
        signal = observed_signal(0.0, self.reflected_signal, self.path_transmission,
                                 self.path_signal) + self.background_signal
        return signal * self.rate_per_signal * self.integration_time

    def electrons(self, temperature) -> np.ndarray:
        """Noise-free charge [e⁻] (photo and dark) from a grey body at ``temperature`` [K]
        (no full-well clip)."""
        return self.photoelectrons(temperature) + (self.electronics.dark_current
                                                   * self.integration_time)

    def counts(self, temperature) -> np.ndarray:
        """Noise-free, unrounded, unclipped digital numbers [DN] at ``temperature`` [K]."""
        return self.electronics.mean_counts(self.photoelectrons(temperature),
                                            self.integration_time)

    # -- inverse ---------------------------------------------------------------------------

    def _signal(self, counts) -> np.ndarray:
        photo = self.electronics.photoelectrons(counts, self.integration_time)  # [e⁻]
        return photo / (self.rate_per_signal * self.integration_time)  # [signal unit]

    def invert(self, counts):
        """
        Apparent temperature [K] of ``counts`` [DN], and where it falls outside the range.

        Returns
        -------
        temperature : numpy.ndarray
            Apparent temperature [K]; NaN below or above the calibration range.
        below, above : numpy.ndarray of bool
            Counts under the lowest or over the highest temperature of the range.
        """
        signal = object_signal(self._signal(counts) - self.background_signal,
                               self.reflected_signal, self.path_transmission, self.path_signal)
        low, high = (self.response.grey_signal(t, self.emissivity)
                     for t in self.temperature_range)
        # The range is closed: its ends survive the counts round trip within a few ulp.
        below, above = signal < low * (1 - _ROUNDING), signal > high * (1 + _ROUNDING)
        temperature = self.response.temperature(np.clip(signal, low, high), self.emissivity)
        return np.where(below | above, np.nan, temperature), below, above

    def temperature(self, counts) -> np.ndarray:
        """
        Apparent temperature [K] of ``counts`` [DN]; NaN where no temperature of the
        calibration range gives them.
        """
        return self.invert(counts)[0]

    def read(self, exposure: Exposure) -> Reading:
        """
        Apparent temperature [K] and flags of a read-out (see the module docstring).
        """
        apparent, below, above = self.invert(exposure.counts)
        floor = self.noise_floor_counts
        saturated = exposure.saturated
        under = ~saturated & (exposure.adc_floor | below | (exposure.counts < floor))
        # Above the range: a temperature the calibration cannot give. It is saturation when
        # the signal would fill the well within the range's reach; noise on a short
        # integration that carries a reading past the top is "over range", not saturation.
        over = ~saturated & ~under & above
        apparent = np.where(saturated | under | over, np.nan, apparent)
        return Reading(apparent, saturated, under, over)

    # -- limits ----------------------------------------------------------------------------

    def noise(self, temperature) -> np.ndarray:
        """Temporal noise of a grey body's reading [e⁻ rms] (see
        :meth:`~radiosim.electronics.Electronics.temporal_noise`)."""
        return self.electronics.temporal_noise(self.electrons(temperature))

    def netd(self, temperature) -> np.ndarray:
        """
        Noise-equivalent temperature difference [K] at ``temperature`` [K]: the temporal noise
        [e⁻ rms] (:meth:`noise`) over the slope of the mean charge d e⁻/dT (a central
        difference of 1e-4 relative); NaN outside the calibration range and from saturation
        up.

        Examples
        --------
        >>> from radiosim.response import LinearResponse
        >>> el = Electronics(read_noise=10.0, shot_noise=False)
        >>> float(Calibration(LinearResponse(1e6), el, 1e6, 1e-3).netd(500.0))  # 10 e⁻ / 1000 e⁻/K
        0.01
        """
        t = np.asarray(temperature, dtype=float)
        h = 1e-4 * t
        slope = (self.photoelectrons(t + h) - self.photoelectrons(t - h)) / (2 * h)  # [e⁻/K]
        low, high = self.temperature_range
        beyond = (t < low) | (t > high) | (t >= self.saturation_temperature)
        return np.where(beyond, np.nan, self.noise(t) / slope)

    def lowest_measurable_temperature(self, snr: float = 1.0) -> float:
        """
        Lowest grey-body temperature [K] of the calibration range whose photo-signal (above
        the background of reflection, path and optics) is ``snr`` times its temporal noise (the
        noise floor at ``snr`` = 1); NaN if none below saturation.
        """
        from scipy.optimize import brentq

        background = self.background_photoelectrons

        def margin(t):
            return float(self.photoelectrons(t) - background - snr * self.noise(t))

        low, top = self.temperature_range
        high = min(self.saturation_temperature, top)  # −∞: everything saturates
        if margin(low) >= 0:
            return float(low)
        if not high > low or margin(high) < 0:
            return float("nan")
        return float(brentq(margin, low, high, xtol=1e-6))

    @cached_property
    def noise_floor_counts(self) -> float:
        """Counts [DN] of the noise floor (:meth:`lowest_measurable_temperature`); readings
        below it are flagged under range (∞ if the whole range is below it)."""
        if self.electronics.is_noise_free and self.electronics.adc_bits is None:
            return -math.inf
        floor = self.lowest_measurable_temperature()
        return math.inf if math.isnan(floor) else float(self.counts(floor))

    @property
    def saturation_temperature(self) -> float:
        """
        Lowest grey-body temperature [K] that fills the well or the converter: +∞ if nothing
        in (or above) the calibration's range saturates, −∞ if even its lowest temperature
        does.
        """
        charge = self.electronics.saturation_charge
        if not math.isfinite(charge):
            return math.inf
        el = self.electronics
        temperature, below, above = self.invert(
            el.gain * apply_nonlinearity(charge, el.nonlinearity, el.full_well) + el.offset)
        if bool(above):
            return math.inf
        if bool(below):
            return -math.inf
        return float(temperature)

    @property
    def counts_span(self) -> float:
        """Counts [DN] between the calibration range's ends, within the converter's codes."""
        low, high = (float(self.counts(t)) for t in self.temperature_range)
        top = self.electronics.max_count
        return min(high, top) - max(low, 0.0)

    def check_resolution(self, stacklevel: int = 2):
        """Warn if a quantising converter resolves the calibration range into fewer than
        :data:`MIN_CALIBRATION_SPAN_DN` codes (e.g. a linear response with real
        electronics: a few DN across thousands of kelvin)."""
        if self.electronics.adc_bits is None:
            return
        span = self.counts_span
        if span < MIN_CALIBRATION_SPAN_DN:
            low, high = self.temperature_range
            step = (high - low) / max(span, 1e-300)
            warnings.warn(
                f"the {self.response.name} response with these electronics spans only "
                f"{span:.3g} DN over {low:g}–{high:g} K at {self.integration_time:g} s: one DN is "
                f"about {step:.3g} K, so readings are coarse (raise the responsivity, gain or "
                "integration time)", RadiosimWarning, stacklevel=stacklevel + 1)


def replace_bad_pixels(values: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """
    ``values`` with each bad pixel replaced by the median of the good ones among its 3 × 3
    neighbours (5 × 5, 7 × 7, … where none is good), as cameras' bad-pixel replacement does.

    Examples
    --------
    >>> v = np.arange(9.0).reshape(3, 3); bad = np.zeros((3, 3), bool); bad[1, 1] = True
    >>> float(replace_bad_pixels(v, bad)[1, 1])
    4.0
    """
    out = np.array(values, dtype=float, copy=True)
    good = ~bad
    if not good.any():
        raise RadiosimError("every pixel is bad: none to replace them from")
    rows, cols = out.shape
    for i, j in zip(*np.nonzero(bad)):
        reach = 1
        while True:
            r0, r1 = max(i - reach, 0), min(i + reach + 1, rows)
            c0, c1 = max(j - reach, 0), min(j + reach + 1, cols)
            near = values[r0:r1, c0:c1][good[r0:r1, c0:c1]]
            if near.size:
                out[i, j] = float(np.median(near))
                break
            reach += 1
    return out


@dataclass(frozen=True, eq=False)
class NonUniformityCorrection:
    """
    A non-uniformity correction (NUC), as cameras compute it from uniform blackbodies: each
    pixel's counts are mapped, piecewise linearly through the calibration points, onto the
    array's mean counts at those points; bad pixels are replaced by their neighbours. Applied
    to counts before the calibration.

    Attributes
    ----------
    points : numpy.ndarray
        (points, rows, columns): each pixel's mean counts at each calibration point [DN].
    targets : numpy.ndarray
        The array's mean counts (over good pixels) at each point [DN].
    bad : numpy.ndarray of bool
        Pixels replaced (dead, hot or saturated at a point, or with an outlying response).
    temperatures : tuple of float
        Blackbody temperatures of the points [K].
    integration_time : float
        Integration time of the points [s].
    """

    points: np.ndarray
    targets: np.ndarray
    bad: np.ndarray
    temperatures: tuple
    integration_time: float

    #: A pixel whose response (count span between the outer points) lies further than this
    #: many robust standard deviations from the median is bad.
    OUTLIER_SIGMAS = 6.0

    @classmethod
    def from_flat_fields(cls, flats, temperatures, integration_time: float,
                         saturated=None) -> NonUniformityCorrection:
        """
        A NUC from mean flat fields [DN] at increasing blackbody temperatures [K] (two for a
        two-point NUC, more for a multi-point one); ``saturated`` marks pixels saturated in
        any frame of a point.
        """
        flats = np.asarray(flats, dtype=float)
        temperatures = tuple(float(t) for t in temperatures)
        if flats.ndim != 3 or flats.shape[0] != len(temperatures) or len(temperatures) < 2:
            raise RadiosimError(f"a NUC needs ≥ 2 flat fields (points, rows, columns) with one "
                                f"temperature each, got {flats.shape} and {len(temperatures)}")
        if np.any(np.diff(temperatures) <= 0):
            raise RadiosimError(f"NUC temperatures must increase, got {temperatures}")
        span = flats[-1] - flats[0]  # [DN]
        median = np.median(span)
        robust = 1.4826 * np.median(np.abs(span - median))
        bad = ~np.isfinite(span) | (span <= 1e-3 * abs(median)) | (
            np.abs(span - median) > cls.OUTLIER_SIGMAS * max(robust, 1e-12 * abs(median)))
        if saturated is not None:
            bad |= np.asarray(saturated, dtype=bool)
        if np.any(np.diff(flats, axis=0)[:, ~bad] <= 0):
            raise RadiosimError("the flat fields do not rise with temperature at every good "
                                "pixel: choose temperatures further apart")
        targets = np.array([f[~bad].mean() for f in flats])
        return cls(flats, targets, bad, temperatures, float(integration_time))

    def apply(self, counts) -> np.ndarray:
        """Corrected counts [DN] (float), bad pixels replaced; ``counts`` may be the first
        rows and columns of the NUC's array."""
        counts = np.asarray(counts, dtype=float)
        rows, cols = counts.shape
        if rows > self.bad.shape[0] or cols > self.bad.shape[1]:
            raise RadiosimError(f"counts of shape {counts.shape} on a NUC of shape "
                                f"{self.bad.shape}")
        points = self.points[:, :rows, :cols]
        # The segment of each pixel's piecewise-linear map (the outer ones extrapolate).
        segment = np.clip(np.sum(counts[None] > points[1:-1], axis=0), 0, len(self.targets) - 2)
        low = np.take_along_axis(points, segment[None], 0)[0]
        high = np.take_along_axis(points, segment[None] + 1, 0)[0]
        t_low, t_high = self.targets[segment], self.targets[segment + 1]
        bad = self.bad[:rows, :cols]
        with np.errstate(divide="ignore", invalid="ignore"):
            corrected = t_low + (counts - low) * (t_high - t_low) / (high - low)
        corrected = np.where(bad, counts, corrected)
        return replace_bad_pixels(corrected, bad) if bad.any() else corrected

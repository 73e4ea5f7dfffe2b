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

What a reading is (the detection limit, IUPAC's convention). The *blank reading* is the mean
count with no signal from the object — dark charge plus the background the calibration assumes
(reflection, path, the optics' emission), b = DN(0 K) — and σ_b its temporal noise [DN], the
EMVA 1288 σ²_y = K² (σ²_read + μ_e) + 1/12 DN² with μ_e the blank's dark and background
electrons (shot noise) and 1/12 DN² the converter's quantisation. The detection limit is
L = b + k·σ_b, with k = ``detection_sigma`` (3 by default, a camera setting): a reading is
reported only where its counts are at least L, i.e. where they are distinguishable from the
blank at that confidence. Noise alone passes L with the probability of a k σ excursion (one
pixel in 740 for k = 3, Gaussian). The *lowest measurable temperature* is the grey-body
temperature whose mean counts equal L (:meth:`Calibration.lowest_measurable_temperature`).

Flags (exactly one per flagged pixel; a flagged pixel has no apparent temperature, NaN):

-   *saturated*: the well is full or the converter is at its top code;
-   *under range*: not saturated, and the converter is at code 0, or the counts lie below the
    detection limit L, or below the counts of the calibration range's lowest temperature;
-   *over range*: neither saturated nor under range, and the counts lie above those of the
    calibration range's highest temperature (a temperature hotter than the calibration
    covers, or noise on a very short integration).

A camera and integration time whose whole calibration range lies below the detection limit
(the counts of its highest temperature below L) or saturates (its lowest temperature fills the
well or the converter) cannot give a reading: :meth:`Calibration.check_measurable` refuses them
with the limits, before any frame is measured.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from radiosim.checks import check_count, check_fraction, check_positive
from radiosim.electronics import Electronics, Exposure, apply_nonlinearity
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.radiometry import CALIBRATION_RANGE
from radiosim.response import Response, object_signal, observed_signal
from radiosim.units import readable_time

__all__ = ["Calibration", "Reading", "MIN_CALIBRATION_SPAN_DN", "NonUniformityCorrection",
           "fill_from_nearest", "replace_bad_pixels", "fit_calibration"]

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
        Converter code 0, below the calibration range, or below the detection limit.
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
        The camera's emissivity setting (dimensionless). This and the parameters after it
        are keyword-only.
    temperature_range
        Temperatures the calibration covers [K].
    reflected_temperature
        The camera's reflected-temperature setting [K]; ``None``: nothing reflected.
    path_transmission, path_temperature
        The camera's path setting: transmission [1] and temperature [K] (``None`` with τ = 1).
    background_signal
        The optics' own emission at the assumed instrument temperature [signal unit].
    detection_sigma
        k of the detection limit: readings below the blank's counts plus k times its temporal
        noise are under range [1] (see the module docstring).

    Examples
    --------
    >>> from radiosim.response import LinearResponse
    >>> cal = Calibration(LinearResponse(1e6), Electronics.ideal(), 1e6, 10e-6)
    >>> float(cal.temperature(cal.counts(1012.15)))
    1012.15
    """

    def __init__(self, response: Response, electronics: Electronics, rate_per_signal: float,
                 integration_time: float, *, assumed_emissivity: float = 1.0,
                 temperature_range=CALIBRATION_RANGE, reflected_temperature: float | None = None,
                 path_transmission: float = 1.0, path_temperature: float | None = None,
                 background_signal: float = 0.0, detection_sigma: float = 3.0):
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
        self.detection_sigma = check_positive(detection_sigma, "detection_sigma", "1")

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

    def object_signal(self, counts) -> np.ndarray:
        """
        The object's emitted signal ε·L(T) [signal unit] that ``counts`` [DN] imply under the
        camera's settings: the counts' photo-charge as signal, less the optics' emission, the
        path and the reflection (the thermography equation solved for the object's term; the
        ratio of two channels' is the ratio method's measured ratio, :mod:`radiosim.ratio`).
        """
        return object_signal(self._signal(counts) - self.background_signal,
                             self.reflected_signal, self.path_transmission, self.path_signal)

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
        codes = _integer_codes(counts)
        if codes is not None:  # a converter's codes: each distinct code inverted once
            first, index = codes
            table = self.invert(np.arange(first, first + int(index.max()) + 1, dtype=float))
            return tuple(part[index] for part in table)
        signal = self.object_signal(counts)
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
        floor = self.detection_limit_counts
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

    @property
    def blank_electrons(self) -> float:
        """Mean charge [e⁻] of the blank reading: dark charge and the background's
        photo-charge (:attr:`background_photoelectrons`), no object signal."""
        return self.background_photoelectrons + (self.electronics.dark_current
                                                 * self.integration_time)

    @property
    def blank_counts(self) -> float:
        """Mean counts [DN] of the blank reading (no signal from the object: dark charge and
        the background of reflection, path and optics)."""
        return float(self.electronics.mean_counts(self.background_photoelectrons,
                                                  self.integration_time))

    @property
    def blank_noise_counts(self) -> float:
        """Temporal noise of the blank reading [DN rms]: σ²_y = K² (σ²_read + μ_e) + 1/12
        (:meth:`~radiosim.electronics.Electronics.temporal_noise_counts`)."""
        return float(self.electronics.temporal_noise_counts(self.blank_electrons))

    def detection_limit(self, k: float | None = None) -> float:
        """
        Counts [DN] of the detection limit: the blank reading plus ``k`` times its temporal
        noise (``k`` default :attr:`detection_sigma`); −∞ for noise-free electronics without a
        converter (any signal is detected).
        """
        k = self.detection_sigma if k is None else check_positive(k, "k", "1")
        if self.electronics.is_noise_free and self.electronics.adc_bits is None:
            return -math.inf
        return self.blank_counts + k * self.blank_noise_counts

    @cached_property
    def detection_limit_counts(self) -> float:
        """Counts [DN] of the detection limit at :attr:`detection_sigma`: readings below it
        are flagged under range (see the module docstring)."""
        return self.detection_limit()

    @property
    def noise_floor_counts(self) -> float:
        """The detection limit's counts [DN] (:attr:`detection_limit_counts`; the former name)."""
        return self.detection_limit_counts

    def lowest_measurable_temperature(self, k: float | None = None) -> float:
        """
        Lowest grey-body temperature [K] of the calibration range whose mean counts reach the
        detection limit at ``k`` σ (default :attr:`detection_sigma`, :meth:`detection_limit`);
        the range's lowest temperature if that already does; NaN if no temperature below
        saturation does.
        """
        from scipy.optimize import brentq

        limit = self.detection_limit(k)
        low, top = self.temperature_range

        def margin(t):
            return float(self.counts(t)) - limit

        high = min(self.saturation_temperature, top)  # −∞: everything saturates
        if not high >= low:
            return float("nan")
        if margin(low) >= 0:
            return float(low)
        if margin(high) < 0:
            return float("nan")
        return float(brentq(margin, low, high, xtol=1e-6))

    def check_measurable(self, camera: str = "the camera"):
        """
        Refuse (:class:`RadiosimError`) an integration time at which no temperature of the
        calibration range gives a reading: the counts of its highest temperature (or of the
        highest below saturation) lie below the detection limit, or its lowest temperature
        saturates. ``camera`` names the camera in the message.
        """
        low, high = self.temperature_range
        t = self.integration_time
        if self.saturation_temperature == -math.inf:
            raise RadiosimError(
                f"{camera} at {readable_time(t)} integration: even the calibration range's lowest "
                f"temperature {low:g} K saturates (saturation charge "
                f"{self.electronics.saturation_charge:.4g} e⁻ < "
                f"{float(self.electronics.dark_current * t + self.photoelectrons(low)):.4g} e⁻ "
                "at it): no reading is possible; shorten the integration time")
        limit = self.detection_limit_counts
        reach = min(self.saturation_temperature, high)
        top = float(self.counts(reach))
        if top < limit:
            what = (f"the calibration range's highest temperature {high:g} K" if reach == high
                    else f"its highest temperature before saturating, {reach:g} K,")
            advice = ("lengthen the integration time" if reach == high
                      else "change the integration time or the gain")
            raise RadiosimError(
                f"{camera} at {readable_time(t)} integration: {what} gives {top:.6g} DN, below the "
                f"detection limit {limit:.6g} DN (blank {self.blank_counts:.6g} DN + "
                f"{self.detection_sigma:g} × σ {self.blank_noise_counts:.3g} DN): no reading is "
                f"possible; {advice}")

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
                f"{span:.3g} DN over {low:g}–{high:g} K at {readable_time(self.integration_time)}: one DN is "
                f"about {step:.3g} K, so readings are coarse (raise the responsivity, gain or "
                "integration time)", RadiosimWarning, stacklevel=stacklevel + 1)


def _unusable_points(camera, t, y, charge) -> list[tuple[int, str]]:
    """(index, reason) of the calibration points beyond the full well or the converter."""
    el = camera.electronics
    bad = []
    for i, (ti, yi, ei) in enumerate(zip(t, y, charge)):
        if el.full_well is not None and ei > el.full_well:
            bad.append((i, f"{ti:g} K ({yi:g} DN): modelled charge {ei:.4g} e⁻ > full well "
                           f"{el.full_well:.4g} e⁻"))
        elif el.adc_bits is not None and yi >= el.max_count:
            bad.append((i, f"{ti:g} K ({yi:g} DN): at or above the ADC's top code "
                           f"{el.max_count:g} DN"))
        elif el.adc_bits is not None and yi <= 0:
            bad.append((i, f"{ti:g} K ({yi:g} DN): at the ADC's code 0"))
    return bad


def fit_calibration(camera, temperatures, counts, integration_time: float, frames: int = 1,
                    emissivity: float = 1.0, instrument_temperatures=None,
                    exclude_unusable: bool = False, fit_full_well: bool = False):
    """
    Fit a camera's free electrical parameters — system gain K [DN/e⁻] and offset [DN], and,
    with several ``instrument_temperatures`` [K], the instrument factor (the share of a black
    cone's radiance at the instrument temperature that reaches the detector,
    :attr:`Optics.instrument_factor <radiosim.optics.Optics.instrument_factor>`) — to a measured
    calibration table: blackbody ``temperatures`` [K] against mean ``counts`` [DN] at
    ``integration_time`` [s], each the mean of ``frames`` read-outs, through radiosim's own
    radiometry with the camera's spectral curves and geometry.

    The model counts = K · (e(T) + f·E(T_i) + dark) + offset is linear in (K, K·f, offset)
    for the charge e(T) the radiometry predicts from the blackbody and E(T_i) that a black
    body at the instrument temperature filling the cold stop's cone would give the pixel; f,
    the instrument factor, is not bounded by 1: a detector that sees warm housing beyond the
    cone needs more (a Cedip Jade LWIR camera's tables need about 6.5). The fit is weighted
    linear least squares, the weights the counts' temporal noise
    (:meth:`Electronics.temporal_noise`, over √frames). Without instrument temperatures the
    optics' emission at the camera's own instrument temperature is part of e(T) (and of the
    offset). Residuals larger than the noise
    explains (χ²/dof > 4) are model error and warn, saying how large it is in kelvin.

    Each point is checked first: a modelled charge above the full well, or counts at or above
    the converter's top code or at code 0, cannot lie on the linear model. Such points are
    named and refused (:class:`RadiosimError`); with ``exclude_unusable`` they are left out with
    a :class:`RadiosimWarning` naming them; with ``fit_full_well`` points above the well (but
    inside the converter's range) are kept and the fitted camera's well is raised to hold
    them. Counts that fall as the temperature rises (by more than 3 σ of the noise) are refused.

    Returns
    -------
    camera : Camera
        The camera with the fitted gain and offset (and instrument factor, and well).
    residuals : numpy.ndarray
        Measured minus fitted counts [DN]; NaN at excluded points.
    """
    if getattr(camera, "channels", None) is not None:
        raise RadiosimError(f"fit_calibration fits one band; {camera.name} has "
                            f"{len(camera.channels)} channels: fit each channel camera "
                            "(camera.channel_cameras[k]) with its own table, or a ratio curve "
                            "with radiosim.ratio.fit_ratio_calibration")

    t = np.asarray(temperatures, dtype=float)
    y = np.asarray(counts, dtype=float)
    if t.ndim != 1 or t.shape != y.shape or t.size < 3:
        raise RadiosimError(f"a calibration table needs at least 3 (temperature, counts) "
                            f"pairs of equal length, got {t.size} and {y.size}")
    if not (np.all(np.isfinite(t)) and np.all(t > 0) and np.all(np.isfinite(y))):
        raise RadiosimError("calibration temperatures must be finite and > 0 K, and the "
                            "counts finite")
    t_int = check_positive(integration_time, "integration_time", "s")
    frames = check_count(frames, "frames (read-outs averaged per counts value)")
    el = camera.electronics
    optics = camera.optics
    t_i = None
    if instrument_temperatures is not None:
        t_i = np.asarray(instrument_temperatures, dtype=float)
        if t_i.shape != t.shape or not np.all(np.isfinite(t_i) & (t_i > 0)):
            raise RadiosimError("instrument_temperatures must give one temperature > 0 K "
                                "per row of the table")
        optics = dataclasses.replace(optics, instrument_temperature=None)
    unit = camera.replace(optics=optics, electronics=dataclasses.replace(
        el, gain=1.0, offset=0.0, adc_bits=None), assumed_emissivity=emissivity)
    charge_all = unit.calibration(t_int).electrons(t)  # [e⁻]: photo (and emission), dark
    # -- the points the linear model cannot hold
    bad = _unusable_points(camera, t, y, charge_all)
    well = el.full_well
    if fit_full_well:
        over_well = [i for i, why in bad if "full well" in why]
        if over_well:
            well = float(np.max(charge_all[over_well])) * (1 + 1e-6)
            bad = [(i, why) for i, why in bad if i not in over_well]
    if bad and not exclude_unusable:
        raise RadiosimError(
            f"{camera.name} at {readable_time(t_int)}: {len(bad)} calibration point(s) beyond the full well "
            f"or the ADC's range: {'; '.join(why for _, why in bad)} — pass "
            "exclude_unusable=True to fit without them" +
            (" or fit_full_well=True to widen the well" if any("full well" in w for _, w in bad)
             else ""))
    keep = np.ones(t.size, dtype=bool)
    keep[[i for i, _ in bad]] = False
    if bad:
        warnings.warn(f"{camera.name}: {len(bad)} calibration point(s) left out: "
                      f"{'; '.join(why for _, why in bad)}", RadiosimWarning, stacklevel=3)
    if keep.sum() < 3:
        raise RadiosimError(f"{camera.name}: only {int(keep.sum())} usable calibration "
                            "point(s) remain; at least 3 are needed")
    tk, yk, charge = t[keep], y[keep], charge_all[keep]
    columns = []
    if t_i is not None:
        ti = t_i[keep]
        if np.ptp(ti) == 0 or tk.size < 4:
            raise RadiosimError("the optics' emission needs at least two different "
                                "instrument temperatures (and 4 rows) to be told from the "
                                "offset")
        black = dataclasses.replace(optics, emissivity=1.0, instrument_factor=None)
        emission = np.array([black.emitted_radiance(camera.fpa.quantum_efficiency, v)
                             for v in ti]) * camera.rate_per_signal * t_int  # [e⁻]
        columns.append(emission)
    el_model = dataclasses.replace(el, full_well=well)
    signal = charge
    if el.nonlinearity and well is not None:
        signal = apply_nonlinearity(charge, el.nonlinearity, well)
    noise0 = np.broadcast_to(el.gain * el.temporal_noise(charge) / math.sqrt(frames),
                             charge.shape)  # [DN]
    if t_i is None:  # counts must rise with temperature, beyond the noise
        order = np.argsort(tk, kind="stable")
        ts, ys, ns = tk[order], yk[order], noise0[order]
        drop = (np.diff(ts) > 0) & (np.diff(ys) < -3 * np.hypot(ns[1:], ns[:-1]))
        if drop.any():
            j = int(np.argmax(drop))
            raise RadiosimError(f"calibration counts fall as the temperature rises: "
                                f"{ts[j]:g} K gives {ys[j]:g} DN but {ts[j + 1]:g} K gives "
                                f"{ys[j + 1]:g} DN")
    design = np.column_stack([signal, *columns, np.ones_like(signal)])
    total = charge
    for _ in range(2):  # weights from the charge, then with the fitted optics' emission
        noise = el_model.gain * el_model.temporal_noise(total) / math.sqrt(frames)  # [DN]
        noise = np.broadcast_to(np.maximum(noise, 1e-12), total.shape)  # noise-free too
        solution, *_ = np.linalg.lstsq(design / noise[:, None], yk / noise, rcond=None)
        if not columns:
            break
        total = charge + max(float(solution[1] / solution[0]), 0.0) * columns[0]
    gain, offset = float(solution[0]), float(solution[-1])
    if not gain > 0:
        raise RadiosimError(f"the fitted gain is {gain:.3g} DN/e⁻: the counts do not rise "
                            "with temperature as this camera's radiometry predicts")
    weighted = design / noise[:, None]
    try:  # the gain's standard uncertainty from the counts' noise alone [DN/e⁻]
        spread = math.sqrt(np.linalg.inv(weighted.T @ weighted)[0, 0])
    except (np.linalg.LinAlgError, ValueError):
        spread = math.inf
    if not gain > 3 * spread:
        raise RadiosimError(f"the counts do not rise with temperature beyond their noise: the "
                            f"fitted gain is {gain:.3g} ± {spread:.2g} DN/e⁻ (a table of dark "
                            "frames, or of the wrong camera?)")
    changes = {"electronics": dataclasses.replace(el_model, gain=gain, offset=offset)}
    if columns:  # the instrument's radiation, as the tables measure it: not bounded by 1
        factor = float(solution[1]) / gain
        if factor < 0:
            warnings.warn(f"{camera.name}: the fitted instrument factor {factor:.3g} is "
                          "negative (the counts fall as the instrument warms): it is set to "
                          "0, no radiation from the instrument", RadiosimWarning, stacklevel=3)
        changes["optics"] = dataclasses.replace(camera.optics,
                                                instrument_factor=max(factor, 0.0))
    fitted = camera.replace(**changes)
    residuals_kept = yk - design @ solution
    chi2 = float(np.sum((residuals_kept / (gain / el.gain * noise)) ** 2)) / max(
        tk.size - design.shape[1], 1)
    if chi2 > 4:
        slope = np.gradient(gain * signal, tk) if np.all(np.diff(tk) != 0) else \
            np.full(tk.size, np.nan)  # [DN/K]
        worst = int(np.argmax(np.abs(residuals_kept)))
        warnings.warn(
            f"{camera.name}: the calibration residuals exceed the counts' noise (χ²/dof = "
            f"{chi2:.3g}): up to {abs(residuals_kept[worst]):.3g} DN at {tk[worst]:g} K, "
            f"{abs(residuals_kept[worst] / slope[worst]):.3g} K of model error there",
            RadiosimWarning, stacklevel=3)
    residuals = np.full(t.size, np.nan)
    residuals[keep] = residuals_kept
    return fitted, residuals


#: Arrays of more values than this, all whole numbers within a span of this many, are
#: inverted code by code (:meth:`Calibration.invert`).
_CODE_TABLE = 1 << 16


def _integer_codes(counts) -> tuple[int, np.ndarray] | None:
    """(the lowest code, each value's index from it) when ``counts`` is a large array of
    whole numbers within :data:`_CODE_TABLE` codes (a converter's output), else ``None``: the
    inversion of each distinct code then stands for every pixel that reads it, exactly (each
    value's inversion depends on it alone)."""
    c = np.asarray(counts)
    if c.size <= _CODE_TABLE or c.dtype.kind not in "fiu":
        return None
    low, high = np.min(c), np.max(c)
    if not (np.isfinite(low) and np.isfinite(high)) or high - low >= _CODE_TABLE:
        return None
    index = c - low
    if c.dtype.kind == "f":
        whole = index.astype(np.int32)
        if not np.array_equal(whole, index):
            return None
        index = whole
    return int(low), index.astype(np.intp, copy=False)


def fill_from_nearest(values: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
    """
    ``values`` with each pixel that is not ``valid`` (default: not finite) taken from its
    nearest valid pixel — flagged pixels that an FFT-based step must not see as features
    (a registration's correlation, a deconvolution). Unchanged when every pixel is valid.

    Examples
    --------
    >>> fill_from_nearest(np.array([[1.0, np.nan, 3.0]])).tolist()
    [[1.0, 1.0, 3.0]]
    """
    from scipy import ndimage

    values = np.asarray(values, dtype=float)
    valid = np.isfinite(values) if valid is None else np.asarray(valid, dtype=bool)
    if valid.all():
        return values
    index = ndimage.distance_transform_edt(~valid, return_distances=False,
                                           return_indices=True)
    return values[tuple(index)]


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

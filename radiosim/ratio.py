"""
Two-colour (ratio) thermography: a camera's spectral channels and the temperature from the
ratio of their signals.

A multi-channel camera (:meth:`Camera.with_channels <radiosim.camera.Camera.with_channels>`, or
``[[channels]]`` tables in a camera file) is one camera seen through several spectral bands:
each :class:`Channel` is the same camera with its own band (and optionally its own filter
curve, integration time, time offset, registration offset, PSF and fitted electronics), and
measuring it measures every channel with the ordinary single-channel chain
(:func:`channel_cameras`). The ratio is formed per pixel *after* each channel's own
calibration, from the object's signal each channel's calibration recovers from its counts,
S_k = ε_k · L_k(T) [signal unit] (:meth:`~radiosim.calibration.Calibration.object_signal`).

For a grey body (ε₁ = ε₂) the emissivity cancels::

    r(T) = L₁(T) / L₂(T) = (S₁ / S₂) · (ε₂ / ε₁) = (S₁ / S₂) / ε_r

with ε_r = ε₁/ε₂ the camera's ``assumed_emissivity_ratio`` (1 by default).
:class:`RatioCurve` tabulates r(T) from the channels' own band radiances (Planck's law
integrated with each channel's filter, optics and quantum efficiency: not Wien's
approximation) over the calibration range and inverts it. A wrong ε_r moves the reading to
the temperature whose ratio is the true one scaled by (ε₁/ε₂)_true / ε_r: through the
``two-colour`` preset, ε_r = 1.1 reads a grey body at 900 K as 785 K.

Its noise: each channel's temporal noise σ_k [signal unit] gives σ_r / r = √((σ₁/S₁)² +
(σ₂/S₂)²) and the NETD of the ratio σ_T = (σ_r / r) / abs(d ln r / dT)
(:func:`ratio_netd`; per pixel in the measurement's ``ratio_netd``).

A pixel has a ratio temperature where both channels give a reading (neither saturated, under
nor over range), the measured ratio lies within the curve's range and, if the camera sets a
``ratio_noise_limit`` [K], the ratio's noise at the measured signals is below it (ratio
pyrometers report only above a minimum signal); elsewhere it is NaN and flagged
(:func:`combine`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from radiosim.calibration import fit_calibration
from radiosim.checks import check_non_negative, check_positive
from radiosim.config import edge_field
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError
from radiosim.measurement import Measurement
from radiosim.psf import as_psf
from radiosim.spectral import as_spectrum
from radiosim.units import MICRO

__all__ = ["Channel", "RatioCurve", "channel_cameras", "ratio_curve", "combine",
           "ratio_netd", "fit_ratio_calibration", "INVERSION_ACCURACY"]

#: The inversion's accuracy [K] (relative to the temperature): the curve is tabulated at
#: 2049 points uniform in 1/T, interpolated linearly in ln r against 1/T (nearly linear:
#: Wien's law makes it exactly so) and refined by two Newton steps on the exact ratio of the
#: channels' radiance tables; tests/test_ratio.py checks 1e-9 · T against a root finder.
INVERSION_ACCURACY = 1e-9

_GRID = 2049


def _band(value, where: str) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in value)
    except (TypeError, ValueError):
        raise RadiosimError(f"{where}band must be (λ_low, λ_high) [m], got {value!r}") from None
    if not (0 < lo < hi <= 1e-3):
        raise RadiosimError(f"{where}band must be (λ_low, λ_high) [m] with 0 < λ_low < "
                            f"λ_high ≤ 1 mm, got {value!r}")
    return lo, hi


@dataclass(frozen=True, eq=False)
class Channel:
    """
    One spectral channel of a camera: the camera's optics, FPA and electronics with a band of
    its own (and what else differs).

    Attributes
    ----------
    band : tuple of float
        Spectral integration limits (λ_low, λ_high) [m]: the channel's band-pass.
    spectral_filter : float, SpectralDistribution or None
        The channel's filter transmission [1]; ``None``: the camera's.
    integration_time : float or None
        The channel's integration time [s]; ``None``: the measurement's.
    time_offset : float
        Start of the channel's window after the measurement's [s] (a filter wheel's slot):
        0 for every channel is the simultaneous layout (beam splitter or two-colour detector).
    registration_offset : tuple of float
        Shift (y, x) [m], ≥ 0, of the channel's pixel grid on the scene (added to the FPA's
        ``origin``): a registration error between two detectors.
    psf : tuple of PSF or None
        The channel's point-spread functions; ``None``: the camera's.
    electronics : Electronics or None
        The channel's fitted electronics (:func:`fit_ratio_calibration`); ``None``: the
        camera's.
    """

    band: tuple[float, float] = edge_field(None, "band_um", MICRO, kind="numbers",
                                           doc="the channel's band (λ_low, λ_high) in µm")
    spectral_filter: object = edge_field(None, "spectral_filter", kind="curve",
                                         doc="the channel's filter curve or number")
    integration_time: float | None = edge_field(None, "integration_time_us", MICRO,
                                                doc="the channel's integration time [µs]")
    time_offset: float = edge_field(0.0, "time_offset_us", MICRO,
                                    doc="start of the channel's window after the first [µs]")
    registration_offset: tuple[float, float] = edge_field(
        (0.0, 0.0), "registration_offset_um", MICRO, kind="numbers",
        doc="shift (y, x) of the channel's pixel grid [µm]")
    psf: tuple | None = edge_field(None, "psf", kind="psf",
                                   doc="the channel's point-spread functions")
    electronics: Electronics | None = None

    def __post_init__(self):
        object.__setattr__(self, "band", _band(self.band, ""))
        if self.spectral_filter is not None:
            object.__setattr__(self, "spectral_filter",
                               as_spectrum(self.spectral_filter, "spectral filter"))
        if self.integration_time is not None:
            object.__setattr__(self, "integration_time", check_positive(
                self.integration_time, "integration_time", "s"))
        object.__setattr__(self, "time_offset",
                           check_non_negative(self.time_offset, "time_offset", "s"))
        try:
            dy, dx = (float(v) for v in self.registration_offset)
        except (TypeError, ValueError):
            raise RadiosimError(f"registration_offset must be (y, x) [m], got "
                                f"{self.registration_offset!r}") from None
        if not (dy >= 0 and dx >= 0 and math.isfinite(dy + dx)):
            raise RadiosimError(f"registration_offset must be (y ≥ 0, x ≥ 0) [m], got "
                                f"{self.registration_offset!r}")
        object.__setattr__(self, "registration_offset", (dy, dx))
        object.__setattr__(self, "psf", as_psf(self.psf))
        if self.electronics is not None and not isinstance(self.electronics, Electronics):
            raise RadiosimError(f"electronics must be Electronics or None, got "
                                f"{self.electronics!r:.60}")


def channel_cameras(camera) -> tuple:
    """
    The single-channel cameras of ``camera``'s channels, in order (built once per camera):
    the camera with each channel's band, and its filter, PSF, electronics and registration
    offset (added to the FPA's ``origin``) where the channel gives them. A camera without
    channels is its own single channel.
    """
    if camera.channels is None:
        return (camera,)
    kept = camera.__dict__.get("_channel_cameras")
    if kept is not None:
        return kept
    out = []
    for k, channel in enumerate(camera.channels):
        optics = {"band": channel.band}
        if channel.spectral_filter is not None:
            optics["spectral_filter"] = channel.spectral_filter
        if channel.psf is not None:
            optics["psf"] = channel.psf
        changes = {"optics": dataclasses.replace(camera.optics, **optics), "channels": None,
                   "name": f"{camera.name} channel {k + 1}"}
        if channel.registration_offset != (0.0, 0.0):
            y, x = camera.fpa.origin
            dy, dx = channel.registration_offset
            changes["fpa"] = dataclasses.replace(camera.fpa, origin=(y + dy, x + dx))
        if channel.electronics is not None:
            changes["electronics"] = channel.electronics
        out.append(camera.replace(**changes))
    out = tuple(out)
    camera.__dict__["_channel_cameras"] = out
    return out


class RatioCurve:
    """
    The band-signal ratio r(T) = L₁(T) / L₂(T) of two channels' responses over a temperature
    range, and its inverse.

    Parameters
    ----------
    first, second
        The channels' :class:`~radiosim.response.Response` (radiometric).
    temperature_range
        (T_min, T_max) [K] the curve covers.

    Examples
    --------
    >>> from radiosim.response import PlanckResponse
    >>> curve = RatioCurve(PlanckResponse((3.8e-6, 4.2e-6), [1.0]),
    ...                    PlanckResponse((4.6e-6, 5.1e-6), [1.0]), (300.0, 2000.0))
    >>> round(float(curve.temperature(curve(900.0))), 6)
    900.0
    """

    def __init__(self, first, second, temperature_range):
        if not (first.radiometric and second.radiometric):
            raise RadiosimError("a ratio of channels needs a radiometric response "
                                "(response = 'planck'); the linear response's ratio is 1 at "
                                "every temperature")
        self.first, self.second = first, second
        low, high = (float(t) for t in temperature_range)
        self.temperature_range = (low, high)
        inverse = np.linspace(1.0 / high, 1.0 / low, _GRID)  # [1/K]
        log_ratio = self.log_ratio(1.0 / inverse)
        steps = np.diff(log_ratio)
        if not (np.all(steps > 0) or np.all(steps < 0)) or abs(
                log_ratio[-1] - log_ratio[0]) < 1e-9:
            raise RadiosimError(
                f"the ratio of the bands {_um(first.band)} and {_um(second.band)} is not "
                f"monotonic over {low:g}–{high:g} K: choose two different bands")
        order = np.argsort(log_ratio)
        self._x, self._y = log_ratio[order], inverse[order]  # ln r, 1/T
        self.rising = bool(log_ratio[0] > log_ratio[-1])  # r rises with T (falls with 1/T)

    def log_ratio(self, temperature) -> np.ndarray:
        """ln r(T) [1] at ``temperature`` [K]."""
        t = np.asarray(temperature, dtype=float)
        return np.log(self.first.grey_signal(t) / self.second.grey_signal(t))

    def __call__(self, temperature) -> np.ndarray:
        """r(T) = L₁(T) / L₂(T) [1] at ``temperature`` [K]."""
        return np.exp(self.log_ratio(temperature))

    @property
    def ratio_range(self) -> tuple[float, float]:
        """The ratios at the range's lowest and highest temperatures [1]."""
        low, high = self.temperature_range
        return float(self(low)), float(self(high))

    def slope(self, temperature) -> np.ndarray:
        """d ln r / dT [1/K] at ``temperature`` [K] (central difference, 1e-5 relative)."""
        t = np.asarray(temperature, dtype=float)
        h = 1e-5 * t
        return (self.log_ratio(t + h) - self.log_ratio(t - h)) / (2 * h)

    def invert(self, ratio):
        """
        The temperature [K] whose ratio is ``ratio`` [1], and where it falls outside the range.

        Returns
        -------
        temperature : numpy.ndarray
            [K]; NaN outside the range (and where the ratio is not a positive number).
        below, above : numpy.ndarray of bool
            Ratios of temperatures below T_min or above T_max.
        """
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.log(np.asarray(ratio, dtype=float))
        lo, hi = self._x[0], self._x[-1]
        slack = 1e-12 * max(abs(lo), abs(hi), 1.0)
        outside_low, outside_high = x < lo - slack, x > hi + slack
        below = outside_low if self.rising else outside_high
        above = outside_high if self.rising else outside_low
        finite = np.isfinite(x)
        xc = np.clip(np.where(finite, x, lo), lo, hi)
        t = 1.0 / np.interp(xc, self._x, self._y)
        low, high = self.temperature_range
        for _ in range(2):  # Newton on ln r(T) = x
            t = np.clip(t - (self.log_ratio(t) - xc) / self.slope(t), low, high)
        bad = below | above | ~finite
        return np.where(bad, np.nan, t), below & finite, above & finite

    def temperature(self, ratio) -> np.ndarray:
        """The temperature [K] whose ratio is ``ratio`` [1]; NaN outside the range."""
        return self.invert(ratio)[0]


def _um(band) -> str:
    return f"{band[0] * 1e6:g}–{band[1] * 1e6:g} µm"


def ratio_curve(camera) -> RatioCurve:
    """The ratio curve of ``camera``'s first two channels over its calibration range (built
    once per camera)."""
    kept = camera.__dict__.get("_ratio_curve")
    if kept is None:
        first, second = channel_cameras(camera)[:2]
        kept = RatioCurve(first.response_model, second.response_model,
                          camera.calibration_range)
        camera.__dict__["_ratio_curve"] = kept
    return kept


def _relative_noise(channel_camera, measurement: Measurement, signal):
    """σ_S / S [1] of a channel's reading: its temporal noise at the measured charge over its
    object signal."""
    cal = channel_camera.calibration(measurement.integration_time)
    noise = channel_camera.electronics.temporal_noise(measurement.electrons)  # [e⁻]
    with np.errstate(divide="ignore", invalid="ignore"):
        return noise / (signal * cal.rate_per_signal * cal.integration_time)


def combine(camera, measurements) -> Measurement:
    """
    The measurement of a multi-channel ``camera`` from its channels' ``measurements``.

    ``channels`` holds them; with two or more, ``ratio_temperature`` [K] is the temperature of
    the first two channels' signal ratio (divided by the camera's ``assumed_emissivity_ratio``)
    and is the measurement's ``apparent_temperature``; ``ratio_netd`` [K] its noise. A pixel
    is flagged saturated where a channel is, else under range where a channel is or the
    ratio lies below the curve's range, else over range likewise. The scene-truth statistics,
    counts, electrons, signal and window are the first channel's (the reference). Channels
    that cover different numbers of pixels (registration offsets) are cut to the pixels they
    all cover.
    """
    measurements = _common_shape(tuple(measurements))
    first = measurements[0]
    extra = {}
    if len(measurements) >= 2:
        cameras = channel_cameras(camera)
        a, b = measurements[:2]
        s1 = cameras[0].calibration(a.integration_time).object_signal(a.counts)
        s2 = cameras[1].calibration(b.integration_time).object_signal(b.counts)
        both = a.valid & b.valid
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(both, s1 / s2, np.nan) / camera.assumed_emissivity_ratio
        curve = ratio_curve(camera)
        temperature, below, above = curve.invert(ratio)
        with np.errstate(invalid="ignore"):
            relative = np.hypot(_relative_noise(cameras[0], a, s1),
                                _relative_noise(cameras[1], b, s2))
            netd = relative / np.abs(curve.slope(np.where(
                np.isfinite(temperature), temperature, curve.temperature_range[0])))
            weak = (both & (netd > camera.ratio_noise_limit)
                    if camera.ratio_noise_limit is not None else False)
        saturated = a.saturated | b.saturated
        under = ~saturated & (a.under_range | b.under_range | (both & below) | weak)
        over = ~saturated & ~under & (a.over_range | b.over_range | (both & above))
        flagged = saturated | under | over | ~np.isfinite(temperature)
        temperature = np.where(flagged, np.nan, temperature)
        netd = np.where(flagged, np.nan, netd)
        extra = {"apparent_temperature": temperature, "saturated": saturated,
                 "under_range": under, "over_range": over, "ratio_temperature": temperature,
                 "ratio_netd": netd}
    return dataclasses.replace(first, camera=camera, channels=measurements, **extra)


def _common_shape(measurements: tuple) -> tuple:
    """The channels' measurements cut to the pixels they all have (a channel registered
    further into the scene may cover fewer columns or rows)."""
    rows, cols = (min(m.shape[i] for m in measurements) for i in (0, 1))
    if all(m.shape == (rows, cols) for m in measurements):
        return measurements
    cut = (slice(0, rows), slice(0, cols))
    return tuple(dataclasses.replace(m, **{name: getattr(m, name)[cut] for name in (
        *Measurement.ARRAYS, "over_range")}) for m in measurements)


def ratio_netd(camera, temperature, integration_time: float) -> np.ndarray:
    """
    Noise-equivalent temperature difference of the ratio [K] for a blackbody at
    ``temperature`` [K] after ``integration_time`` [s]:
    σ_T = √((σ₁/S₁)² + (σ₂/S₂)²) / abs(d ln r/dT), with each channel's temporal noise
    σ_k and object photo-charge S_k [e⁻] of the noise-free reading (its calibration's forward
    model); NaN where a channel saturates.
    """
    t = np.asarray(temperature, dtype=float)
    parts = []
    for cam in channel_cameras(camera)[:2]:
        cal = cam.calibration(integration_time)
        photo = cal.photoelectrons(t) - cal.background_photoelectrons  # [e⁻]
        relative = cal.noise(t) / photo
        parts.append(np.where(t >= cal.saturation_temperature, np.nan, relative))
    return np.hypot(*parts) / np.abs(ratio_curve(camera).slope(t))


def fit_ratio_calibration(camera, temperatures, counts, integration_time: float,
                          frames: int = 1, **options):
    """
    The ratio calibration from blackbody points: each channel's electronics (gain, offset)
    fitted with :func:`~radiosim.calibration.fit_calibration` to its row of ``counts``
    [DN] at ``temperatures`` [K]; the ratio curve then follows from the channels' radiometry
    (:func:`ratio_curve`).

    Parameters
    ----------
    camera
        A camera with channels.
    temperatures
        Blackbody temperatures [K].
    counts
        Mean counts [DN], one row per channel (channels × temperatures).
    integration_time
        [s].
    frames
        Read-outs averaged per counts value.
    options
        Passed to :func:`~radiosim.calibration.fit_calibration` (``emissivity``,
        ``exclude_unusable``, ``fit_full_well``).

    Returns
    -------
    camera : Camera
        The camera with each channel's fitted electronics.
    residuals : numpy.ndarray
        Measured minus fitted counts [DN], channels × temperatures.
    """
    if camera.channels is None:
        raise RadiosimError(f"{camera.name} has no channels: use fit_calibration")
    counts = np.asarray(counts, dtype=float)
    cameras = channel_cameras(camera)
    if counts.ndim != 2 or counts.shape[0] != len(cameras):
        raise RadiosimError(f"counts must have one row per channel ({len(cameras)}), got an "
                            f"array of shape {counts.shape}")
    channels, residuals = [], []
    for channel, cam, row in zip(camera.channels, cameras, counts):
        fitted, residual = fit_calibration(cam, temperatures, row, integration_time, frames,
                                           **options)
        channels.append(dataclasses.replace(channel, electronics=fitted.electronics))
        residuals.append(residual)
    return camera.replace(channels=tuple(channels)), np.array(residuals)

"""
Calibration: the camera's own inversion of digital numbers to apparent temperature.

Like a real radiometric camera, the calibration is built for one camera and one integration
time from its noise-free response to a blackbody (or a grey body of an *assumed* emissivity,
the camera's emissivity setting, which may differ from the scene's true one):

    DN(T) = K · (ε_a · conversion · S(T) · t_int + I_dark · t_int) + offset

with S the response signal (in-band photon radiance for the Planck response, T for the linear
one). The inversion solves this for T on the response's tabulated, monotonic curve. Counts with
no temperature in the measurable range return NaN, and the camera flags them.
"""

from __future__ import annotations

import numpy as np

from radiosim.errors import RadiosimError

__all__ = ["Calibration"]


class Calibration:
    """
    DN ↔ apparent temperature for one camera and integration time.

    Parameters
    ----------
    camera
        A :class:`~radiosim.camera.Camera`.
    integration_time
        Integration time [s].

    Examples
    --------
    >>> from radiosim import Camera
    >>> cal = Calibration(Camera.linear_ideal(6e-6), 10e-6)
    >>> float(cal.temperature(cal.counts(1012.15)))
    1012.15
    """

    def __init__(self, camera, integration_time: float):
        if not integration_time > 0:
            raise RadiosimError(f"integration time must be > 0 [s], got {integration_time!r}")
        self.camera = camera
        self.integration_time = float(integration_time)
        self.response = camera.response_model
        self.electronics = camera.electronics
        self.emissivity = camera.assumed_emissivity

    def electrons(self, temperature) -> np.ndarray:
        """Noise-free charge [e⁻] from a grey body at ``temperature`` [K] (no full-well clip)."""
        t = self.integration_time
        signal = self.response.signal(np.asarray(temperature, dtype=float), self.emissivity)
        return self.response.conversion * signal * t + self.electronics.dark_current * t

    def counts(self, temperature) -> np.ndarray:
        """Noise-free, unrounded, unclipped digital numbers [DN] at ``temperature`` [K]."""
        return self.electronics.gain * self.electrons(temperature) + self.electronics.offset

    def invert(self, counts):
        """
        Apparent temperature [K] of ``counts`` [DN], and where it falls outside the range.

        Returns
        -------
        temperature : numpy.ndarray
            Apparent temperature [K]; NaN below or above the measurable range.
        below, above : numpy.ndarray of bool
            Counts under the lowest or over the highest temperature of the range.
        """
        t = self.integration_time
        e = (np.asarray(counts, dtype=float) - self.electronics.offset) / self.electronics.gain
        signal = (e - self.electronics.dark_current * t) / (self.response.conversion * t)
        low, high = self.response.signal_range(self.emissivity)
        return self.response.temperature(signal, self.emissivity), signal < low, signal > high

    def temperature(self, counts) -> np.ndarray:
        """
        Apparent temperature [K] of ``counts`` [DN]; NaN where no temperature of the
        measurable range gives them.
        """
        return self.invert(counts)[0]

    def noise(self, temperature) -> np.ndarray:
        """Temporal noise of a grey body's reading [e⁻ rms] (see
        :meth:`~radiosim.electronics.Electronics.temporal_noise`)."""
        return self.electronics.temporal_noise(self.electrons(temperature))

    def lowest_measurable_temperature(self, snr: float = 1.0) -> float:
        """
        Lowest grey-body temperature [K] whose signal above the dark level is ``snr`` times its
        temporal noise (the noise floor at ``snr`` = 1); NaN if none below saturation.
        """
        from scipy.optimize import brentq

        dark = self.electronics.dark_current * self.integration_time

        def margin(t):
            return (self.electrons(t) - dark) - snr * self.noise(t)

        low, top = getattr(self.response, "temperature_range", (1.0, 1e4))
        saturation = self.saturation_temperature
        high = top if not np.isfinite(saturation) else min(saturation, top)
        if margin(low) >= 0:
            return float(low)
        if margin(high) < 0:
            return float("nan")
        return float(brentq(margin, low, high, xtol=1e-6))

    @property
    def saturation_temperature(self) -> float:
        """
        Lowest grey-body temperature [K] that fills the well or the converter: ∞ if nothing
        saturates, NaN if it lies beyond the calibration's temperature range.
        """
        el = self.electronics
        limits = []
        if el.full_well is not None:
            limits.append(el.full_well)
        if el.adc_bits is not None:
            limits.append((el.max_count - 0.5 - el.offset) / el.gain)
        if not limits:
            return np.inf
        return float(self.temperature(el.gain * min(limits) + el.offset))

"""
A camera maker's own calibration: FLIR's Planck curve and object parameters.

FLIR radiometric cameras store, with every file, the curve that turns a blackbody temperature
into raw counts (the Sakuma–Hattori form, linear in radiance)::

    raw(T) = R1 / (R2 · (exp(B / T) − F)) − O

and the parameters of the measurement: the object's emissivity, the temperature it reflects,
the atmosphere's temperature, humidity and path length, and an external window's
temperature and transmission. The object's temperature follows by removing, in raw counts,
what the reflection, the atmosphere and the window add, and inverting the curve (Minkina &
Dudzik; the form ThermImage's ``raw2temp`` and exiftool document)::

    raw_obj = raw / (ε τ₁ τ_w τ₂) − (1 − ε)/ε · raw(T_refl)
              − (1 − τ₁)/(ε τ₁) · raw(T_atm) − (1 − τ₂)/(ε τ₁ τ_w τ₂) · raw(T_atm)
              − (1 − τ_w)/(ε τ₁ τ_w) · raw(T_w)
    T = B / ln(R1 / (R2 · (raw_obj + O)) + F)

with τ₁ = τ₂ the atmosphere's transmission over half the distance each side of the window::

    τ = X exp(−√(d/2) (α₁ + β₁ √h)) + (1 − X) exp(−√(d/2) (α₂ + β₂ √h)),
    h = RH · exp(1.5587 + 0.06939 t − 2.7816e-4 t² + 6.8455e-7 t³)  (t in °C),

the relative humidity RH as a fraction (0–1: FLIR files store it so; a percentage is refused).

References
----------
-   Minkina, W. & Dudzik, S. (2009). *Infrared Thermography: Errors and Uncertainties*.
    Wiley. Chapter 2 (the measurement equation).
-   Tattersall, G. J. (2017). ThermImage: thermal image analysis in R, ``raw2temp``.
-   Harvey, P. exiftool, FLIR tags (``PlanckR1``, ``PlanckR2``, ``PlanckB``, ``PlanckF``,
    ``PlanckO``, ``AtmosphericTransAlpha1`` …).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.units import to_celsius

__all__ = ["PlanckCurve", "ObjectParameters", "atmospheric_transmission", "raw_to_temperature",
           "temperature_to_raw"]


@dataclass(frozen=True)
class PlanckCurve:
    """A FLIR camera's calibration curve raw(T) = R1 / (R2 (exp(B/T) − F)) − O: R1 [DN·…],
    R2 [1/…], B [K], F [1], O [DN] as the file states them."""

    R1: float
    R2: float
    B: float
    F: float
    O: float  # noqa: E741 - FLIR's name

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, (int, float, np.floating, np.integer)) or \
                    not math.isfinite(value):
                raise RadiosimError(f"Planck {f.name} must be a finite number, got {value!r}")
            object.__setattr__(self, f.name, float(value))
        if self.R1 <= 0 or self.R2 <= 0 or self.B <= 0:
            raise RadiosimError(f"Planck R1, R2 and B must be > 0, got R1 = {self.R1:g}, "
                                f"R2 = {self.R2:g}, B = {self.B:g}")

    def raw(self, temperature):
        """Raw counts [DN] of a blackbody at ``temperature`` [K]."""
        t = np.asarray(temperature, dtype=float)
        return self.R1 / (self.R2 * (np.exp(self.B / t) - self.F)) - self.O

    def temperature(self, raw):
        """The blackbody temperature [K] of ``raw`` counts [DN] (NaN where none gives them)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.B / np.log(self.R1 / (self.R2 * (np.asarray(raw, dtype=float) + self.O))
                                   + self.F)


@dataclass(frozen=True)
class ObjectParameters:
    """
    What lies between the object and a FLIR camera, in SI: ``emissivity`` (0, 1],
    ``reflected_temperature`` [K], ``atmospheric_temperature`` [K], ``distance`` [m] ≥ 0,
    ``relative_humidity`` [0–1], ``window_temperature`` [K], ``window_transmission`` (0, 1],
    and the atmosphere's transmission coefficients ``alpha1``, ``alpha2``, ``beta1``,
    ``beta2``, ``x`` (FLIR's AtmosphericTransAlpha1 …, X). The defaults are FLIR's: a black
    object at 1 m in air at 20 °C and 50 % humidity, no window.
    """

    emissivity: float = 1.0
    reflected_temperature: float = 293.15
    atmospheric_temperature: float = 293.15
    distance: float = 1.0
    relative_humidity: float = 0.5
    window_temperature: float = 293.15
    window_transmission: float = 1.0
    alpha1: float = 0.006569
    alpha2: float = 0.01262
    beta1: float = -0.002276
    beta2: float = -0.00667
    x: float = 1.9

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(
                    value, (int, float, np.floating, np.integer)) or not math.isfinite(value):
                raise RadiosimError(f"{f.name} must be a finite number, got {value!r}")
            object.__setattr__(self, f.name, float(value))
        if not 0 < self.emissivity <= 1:
            raise RadiosimError(f"emissivity must be in (0, 1], got {self.emissivity:g}")
        if not 0 < self.window_transmission <= 1:
            raise RadiosimError(f"window_transmission must be in (0, 1], got "
                                f"{self.window_transmission:g}")
        if not 0 <= self.relative_humidity <= 1:
            hint = (f" (a percentage? {self.relative_humidity:g} % is "
                    f"{self.relative_humidity / 100:g})" if 1 < self.relative_humidity <= 100
                    else "")
            raise RadiosimError(f"relative_humidity must be a fraction in [0, 1], got "
                                f"{self.relative_humidity:g}{hint}")
        if self.distance < 0:
            raise RadiosimError(f"distance must be ≥ 0 [m], got {self.distance:g}")
        for name in ("reflected_temperature", "atmospheric_temperature", "window_temperature"):
            if getattr(self, name) <= 0:
                raise RadiosimError(f"{name} must be > 0 K, got {getattr(self, name):g} K "
                                    "(°C given as kelvin?)")


def atmospheric_transmission(p: ObjectParameters) -> float:
    """The atmosphere's transmission [1] over half of ``p.distance`` (FLIR's model: either
    side of an external window)."""
    t = float(to_celsius(p.atmospheric_temperature))  # [°C]
    h2o = p.relative_humidity * math.exp(1.5587 + 0.06939 * t - 0.00027816 * t**2
                                         + 0.00000068455 * t**3)
    root = math.sqrt(p.distance / 2)
    return (p.x * math.exp(-root * (p.alpha1 + p.beta1 * math.sqrt(h2o)))
            + (1 - p.x) * math.exp(-root * (p.alpha2 + p.beta2 * math.sqrt(h2o))))


def raw_to_temperature(raw, curve: PlanckCurve, parameters: ObjectParameters | None = None):
    """
    The object's temperature [K] from a FLIR camera's ``raw`` counts [DN] through its
    ``curve`` and the object ``parameters`` (module docstring); NaN where the object's share
    of the counts lies outside the curve.

    Examples
    --------
    >>> curve = PlanckCurve(R1=21106.77, R2=0.012545, B=1501.0, F=1.0, O=-7340.0)
    >>> round(float(raw_to_temperature(curve.raw(310.0), curve,
    ...                                ObjectParameters(distance=0.0))), 6)
    310.0
    """
    p = ObjectParameters() if parameters is None else parameters
    tau = atmospheric_transmission(p)
    e, w = p.emissivity, p.window_transmission
    raw = np.asarray(raw, dtype=float)
    raw_obj = (raw / (e * tau * w * tau)
               - (1 - e) / e * curve.raw(p.reflected_temperature)
               - (1 - tau) / (e * tau) * curve.raw(p.atmospheric_temperature)
               - (1 - tau) / (e * tau * w * tau) * curve.raw(p.atmospheric_temperature)
               - (1 - w) / (e * tau * w) * curve.raw(p.window_temperature))
    return curve.temperature(raw_obj)


def temperature_to_raw(temperature, curve: PlanckCurve,
                       parameters: ObjectParameters | None = None):
    """The raw counts [DN] a FLIR camera reads from an object at ``temperature`` [K] (the
    inverse of :func:`raw_to_temperature`)."""
    p = ObjectParameters() if parameters is None else parameters
    tau = atmospheric_transmission(p)
    e, w = p.emissivity, p.window_transmission
    return (e * tau * w * tau * curve.raw(temperature)
            + (1 - e) * tau * w * tau * curve.raw(p.reflected_temperature)
            + (1 - tau) * w * tau * curve.raw(p.atmospheric_temperature)
            + (1 - tau) * curve.raw(p.atmospheric_temperature)
            + (1 - w) * tau * curve.raw(p.window_temperature))

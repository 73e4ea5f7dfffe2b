"""
Radiometry: Planck's law, in-band radiance and its fast evaluation and inversion.

The in-band radiance of a surface at temperature :math:`T`, seen through a spectral
responsivity :math:`R(\\lambda)` (filter × optics × quantum efficiency) is

.. math::

    L_q(T) = \\int_{\\lambda_1}^{\\lambda_2} \\varepsilon(\\lambda) R(\\lambda)
             \\frac{2 c}{\\lambda^4} \\frac{1}{e^{c_2/\\lambda T} - 1}\\, d\\lambda
             \\quad [\\mathrm{photons\\ s^{-1}\\ m^{-2}\\ sr^{-1}}]

in photon units, and the same integral of :math:`2 h c^2 / \\lambda^5 (\\ldots)` in energy units
[W m⁻² sr⁻¹]. The constants are CODATA's exact SI values from :mod:`scipy.constants`
(:math:`c_2 = h c / k`), not ITS-90's rounded :math:`c_2 = 0.014388` m K.

:func:`band_radiance` evaluates the integral by Gauss–Legendre quadrature on the pieces between
the nodes of the spectral curves, which is exact to rounding for piecewise-linear curves.
:class:`BandRadianceTable` tabulates it once and evaluates it per sample (and inverts it) fast.

References
----------
-   CIE 015:2004, Colorimetry (Planck's law as in :func:`colour.colorimetry.planck_law`).
-   Tiesinga, E. et al. (2021). CODATA recommended values of the fundamental physical
    constants: 2018. Rev. Mod. Phys. 93, 025010.
-   Wiebelt, J. A. (1966). Engineering Radiation Heat Transfer. Holt, Rinehart and Winston
    (series for the blackbody fraction :math:`F_{0\\to\\lambda T}`).
-   Modest, M. F. (1993). Radiative Heat Transfer. McGraw-Hill, pp. 775–777 (table of
    blackbody fractions, as reproduced in OpenFOAM's ``blackBodyEmission``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import scipy.constants as sc
from scipy.interpolate import CubicSpline
from scipy.special import bernoulli, factorial

from radiosim.errors import RadiosimError
from radiosim.spectral import as_spectrum, is_spectrum

if TYPE_CHECKING:  # colour-science is imported when a curve is built
    from colour import SpectralDistribution

__all__ = [
    "PLANCK_C1",
    "PLANCK_C1L",
    "PLANCK_C2",
    "QUANTITIES",
    "BLACKBODY_FRACTION_TABLE",
    "planck_spectral_radiance",
    "blackbody_fraction",
    "band_radiance",
    "BandRadianceTable",
    "TABLE_C_DU",
    "DEFAULT_BAND",
    "CALIBRATION_RANGE",
]

#: First radiation constant :math:`c_1 = 2 \pi h c^2` [W m²] (CODATA, exact).
PLANCK_C1 = 2 * math.pi * sc.h * sc.c**2
#: First radiation constant for spectral radiance :math:`c_{1L} = 2 h c^2` [W m² sr⁻¹].
PLANCK_C1L = 2 * sc.h * sc.c**2
#: Second radiation constant :math:`c_2 = h c / k` [m K] (CODATA, exact).
PLANCK_C2 = sc.h * sc.c / sc.k

#: The default spectral band (λ1, λ2) [m]: 3.8–5.1 µm, the band of the paper's MWIR camera
#: (InSb, no narrow filter), for radiance tables and optics that state none.
DEFAULT_BAND = (3.8e-6, 5.1e-6)
#: The temperatures (T_min, T_max) [K] a radiance table, and so a camera's calibration, cover
#: by default: from below room temperature to beyond any cutting temperature.
CALIBRATION_RANGE = (150.0, 3000.0)

#: Radiance quantities and their units.
QUANTITIES = {
    "photon": "photons s-1 m-2 sr-1",
    "energy": "W m-2 sr-1",
}

#: Blackbody fractions F(0→λT) against λT [µm K], from Modest (1993), pp. 775–777, to five
#: decimals. The table was computed with c₂ = 14 388 µm K; CODATA's 14 387.77 µm K shifts F by
#: at most dF/d ln(λT) · 1.6e-5 < 1.2e-5, so radiosim agrees with it to within 2e-5. (The
#: reproduction's λT = 1500 entry, 0.01280, differs from the series evaluated with the table's
#: own c₂ by 5e-5 where every other entry agrees to 5e-6: a transcription error, left out.)
BLACKBODY_FRACTION_TABLE = {
    1000: 0.00032, 2000: 0.06672, 2500: 0.16135, 2900: 0.25055,
    3000: 0.27322, 3500: 0.38290, 4000: 0.48085, 4500: 0.56429, 5000: 0.63372,
    6000: 0.73778, 7000: 0.80807, 8000: 0.85625, 9000: 0.88999, 10000: 0.91415,
    12000: 0.94505, 15000: 0.96893, 20000: 0.98555, 30000: 0.99529, 50000: 0.99890,
}

_BERNOULLI = bernoulli(40)  # B₁ = −1/2 convention, as in t/(eᵗ − 1) = Σ Bₖ tᵏ/k!
_FACTORIAL = factorial(np.arange(_BERNOULLI.size), exact=False)
_GAUSS_ORDER = 8
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(_GAUSS_ORDER)
_MAX_PIECE_RATIO = 1.02  # quadrature pieces span at most 2 % in wavelength
_CHUNK = 16384  # samples per chunk of table evaluation (fits in L2 cache)
#: The default radiance table's grid step at its coldest node, as c·ΔT/T² with c = c₂/λ₁ (the
#: fastest decay rate in 1/T of any Planck term of the band): relative error at most about
#: 5/384 (c ΔT/T²)⁴ ≈ 1e-8 there (measured: 3e-10 for the nist-ir band), and less in every
#: hotter interval.
TABLE_C_DU = 0.03
_TABLE_MARGIN = 12  # grid intervals past each end of a table's range
_MAX_TABLE_INTERVALS = 10**7  # 320 MB of coefficients


def _check_temperature(temperature) -> np.ndarray:
    t = np.asarray(temperature, dtype=float)
    if not np.all(np.isfinite(t)):
        raise RadiosimError("temperature contains NaN or infinite values; expected kelvin > 0")
    if np.any(t <= 0):
        raise RadiosimError(
            f"temperature must be > 0 K, got a minimum of {t.min():g} K (°C passed as kelvin?)"
        )
    return t


def _check_quantity(quantity: str) -> str:
    if quantity not in QUANTITIES:
        raise RadiosimError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    return quantity


def planck_spectral_radiance(wavelength, temperature, quantity: str = "energy") -> np.ndarray:
    """
    Spectral radiance of a blackbody (Planck's law) with CODATA constants.

    Parameters
    ----------
    wavelength
        Wavelength :math:`\\lambda` [m].
    temperature
        Temperature :math:`T` [K].
    quantity
        ``"energy"``: :math:`L_\\lambda` [W m⁻² sr⁻¹ m⁻¹]; ``"photon"``:
        :math:`L_{q,\\lambda} = L_\\lambda \\lambda / h c` [photons s⁻¹ m⁻² sr⁻¹ m⁻¹].

    Returns
    -------
    numpy.ndarray
        Shape ``temperature.shape + wavelength.shape`` (every temperature at every wavelength).

    Examples
    --------
    >>> float(planck_spectral_radiance(10e-6, 300.0))  # doctest: +ELLIPSIS
    9924...
    """
    _check_quantity(quantity)
    wl = np.asarray(wavelength, dtype=float)
    t = _check_temperature(temperature)
    if np.any(wl <= 0) or not np.all(np.isfinite(wl)):
        raise RadiosimError("wavelength must be finite and > 0 [m]")
    # L_λ = c1 / (π λ⁵ (exp(c2/λT) − 1)) for every (λ, T) pair, in the operations' order of
    # colour-science's planck_law (CIE 015:2004; the tests compare the two), without importing
    # colour (seconds: its plotting package) for a law of one line. exp overflows to inf far
    # in the Wien tail, where the radiance is correctly 0.
    lam, temp = wl.ravel()[:, None], t.ravel()[None, :]
    with np.errstate(over="ignore"):
        radiance = (((PLANCK_C1 * lam**-5) / np.pi) * (1 / np.expm1(PLANCK_C2 / (lam * temp)))).T
    if quantity == "photon":
        radiance = radiance * (wl.ravel() / (sc.h * sc.c))
    return radiance.reshape(t.shape + wl.shape)


def blackbody_fraction(wavelength_temperature) -> np.ndarray:
    """
    Fraction :math:`F_{0\\to\\lambda T}` of blackbody exitance below wavelength λ.

    Evaluated with the convergent series of Wiebelt (1966),
    :math:`F = \\frac{15}{\\pi^4} \\sum_{n \\ge 1} \\frac{e^{-n x}}{n}
    \\left(x^3 + \\frac{3x^2}{n} + \\frac{6x}{n^2} + \\frac{6}{n^3}\\right)`, :math:`x = c_2/\\lambda T`,
    independent of the quadrature in :func:`band_radiance`.

    Parameters
    ----------
    wavelength_temperature
        Product :math:`\\lambda T` [m K], > 0.

    Returns
    -------
    numpy.ndarray
        Dimensionless fraction in [0, 1].

    Examples
    --------
    A quarter of the exitance lies below Wien's peak wavelength:

    >>> import scipy.constants as sc
    >>> round(float(blackbody_fraction(sc.Wien)), 5)
    0.25005
    """
    lt = np.asarray(wavelength_temperature, dtype=float)
    if np.any(lt <= 0) or not np.all(np.isfinite(lt)):
        raise RadiosimError("λT must be finite and > 0 [m K]")
    x = np.atleast_1d(PLANCK_C2 / lt)
    # For x ≥ 2 the series' terms fall at least as e^{-2n}; below, use the complement
    # 1 − F = (15/π⁴) ∫₀ˣ t³/(eᵗ − 1) dt = (15/π⁴) Σₖ Bₖ x^(k+3) / (k! (k + 3)), which converges
    # for x < 2π with terms falling as (x/2π)^k.
    small = x < 2.0
    fraction = np.empty_like(x)
    xs = x[~small]
    total = np.zeros_like(xs)
    for n in range(1, 40):
        total += np.exp(-n * xs) / n * (xs**3 + 3 * xs**2 / n + 6 * xs / n**2 + 6 / n**3)
    fraction[~small] = 15 / np.pi**4 * total
    xb = x[small]
    k = np.arange(_BERNOULLI.size)
    terms = _BERNOULLI / (_FACTORIAL * (k + 3)) * xb[:, None] ** (k + 3)
    fraction[small] = 1 - 15 / np.pi**4 * terms.sum(axis=1)
    return fraction.reshape(lt.shape)


def _split_factors(responsivity, emissivity):
    """Spectral curves and the scalar factor of responsivity × emissivity."""
    factors = []
    if responsivity is not None:
        if isinstance(responsivity, Sequence) and not isinstance(responsivity, str):
            factors.extend(responsivity)
        else:
            factors.append(responsivity)
    factors.append(emissivity)
    curves, scale = [], 1.0
    for factor in factors:
        value = as_spectrum(factor, "responsivity or emissivity")
        if is_spectrum(value):
            curves.append(value)
        else:
            scale *= value
    return curves, scale


def _quadrature(band, curves) -> tuple[np.ndarray, np.ndarray]:
    """Wavelength nodes [m] and weights [m] (× the curves' product) over the band."""
    lo, hi = (float(b) for b in band)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
        raise RadiosimError(f"band must be (λ1, λ2) with 0 < λ1 < λ2 in metres, got {band!r}")
    if hi > 1e-2:
        raise RadiosimError(f"band upper edge {hi:g} m is beyond 1 cm: a band is given in metres")
    edges = [lo, hi]
    for curve in curves:
        domain = np.asarray(curve.domain, dtype=float)
        edges.extend(domain[(domain > lo) & (domain < hi)])
    edges = np.unique(edges)
    pieces = []
    for a, b in zip(edges[:-1], edges[1:]):
        n = max(1, math.ceil(math.log(b / a) / math.log(_MAX_PIECE_RATIO)))
        pieces.append(np.geomspace(a, b, n + 1) if n > 1 else np.array([a, b]))
    bounds = np.unique(np.concatenate(pieces))
    a, b = bounds[:-1, None], bounds[1:, None]
    nodes = (0.5 * (b - a) * _GAUSS_X + 0.5 * (a + b)).ravel()
    weights = (0.5 * (b - a) * _GAUSS_W).ravel()
    for curve in curves:
        weights = weights * np.asarray(curve[nodes], dtype=float)
    return nodes, weights


def band_radiance(
    temperature,
    band=DEFAULT_BAND,
    quantity: str = "photon",
    responsivity=None,
    emissivity=1.0,
) -> np.ndarray:
    """
    In-band radiance of a (grey or spectral) emitter, by direct quadrature.

    Parameters
    ----------
    temperature
        Temperature [K], any shape, > 0.
    band
        Integration limits (λ1, λ2) [m].
    quantity
        ``"photon"`` [photons s⁻¹ m⁻² sr⁻¹] or ``"energy"`` [W m⁻² sr⁻¹].
    responsivity
        ``None`` (the pure blackbody integral over the band), or a dimensionless spectral
        weight: a scalar, a ``SpectralDistribution`` (domain [m]), a shipped curve name, a CSV
        path, or a sequence of these that multiply (e.g. filter, optics, quantum efficiency).
    emissivity
        Scalar (grey) or spectral emissivity, as for one ``responsivity`` factor.

    Returns
    -------
    numpy.ndarray
        Radiance shaped like ``temperature`` in the units of ``quantity``.

    Examples
    --------
    Energy over a band that holds all of the spectrum is σT⁴/π:

    >>> import scipy.constants as sc
    >>> wide = band_radiance(1000.0, band=(1e-8, 1e-2), quantity="energy")
    >>> round(float(wide / (sc.Stefan_Boltzmann * 1000.0**4 / np.pi)), 9)
    1.0
    """
    _check_quantity(quantity)
    t = _check_temperature(temperature)
    curves, scale = _split_factors(responsivity, emissivity)
    nodes, weights = _quadrature(band, curves)
    flat = t.ravel()
    out = np.empty(flat.shape)
    chunk = max(1, 4_000_000 // nodes.size)
    for start in range(0, flat.size, chunk):
        spectral = planck_spectral_radiance(nodes, flat[start : start + chunk], quantity)
        out[start : start + chunk] = spectral @ weights
    return scale * out.reshape(t.shape)


class BandRadianceTable:
    """
    Fast evaluator of in-band radiance :math:`L(T)` and of its inverse.

    :math:`L` is tabulated by :func:`band_radiance` on a grid in :math:`T` whose nodes are the
    floating-point numbers with only their top :math:`m` mantissa bits set: every octave of
    temperature is cut into :math:`2^m` equal intervals, so the interval of a sample is read
    off the bits of its float64 value, ``k = (bits(T) >> (52 − m)) − k₀``, and its node
    :math:`T_k` is those bits with the rest cleared: no logarithm, no division, no exponential.
    :math:`L` is interpolated by a cubic spline in :math:`T` (scipy's not-a-knot
    ``CubicSpline`` through the nodes, running :data:`_TABLE_MARGIN` intervals past each end
    of the range, clear of its end effects), held per interval as a cubic in
    :math:`d = T − T_k` [K] (exact in floating point: same octave).

    Accuracy: every Planck term of the band decays like :math:`e^{-c/T}` with
    :math:`c = c_2/\\lambda` at most :math:`c_2/\\lambda_1` (≈ 3.8 × 10³ K for a band from
    3.75 µm), so the relative derivatives of :math:`L` are of order
    :math:`(c/T^2)^k` and the spline's relative error of order
    :math:`5/384\\,(c\\,\\Delta T/T^2)^4`. The interval :math:`\\Delta T \\le 2^{-m}T`, and
    :math:`m` is the smallest with :math:`c\\,2^{-m}/T_\\text{min} \\le` :data:`TABLE_C_DU`
    (the coldest interval is the worst; hotter ones are finer than needed): measured, a
    relative error of 3e-10 over 130–4000 K for the nist-ir camera's band (1024 intervals
    per octave, 5 081 intervals, 160 kB).

    Evaluation per sample: k = clip((bits(T) >> s) − k₀, 0, n − 1) with s = 52 − m,
    d = T − T_k, then the interval's cubic ((a d + b) d + c) d + e (Horner, separate multiply
    and add): the compiled kernels of :mod:`radiosim.kernels` do the same operations in the
    same order, so the two agree to rounding. The inverse starts from linear interpolation of
    ln L in T between the nodes and takes Newton steps on ln of the same cubic, converging to
    rounding: forward and inverse are consistent to about 1e-11 K.

    Parameters
    ----------
    band, quantity, responsivity, emissivity
        As for :func:`band_radiance`.
    temperature_range
        Tabulated range (T_min, T_max) [K]; evaluation outside it raises.
    per_octave
        Grid intervals per octave of temperature, a power of two from 4 to 2²⁰; default: the
        fewest with :math:`c_2 2^{-m}/(\\lambda_1 T_\\text{min}) \\le` :data:`TABLE_C_DU`.

    Attributes
    ----------
    temperatures
        The grid nodes T₀ < T₁ < … < T_n [K].
    shift
        s = 52 − m: the interval of T is ``(bits(T) >> s) − key0`` [bits].
    key0
        The bits of T₀ shifted right by ``shift``.
    coefficients
        (n, 4) array: row k holds (a, b, c, e) of interval k, in d = T − T_k [K], highest power
        first.

    Examples
    --------
    >>> table = BandRadianceTable(quantity="energy")
    >>> t = np.array([300.0, 1012.15])
    >>> bool(np.allclose(table(t), band_radiance(t, quantity="energy"), rtol=1e-9))
    True
    >>> table.temperature(table(t))
    array([ 300.  , 1012.15])
    >>> table.per_octave, table.temperatures[:2]
    (1024, array([148.5  , 148.625]))
    """

    def __init__(
        self,
        band=DEFAULT_BAND,
        quantity: str = "photon",
        responsivity=None,
        emissivity=1.0,
        temperature_range=CALIBRATION_RANGE,
        per_octave: int | None = None,
    ):
        t_min, t_max = (float(v) for v in temperature_range)
        if not (0 < t_min < t_max and np.isfinite(t_max)):
            raise RadiosimError(
                f"temperature_range must be (T_min, T_max) with 0 < T_min < T_max [K], "
                f"got {temperature_range!r}"
            )
        self.band = tuple(float(b) for b in band)
        self.quantity = _check_quantity(quantity)
        self.unit = QUANTITIES[quantity]
        if per_octave is None:
            if not 0 < self.band[0] < np.inf:
                raise RadiosimError(f"band must be (λ1, λ2) with 0 < λ1 < λ2 in metres, got "
                                    f"{band!r}")
            c = PLANCK_C2 / self.band[0]
            bits = max(4, math.ceil(math.log2(c / (t_min * TABLE_C_DU))))
            per_octave = 2 ** min(bits, 20)
        try:
            valid = (not isinstance(per_octave, bool) and int(per_octave) == per_octave
                     and 4 <= per_octave <= 2**20 and not int(per_octave) & (int(per_octave) - 1))
        except (TypeError, ValueError, OverflowError):
            valid = False
        if not valid:
            raise RadiosimError(f"per_octave must be a power of two from 4 to 2**20 (intervals "
                                f"per octave of temperature), got {per_octave!r}")
        self.per_octave = int(per_octave)
        self.shift = 52 - (self.per_octave.bit_length() - 1)
        # The grid runs _TABLE_MARGIN intervals past each end of the range, clear of the
        # spline's end effects, which decay by 2 − √3 per interval; on the cold side at most an
        # octave (a coarse table stays above T_min/2, where the band still has radiance).
        first = self._key(t_min) - min(_TABLE_MARGIN, self.per_octave)
        stop = self._key(t_max) + 1 + _TABLE_MARGIN
        if stop - first > _MAX_TABLE_INTERVALS:
            raise RadiosimError(
                f"a table of {self.per_octave} intervals per octave over {t_min:g}–{t_max:g} K "
                f"would hold {stop - first} intervals (at most {_MAX_TABLE_INTERVALS}): use "
                "fewer per octave or a narrower range")
        self.key0 = int(first)
        keys = np.arange(first, stop + 1, dtype=np.int64)
        self.temperatures = (keys << self.shift).view(np.float64)
        radiance = band_radiance(self.temperatures, band, quantity, responsivity, emissivity)
        if np.any(radiance <= 0):
            raise RadiosimError(
                f"in-band radiance is zero at {self.temperatures[radiance <= 0][-1]:g} K: the "
                "band and responsivity do not overlap (or the range starts too cold to "
                "represent)"
            )
        self.radiance = radiance
        self.log_radiance = np.log(radiance)
        spline = CubicSpline(self.temperatures, radiance)
        # One row (a, b, c, e) per interval, highest power of d first (the kernels load a row
        # at once).
        self.coefficients = np.ascontiguousarray(spline.c.T)
        self.coefficients.flags.writeable = False
        self.temperature_range = (t_min, t_max)
        self.radiance_range = (float(radiance[0]), float(radiance[-1]))

    def _key(self, t: float) -> int:
        return int(np.array(t, dtype=np.float64).view(np.int64)) >> self.shift

    @property
    def intervals(self) -> int:
        """Number of grid intervals."""
        return int(self.coefficients.shape[0])

    def _locate(self, t: np.ndarray):
        """Interval index k and d = T − T_k [K] of float64 temperatures (the kernels'
        arithmetic: k = clip((bits(T) >> s) − k₀, 0, n − 1); any input gives a valid k)."""
        index = (t.view(np.uint64) >> np.uint64(self.shift)).astype(np.int64)
        index -= self.key0
        np.clip(index, 0, self.intervals - 1, out=index)
        node = ((index + self.key0) << self.shift).view(np.float64)
        return index, t - node

    def _log_and_slope(self, t: np.ndarray):
        """ln L and d ln L/dT [K⁻¹] at temperatures t (1-D) inside the grid."""
        index, d = self._locate(t)
        a, b, c, e = np.take(self.coefficients, index, axis=0).T
        value = ((a * d + b) * d + c) * d + e
        slope = (3 * a * d + 2 * b) * d + c
        return np.log(value), slope / value

    def _check_range(self, t: np.ndarray):
        lo, hi = self.temperature_range
        if t.size and not (t.min() >= lo and t.max() <= hi):  # also catches NaN
            bad = t[~((t >= lo) & (t <= hi))].flat[0]
            raise RadiosimError(
                f"temperature {bad:g} K is outside the radiance table's range {lo:g}–{hi:g} K"
            )

    def evaluate_reference(self, temperature) -> np.ndarray:
        """
        The table at temperatures inside its range, in plain numpy, without the range check:
        the oracle of the compiled kernels' evaluation (the same Horner steps in the same order;
        the kernels fuse each multiply-add, so the two agree to a few units in the last place).
        """
        t = np.asarray(temperature, dtype=float)
        flat = np.ascontiguousarray(t).reshape(-1)
        out = np.empty(flat.shape)
        coefficients = self.coefficients
        for start in range(0, flat.size, _CHUNK):
            index, d = self._locate(flat[start : start + _CHUNK])
            row = np.take(coefficients, index, axis=0)
            value = row[:, 0] * d
            for k in (1, 2):
                value += row[:, k]
                value *= d
            value += row[:, 3]
            out[start : start + _CHUNK] = value
        return out.reshape(t.shape)

    def log_radiance_at(self, temperature) -> np.ndarray:
        """Natural log of the in-band radiance (of :attr:`unit`) at ``temperature`` [K]."""
        return np.log(self(temperature))

    def __call__(self, temperature) -> np.ndarray:
        """In-band radiance [:attr:`unit`] at ``temperature`` [K], shaped like it."""
        t = np.asarray(temperature, dtype=float)
        self._check_range(t)
        return self.evaluate_reference(t)

    def temperature(self, radiance) -> np.ndarray:
        """
        Invert the table: temperature [K] whose in-band radiance is ``radiance``.

        Radiances outside :attr:`radiance_range` (or ≤ 0, or NaN) give NaN: they have no
        temperature in the tabulated range, and callers flag them.
        """
        radiance = np.asarray(radiance, dtype=float)
        inside = (radiance >= self.radiance_range[0]) & (radiance <= self.radiance_range[1])
        target = np.log(np.where(inside, radiance, self.radiance_range[0]))
        # ln L rises along the T grid: interpolate between the nodes, then Newton.
        target = target.reshape(-1)
        t = np.interp(target, self.log_radiance, self.temperatures)
        lo, hi = self.temperatures[0], self.temperatures[-1]
        active = np.arange(t.size)
        for _ in range(4):  # Newton on ln L(T), smooth and monotonic: quadratic convergence
            value, slope = self._log_and_slope(t[active])
            step = (value - target[active]) / slope
            t[active] = np.clip(t[active] - step, lo, hi)
            # Each value stops when its own step was at rounding (two steps from the
            # interpolated start on the default grids): a value's result does not depend on
            # the others inverted with it.
            active = active[np.abs(step) > 1e-12 * t[active]]
            if active.size == 0:
                break
        t = np.clip(t.reshape(radiance.shape), *self.temperature_range)
        return np.where(inside, t, np.nan)

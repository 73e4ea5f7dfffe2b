"""
The segmented chip's moving terms in numpy: the reference model.

A frame is the static field of its region (:class:`~.geometry.RegionData`) plus the terms
that move, evaluated term by term on the index sets they can reach:

1.  the secondary zone's modulation, travelling with the chip;
2.  the released bands, carried up the rake face with the chip (stick–slip) and diffusing:
    a profile along ζ, interpolated;
3.  the forming shear band on L0, growing through the cycle and narrowing as it intensifies;
4.  the saw-tooth free surface of the chip: beyond it, air.

:func:`evaluate_reference` is the oracle the compiled kernel (:mod:`.kernel`) is tested
against; the time functions here (:func:`phase`, :func:`forming_base`, :func:`forming_reach`,
:func:`band_terms`) are shared by both implementations.

References
----------
-   Whitenton, E. P., Heigel, J. C. & Ivester, R. W. (2009). ASME MSEC2009-84319.
"""

from __future__ import annotations

import math

import numpy as np

from radiosim.scenes.segmented_chip.geometry import REGIONS, RegionData, primary_step_of
from radiosim.scenes.segmented_chip.parameters import ChipParameters
from radiosim.scenes.segmented_chip.profiles import gaussian_reach

__all__ = ["phase", "forming_base", "forming_reach", "band_terms", "band_profile",
           "evaluate_reference"]


def phase(p: ChipParameters, t: float):
    """Time τ into the period [s], phase θ = τ/P, and the chip's displacement d [m] at t [s]
    (stick–slip: a share ε of the period's travel within the slip time)."""
    tau = t % p.period
    theta = tau / p.period
    slip = min(max(tau / p.slip_time, 0.0), 1.0)  # hermite_step's arithmetic, on one float
    d = p.chip_speed * ((1 - p.slip_fraction) * tau
                        + p.slip_fraction * p.period * (slip * slip * (3.0 - 2.0 * slip)))
    return tau, theta, d


def forming_base(p: ChipParameters, theta: float) -> float:
    """The forming band's growth, 0 during the slip, rising to 1 at the end of the cycle."""
    return min(max((theta - p.slip_time / p.period) / (1 - p.slip_time / p.period), 0.0),
               1.0)


def forming_reach(p: ChipParameters, base: float) -> float:
    """|ξ| beyond which the forming band is below 1 mK [m]."""
    widest = p.band_width + (p.band_initial_width - p.band_width) * (1 - base) ** 2
    return gaussian_reach(p.band_amplitude * base) * max(widest, p.band_width)


def band_terms(p: ChipParameters, r: RegionData, tau: float, d: float):
    """The released bands, carried with the chip and diffusing: per band k, its ζ_k, σ_k²
    and amplitude, and the range of nodes of the region's ``zeta_grid`` within its reach
    (shared by both implementations). The bands' primary-zone backgrounds are one array
    operation and their node ranges one search, with each band's arithmetic as written."""
    sin_b = math.sin(p.band_angle)
    count = int(p.released_bands)
    pitch, width2, diffusion = p.segment_pitch, p.band_width**2, 2 * p.chip_diffusivity
    t0, rise = p.initial_temperature, p.primary_rise
    peak = p.band_amplitude + r.background_at_l0
    zk = [d + k * pitch for k in range(count)]
    # The primary zone's background at each band, RegionData.background: its step in one call.
    step = primary_step_of(p, np.array(zk) * sin_b).tolist()
    terms, bounds = [], []
    for k, (z, s) in enumerate(zip(zk, step)):
        sigma2 = width2 + diffusion * (tau + k * p.period)
        amplitude = (peak - (t0 + rise * s)) * math.sqrt(width2 / sigma2)
        reach = gaussian_reach(amplitude) * math.sqrt(sigma2) / sin_b
        terms.append((z, sigma2, amplitude))
        bounds.append((z - reach, z + reach))
    nodes = np.searchsorted(r.zeta_grid, bounds).astype(np.int64, copy=False).reshape(count, 2)
    return np.array(terms, dtype=np.float64).reshape(count, 3), nodes


def band_profile(p: ChipParameters, r: RegionData, tau: float, d: float) -> np.ndarray:
    """The released bands' profile along ζ on the region's ``zeta_grid`` [K]."""
    sin_b = math.sin(p.band_angle)
    profile = np.zeros(r.zeta_grid.size)
    for (zk, sigma2, amplitude), (lo, hi) in zip(*band_terms(p, r, tau, d)):
        dz = (r.zeta_grid[lo:hi] - zk) * sin_b
        profile[lo:hi] += amplitude * np.exp(-dz * dz / (2 * sigma2))
    return profile


def evaluate_reference(p: ChipParameters, r: RegionData, t: float, want_regions: bool = False):
    """The frame at time t [s] over the region of ``r``: its static field plus the moving
    terms in numpy, term by term over their index sets. Temperature [K] (and, with
    ``want_regions``, the region map)."""
    tau, theta, d = phase(p, t)
    temperature = r.static.copy()
    flat = temperature.reshape(-1)
    # Travelling modulation of the secondary zone (chip and tool) [K].
    angle = 2 * np.pi * (theta - p.modulation_phase)
    flat[r.periodic] += math.cos(angle) * r.cos_field + math.sin(angle) * r.sin_field

    # Released bands, carried with the chip and diffusing: a profile along ζ [K].
    if r.chip.size:
        profile = band_profile(p, r, tau, d)
        left = profile[r.zeta_index]
        excess = left + r.zeta_frac * (profile[r.zeta_index + 1] - left)
        excess[r.chip_faded] *= r.chip_fade
        flat[r.chip] += excess

    # The forming band on L0, on the samples within reach of its current width [K].
    base = forming_base(p, theta)
    if base > 0 and r.forming.size:
        reach = forming_reach(p, base)
        n = np.searchsorted(r.forming_abs_xi, reach)
        f = np.exp(r.forming_exponent[:n] * math.log(base))
        sigma = (1 - f) ** 2
        sigma *= p.band_initial_width - p.band_width
        sigma += p.band_width
        sigma *= sigma
        sigma *= -2.0
        excess = np.divide(r.forming_xi2[:n], sigma)
        np.exp(excess, out=excess)
        excess *= f
        excess *= r.forming_fade[:n]
        flat[r.forming[:n]] += p.band_amplitude * excess

    # The saw-tooth free surface: beyond it, air.
    air = None
    if r.surface.size:
        frac = np.mod((r.surface_zeta - d) / p.segment_pitch, 1.0)
        outline = p.min_thickness + (p.max_thickness - p.min_thickness) * (1 - frac)
        air = r.surface[r.surface_n > outline]
        flat[air] = p.ambient_temperature
    if not want_regions:
        return temperature
    regions = r.regions.copy()
    if air is not None:
        regions.reshape(-1)[air] = REGIONS["air"]
    return temperature, regions

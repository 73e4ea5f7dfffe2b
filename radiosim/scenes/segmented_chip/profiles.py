"""
The scene's one-dimensional shapes: the two smooth steps, the reach of a Gaussian term, and
the secondary zone's shape, Jaeger's high-Péclet moving band source, tabulated.

The two steps are different functions and both are used:

-   :func:`tanh_step`, S(z) = ½(1 + tanh z), a step of infinite support (the primary zone
    across L0, the band's fade at the rake face);
-   :func:`hermite_step`, H(x) = x²(3 − 2x) on clip(x, 0, 1), the cubic Hermite step that
    reaches 0 and 1 exactly (the chip's displacement during the slip).

References
----------
-   Jaeger, J. C. (1942). Moving sources of heat and the temperature at sliding contacts.
    Proc. R. Soc. N.S.W. 76, 203–224 (the high-Péclet band source).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import fft as sfft
from scipy.special import erfc

from radiosim.scenes.segmented_chip.parameters import ChipParameters

__all__ = ["tanh_step", "hermite_step", "jaeger_band_source"]

NEGLIGIBLE = 1e-3  # K: moving terms below this are not evaluated
FADE_REACH = 10.0  # the rake-face fade is 1 − O(e^{−20}) beyond 10 fade lengths


def gaussian_reach(amplitude: float) -> float:
    """Distance in σ beyond which a Gaussian of peak ``amplitude`` [K] is below 1 mK."""
    return math.sqrt(2.0 * math.log(max(abs(amplitude), 2 * NEGLIGIBLE) / NEGLIGIBLE))


def tanh_step(z):
    """S(z) = ½(1 + tanh z): a step from 0 to 1 of infinite support, ½ at z = 0."""
    return 0.5 * (1.0 + np.tanh(z))


def hermite_step(x):
    """H(x) = x²(3 − 2x) on clip(x, 0, 1): the cubic Hermite step, 0 for x ≤ 0, 1 for x ≥ 1."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def jaeger_band_source(p: ChipParameters, s_max: float, n_max: float, step: float):
    """
    Tabulate the secondary zone's shape I(s, n)·(1 − κ·exp(−n/λ)), normalised to a maximum of 1.

    I(s, n) = ∫₀ˢ q(s′) (s − s′)^(−½) exp(−n² V_c / 4 a_s (s − s′)) ds′ is evaluated as a
    discrete convolution of q (piecewise constant on cells of ``step``) with the kernel
    integrated exactly over each cell, using the antiderivative
    G(r) = 2√r exp(−c/r) − 2√(πc) erfc(√(c/r)), c = n² V_c / 4 a_s.

    Returns
    -------
    s, n : numpy.ndarray
        Grid along and normal to the rake face [m].
    shape : numpy.ndarray
        Dimensionless field (len(n), len(s)), maximum 1.
    """
    s = np.arange(0.0, s_max + step, step)
    n = np.arange(0.0, n_max + step, step)
    centres = s[:-1] + 0.5 * step
    full = p.full_flux_fraction * p.contact_length
    q = np.clip((p.contact_length - centres) / (p.contact_length - full), 0.0, 1.0)
    c = (n[:, None] ** 2) * p.chip_speed / (4.0 * p.secondary_diffusivity)
    r = s[None, :]  # kernel abscissae r = m·step, m = 0 … M
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(r > 0, c / np.where(r > 0, r, 1.0), np.inf)
        g = np.where(r > 0, 2 * np.sqrt(r) * np.exp(-ratio)
                     - 2 * np.sqrt(np.pi * c) * erfc(np.sqrt(ratio)), 0.0)
    kernel = np.diff(g, axis=1)  # ∫ over [m·step, (m+1)·step] of r^{−½} e^{−c/r} dr
    # I(s_j) = Σ_{i<j} q_i · kernel[j − 1 − i]: the full linear convolution along s, by real
    # FFTs of a fast length (the operations of scipy.signal.fftconvolve(kernel, q[None, :],
    # axes=1), without importing scipy.signal and with it scipy.stats: about a second)
    length = kernel.shape[1] + q.size - 1
    fast = [sfft.next_fast_len(length, True)]
    product = sfft.rfftn(kernel, fast, axes=[1]) * sfft.rfftn(q[None, :], fast, axes=[1])
    conv = sfft.irfftn(product, fast, axes=[1])[:, :length][:, : s.size - 1]
    field_ = np.zeros((n.size, s.size))
    field_[:, 1:] = np.clip(conv, 0.0, None)
    field_ *= 1.0 - p.tool_sink * np.exp(-n / p.tool_sink_depth)[:, None]
    return s, n, field_ / field_.max()

"""
Measuring a camera's point-spread function from its image of a uniform disc (a blackbody's
aperture): the edge's spread gives the PSF's core, the light the disc throws far beyond its
edge — and takes from just inside it — gives the scatter halo (the size-of-source effect).

The model, in a linear signal (the calibrated object signal, not temperature): a disc of
centre (y₀, x₀) and radius R [pixels] at signal S_in on a surround at S_out, averaged over
each pixel's active area (fill factor f: a square of side √f pixels), blurred by a Gaussian
core of standard deviation σ and a :class:`~radiosim.psf.ScatterHalo` (fraction β, width a),
as their optical transfer functions on the pixel grid (circular convolution; the disc is kept
away from the frame's edges). The eight parameters are fitted by least squares with a robust
(soft-L1) loss at the scale of the pixels' noise, on the pixels within reach of the edge, so
that a hot pixel or a small spot near the disc does not pull the fit.

References
----------
ISO 12233:2017, *Photography — Electronic still picture imaging — Resolution and spatial
frequency responses* (the edge's spread as the measure of a camera's blur). Saunders, P. &
Edgar, H. (2009). On the characterization and correction of the size-of-source effect in
radiation thermometers. Metrologia 46, 62–74.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np
from scipy import fft, optimize

from radiosim.errors import RadiosimError
from radiosim.psf import GaussianBlur, ScatterHalo

__all__ = ["DiscFit", "fit_disc_psf"]

@dataclass(frozen=True)
class DiscFit:
    """
    A disc's image fitted with a PSF (:func:`fit_disc_psf`).

    Attributes
    ----------
    psf : tuple
        (:class:`~radiosim.psf.GaussianBlur`, :class:`~radiosim.psf.ScatterHalo`), in object
        space [m]: what ``Optics(psf=...)`` takes.
    centre : tuple of float
        The disc's centre (row, column) [pixels, from the frame's corner].
    radius : float
        Its radius [pixels].
    inside, outside : float
        The signal of the disc and of its surround [the image's unit].
    sigma, halo_fraction, halo_width : float
        The core's σ [pixels], the halo's fraction β [1] and width a [pixels].
    residual_rms : float
        The fit's root-mean-square residual on the pixels it used [the image's unit].
    used : numpy.ndarray of bool
        The pixels the fit used.
    """

    psf: tuple
    centre: tuple
    radius: float
    inside: float
    outside: float
    sigma: float
    halo_fraction: float
    halo_width: float
    residual_rms: float
    used: np.ndarray


def _disc(shape, cy, cx, radius, side):
    """The share [1] of each pixel's active square (``side`` pixels on a side, centred) inside
    the disc: the edge taken as straight across the square, the share is the distribution
    function of the sum of two uniform variables (the square's extent along the edge's
    normal, a · |cos θ| and a · |sin θ|), continuous in the disc's centre and radius — which
    a least-squares fit differentiates."""
    y = np.arange(shape[0])[:, None] + 0.5 - cy
    x = np.arange(shape[1])[None, :] + 0.5 - cx
    r = np.hypot(y, x)
    safe = np.where(r > 0, r, 1.0)
    a = side * np.maximum(np.abs(x), np.abs(y)) / safe  # the larger projection [pixels]
    b = side * np.minimum(np.abs(x), np.abs(y)) / safe
    t = np.clip(radius - r + 0.5 * (a + b), 0.0, a + b)  # from the innermost corner [pixels]
    ab = np.maximum(2 * a * b, 1e-12)
    share = np.where(t < b, t * t / ab,
                     np.where(t < a, (t - 0.5 * b) / np.maximum(a, 1e-12),
                              1.0 - (a + b - t) ** 2 / ab))
    share = np.where(b < 1e-9 * side, t / np.maximum(a, 1e-12), share)
    return np.clip(np.where(r > 0, share, float(radius > 0)), 0.0, 1.0)


def _model(params, shape, pad, side):
    """The model image on ``shape`` pixels, computed on a grid ``pad`` pixels wider on every
    side (the circular convolution's wrap falls outside the frame)."""
    cy, cx, radius, inside, outside, sigma, beta, width = params
    grid = (shape[0] + 2 * pad, shape[1] + 2 * pad)
    disc = _disc(grid, cy + pad, cx + pad, radius, side)
    fy = np.fft.fftfreq(grid[0])[:, None]  # [cycles pixel⁻¹]
    fx = np.fft.rfftfreq(grid[1])[None, :]
    f2 = fy * fy + fx * fx
    otf = (np.exp(-2.0 * math.pi ** 2 * sigma ** 2 * f2)
           * ((1.0 - beta) + beta * np.exp(-2.0 * math.pi * width * np.sqrt(f2))))
    blurred = fft.irfft2(fft.rfft2(disc) * otf, s=grid)[pad:pad + shape[0], pad:pad + shape[1]]
    return outside + (inside - outside) * blurred


def fit_disc_psf(image, pixel_pitch: float, fill_factor: float = 1.0, valid=None,
                 reach: float = 30.0) -> DiscFit:
    """
    Fit a Gaussian core and a scatter halo to the image of a uniform disc (module docstring).

    Parameters
    ----------
    image
        2-D linear signal [any unit] (a calibrated object signal, or counts less the dark
        level: not temperatures), the disc brighter or darker than its surround.
    pixel_pitch
        The pixel's pitch in object space [m] (the returned PSF's unit).
    fill_factor
        The pixel's active share [1].
    valid
        Pixels to use (default: the finite ones); leave out defect pixels.
    reach
        Pixels farther than this from the edge [pixels] are not fitted.

    Returns
    -------
    DiscFit

    Examples
    --------
    >>> y, x = np.mgrid[0:96, 0:96] + 0.5
    >>> truth = np.where(np.hypot(y - 48, x - 47) < 20, 2.0, 1.0)
    >>> f2 = np.fft.fftfreq(96)[:, None] ** 2 + np.fft.rfftfreq(96)[None] ** 2
    >>> image = np.fft.irfft2(np.fft.rfft2(truth) * np.exp(-2 * np.pi**2 * 1.5**2 * f2), s=(96, 96))
    >>> fit = fit_disc_psf(image, 10e-6)
    >>> round(fit.sigma, 1), round(fit.radius)  # the disc drawn at pixel centres: ±0.1 px
    (1.5, 20)
    """
    image = np.asarray(image, dtype=float)
    if image.ndim != 2 or min(image.shape) < 16:
        raise RadiosimError(f"the disc's image must be 2-D, at least 16 × 16 pixels, got "
                            f"shape {image.shape}")
    for name, value, least in (("pixel_pitch", pixel_pitch, 0.0), ("reach", reach, 6.0)):
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or \
                not (math.isfinite(value) and value > least):
            unit = "[m]" if least == 0 else "[pixels]"
            raise RadiosimError(f"{name} must be a number > {least:g} {unit}, got {value!r}")
    if isinstance(fill_factor, bool) or not isinstance(fill_factor, numbers.Real) or \
            not 0 < fill_factor <= 1:
        raise RadiosimError(f"fill_factor must be in (0, 1], got {fill_factor!r}")
    if valid is not None and np.shape(valid) != image.shape:
        raise RadiosimError(f"valid must be a mask shaped like the image {image.shape}, got "
                            f"shape {np.shape(valid)}")
    usable = np.isfinite(image) if valid is None else np.asarray(valid, bool) & np.isfinite(image)
    if usable.sum() < 64:
        raise RadiosimError("fit_disc_psf needs at least 64 valid pixels")
    # A start: the disc is the side of the median level farther from the frame's border.
    border = np.concatenate([image[0], image[-1], image[:, 0], image[:, -1]])
    outside0 = float(np.nanmedian(border))
    spread = np.nanpercentile(image[usable], [1, 99])
    far = spread[1] if abs(spread[1] - outside0) > abs(spread[0] - outside0) else spread[0]
    mask = usable & (np.abs(image - outside0) > 0.5 * abs(far - outside0))
    if mask.sum() < 12 or abs(far - outside0) == 0:
        raise RadiosimError("no disc found: the image has no region that differs from its "
                            "border by half its range")
    ys, xs = np.nonzero(mask)
    cy, cx = ys.mean() + 0.5, xs.mean() + 0.5
    radius0 = math.sqrt(mask.sum() / math.pi)
    inside0 = float(np.median(image[mask]))
    y = np.arange(image.shape[0])[:, None] + 0.5
    x = np.arange(image.shape[1])[None, :] + 0.5
    r = np.hypot(y - cy, x - cx)
    used = usable & (np.abs(r - radius0) < reach)
    if (np.abs(r - radius0) < 0.5 * reach).sum() < 0.25 * 2 * math.pi * radius0 * reach:
        raise RadiosimError(f"the disc (radius {radius0:.0f} px at ({cy:.0f}, {cx:.0f})) "
                            "must lie mostly inside the frame, its edge with it")
    # The noise scale of the robust loss: the pixel-to-pixel spread inside the disc.
    core = usable & (r < 0.6 * radius0)
    noise = float(np.median(np.abs(np.diff(image[core])))) if core.sum() > 8 else 0.0
    scale = max(noise, 1e-3 * abs(inside0 - outside0))
    side = math.sqrt(fill_factor)
    pad = int(math.ceil(reach))

    def residuals(p):
        return (_model(p, image.shape, pad, side) - image)[used] / scale

    start = [cy, cx, radius0, inside0, outside0, 1.0, 0.05, min(5.0, 0.5 * reach)]
    low = [cy - 5, cx - 5, 0.5 * radius0, -np.inf, -np.inf, 0.05, 0.0, 0.5]
    high = [cy + 5, cx + 5, 1.5 * radius0, np.inf, np.inf, reach / 3, 0.9, reach]
    fit = optimize.least_squares(residuals, start, bounds=(low, high), loss="soft_l1",
                                 x_scale="jac", diff_step=1e-4)
    if not fit.success:
        raise RadiosimError(f"the disc's PSF fit did not converge: {fit.message}")
    cy, cx, radius, inside, outside, sigma, beta, width = (float(v) for v in fit.x)
    rms = float(np.sqrt(np.mean((fit.fun * scale) ** 2)))
    psf = (GaussianBlur(sigma * pixel_pitch),) + (
        (ScatterHalo(beta, width * pixel_pitch),) if beta > 0 else ())
    return DiscFit(psf, (cy, cx), radius, inside, outside, sigma, beta, width, rms, used)

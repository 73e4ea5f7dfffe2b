"""
Defect pixels found in frames a camera recorded: hot, cold, dead and noisy, after the rules of
EMVA 1288 (release 4.0, §8.4 "defect pixel characterization"): a pixel is a defect when its
deviation from what its neighbours say it should read exceeds a stated multiple of the
spread that all pixels' deviations show.

-   The mean image μ over the frames is compared with its eight neighbours: **hot** where μ
    exceeds the third-highest of them by more than k σ, **cold** where it is below the
    third-lowest by more than k σ (a scene's edges and gradients are no defects: a pixel on
    an edge has neighbours like it; a lone defect, or two side by side, has none). σ, the
    mean image's noise, is the median absolute deviation × 1.4826 of μ minus the median of
    its 5 × 5 neighbourhood (robust: the defects and edges, few, do not widen it).
-   The temporal standard deviation s, with eight frames or more (so that s is known to
    ~25 %, and a good pixel's integer counts are not all equal by chance): **dead**: s = 0
    where the array's median s is not (a pixel that does not respond: stuck, or at a
    converter's end); **noisy**: s above the median s by more than k times the spread of s.

k defaults to 6: for Gaussian deviations a pixel passes 6 σ with probability 2e-9, so a
megapixel array of good pixels shows none. Raw counts without a non-uniformity correction
have a fixed pattern with heavier tails than a Gaussian's: there k = 6 also flags its mild
outliers (a real Cedip Jade LWIR frame: 112 hot and 1121 cold of 76 800), and a large k
keeps the blatant ones (k = 500: its 16 hot pixels near 10 870 DN, 4 000 DN above their
neighbours).

References
----------
EMVA Standard 1288, Release 4.0 General (2021), §8.4.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radiosim.errors import RadiosimError

__all__ = ["DefectPixels", "find_defect_pixels", "ROBUST_SIGMA"]

#: The factor from a median absolute deviation to a Gaussian's σ: 1 / Φ⁻¹(3/4).
ROBUST_SIGMA = 1.482602218505602
_NEIGHBOURHOOD = 5  # pixels: the median filter's square


@dataclass(frozen=True)
class DefectPixels:
    """
    Boolean maps (rows, columns) of each kind of defect, and the thresholds used.

    Attributes
    ----------
    hot, cold, dead, noisy : numpy.ndarray of bool
        The defects found, one class a pixel (dead, else noisy, else hot or cold; ``noisy``
        and ``dead`` all False with fewer than eight frames).
    k : float
        The multiple of the spread beyond which a pixel is a defect.
    spread : float
        σ of the mean image's deviations from the local median [DN].
    frames : int
        Frames analysed.
    """

    hot: np.ndarray
    cold: np.ndarray
    dead: np.ndarray
    noisy: np.ndarray
    k: float
    spread: float
    frames: int

    @property
    def any(self) -> np.ndarray:
        """Every defect pixel."""
        return self.hot | self.cold | self.dead | self.noisy

    def counts(self) -> dict[str, int]:
        """How many pixels of each kind."""
        return {name: int(getattr(self, name).sum()) for name in ("hot", "cold", "dead", "noisy")}


def find_defect_pixels(frames, k: float = 6.0) -> DefectPixels:
    """
    The defect pixels of ``frames`` [DN] (frames, rows, columns) by the rules of the module
    docstring, at ``k`` robust σ.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> frames = rng.normal(1000.0, 5.0, (10, 40, 40)); frames[:, 7, 9] += 200.0
    >>> find_defect_pixels(frames).counts()
    {'hot': 1, 'cold': 0, 'dead': 0, 'noisy': 0}
    """
    from scipy.ndimage import median_filter

    stack = np.asarray(frames, dtype=float)
    if stack.ndim == 2:
        stack = stack[None]
    if stack.ndim != 3 or min(stack.shape[1:]) < _NEIGHBOURHOOD:
        raise RadiosimError(f"defect pixels need frames (frames, rows, columns) of at least "
                            f"{_NEIGHBOURHOOD} × {_NEIGHBOURHOOD} pixels, got shape "
                            f"{stack.shape}")
    if stack.shape[0] == 0:
        raise RadiosimError("defect pixels need at least one frame; got none")
    if not np.all(np.isfinite(stack)):
        raise RadiosimError("defect pixels need finite counts; the frames hold NaN or ∞")
    if isinstance(k, bool) or not isinstance(k, (int, float, np.integer, np.floating)) or \
            not (np.isfinite(k) and k > 0):
        raise RadiosimError(f"k must be a finite number > 0, got {k!r}")
    n = stack.shape[0]
    mean = stack.mean(axis=0)
    deviation = mean - median_filter(mean, size=_NEIGHBOURHOOD, mode="reflect")
    spread = ROBUST_SIGMA * float(np.median(np.abs(deviation - np.median(deviation))))
    spread = max(spread, 1e-12 * max(float(np.abs(mean).max()), 1.0))  # noise-free frames
    padded = np.pad(mean, 1, mode="reflect")
    rows, cols = mean.shape
    neighbours = np.sort([padded[1 + di:1 + di + rows, 1 + dj:1 + dj + cols]
                          for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj], axis=0)
    hot = mean - neighbours[-3] > k * spread
    cold = neighbours[2] - mean > k * spread
    none = np.zeros(mean.shape, dtype=bool)
    dead, noisy = none, none
    if n >= 8:
        s = stack.std(axis=0, ddof=1)
        typical = float(np.median(s))
        if typical > 0:
            dead = s == 0
        s_spread = ROBUST_SIGMA * float(np.median(np.abs(s - typical)))
        noisy = (s - typical > k * s_spread) & ~dead if s_spread > 0 else none
    # One class a pixel: a dead pixel's or a noisy one's mean deviates because it is so.
    return DefectPixels(hot & ~dead & ~noisy, cold & ~dead & ~noisy, dead, noisy, float(k),
                        spread, n)

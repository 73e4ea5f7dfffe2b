"""
Per-pixel streaming statistics of Monte Carlo draws, in memory bounded in the number of draws.

:class:`PixelMoments` keeps each pixel's mean and variance over its valid (finite) draws by
Welford's update, and its quantiles from a histogram of :data:`HISTOGRAM_BINS` bins spanning
±8 standard deviations of the first draws around their mean, interpolated linearly within a
bin (a quantile is resolved to 16/400 = 0.04 standard deviations; draws outside the span are
counted, and a pixel with more than 0.5 % of them there has no quantile, NaN). It serves the
coverage interval of :func:`radiosim.uncertainty.propagate` (JCGM 101:2008, §7.7).

References
----------
-   Welford, B. P. (1962). Technometrics 4, 419 (the streaming variance).
"""

from __future__ import annotations

import numpy as np

__all__ = ["PixelMoments", "HISTOGRAM_BINS", "over_draws"]

#: Bins of each pixel's histogram.
HISTOGRAM_BINS = 400
_SPAN_SIGMAS = 8.0
_MAX_OUTSIDE = 0.005


class PixelMoments:
    """Per-pixel streaming mean and variance over valid draws (Welford), and the histogram of
    the quantile method."""

    def __init__(self, shape):
        self.n = np.zeros(shape)
        self.mean = np.zeros(shape)
        self.m2 = np.zeros(shape)
        self.draws = 0
        self.edges = None
        self.counts = None
        self.below = np.zeros(shape)
        self.above = np.zeros(shape)

    def add(self, values: np.ndarray):
        self.draws += 1
        valid = np.isfinite(values)
        self.n += valid
        delta = np.where(valid, values - self.mean, 0.0)
        self.mean += np.where(valid, delta / np.maximum(self.n, 1), 0.0)
        self.m2 += np.where(valid, delta * (values - self.mean), 0.0)
        if self.edges is not None:
            self._bin(values)

    def start_histogram(self, first: list[np.ndarray]):
        """Fix each pixel's histogram span from the first draws, and bin them."""
        std = np.sqrt(self.variance)
        half = _SPAN_SIGMAS * np.where(std > 0, std, 1e-9 * np.abs(self.mean) + 1e-12)
        self.edges = (self.mean - half, self.mean + half)
        self.counts = np.zeros((*self.mean.shape, HISTOGRAM_BINS), dtype=np.int32)
        for values in first:
            self._bin(values)

    def _bin(self, values):
        low, high = self.edges
        valid = np.isfinite(values)
        position = (values - low) / (high - low) * HISTOGRAM_BINS
        inside = valid & (position >= 0) & (position < HISTOGRAM_BINS)
        self.below += valid & (position < 0)
        self.above += valid & (position >= HISTOGRAM_BINS)
        flat = np.flatnonzero(inside)
        index = flat * HISTOGRAM_BINS + position.ravel()[flat].astype(np.int64)
        np.add.at(self.counts.reshape(-1), index, 1)

    @property
    def variance(self):
        return np.where(self.n > 1, self.m2 / np.maximum(self.n - 1, 1), np.nan)

    def quantile(self, q: float) -> np.ndarray:
        """Per-pixel quantile by linear interpolation of the histogram's CDF (NaN where too
        many draws fell outside its span)."""
        low, high = self.edges
        counts = self.counts
        outside = self.below + self.above
        total = counts.sum(axis=-1) + outside
        cdf = np.cumsum(counts, axis=-1)
        target = q * total - self.below  # the rank among all draws, within the span
        k = np.sum(cdf < target[..., None], axis=-1).clip(0, HISTOGRAM_BINS - 1)
        before = np.take_along_axis(cdf, np.maximum(k - 1, 0)[..., None], -1)[..., 0]
        before = np.where(k > 0, before, 0)
        inbin = np.take_along_axis(counts, k[..., None], -1)[..., 0]
        fraction = np.where(inbin > 0, (target - before) / np.maximum(inbin, 1), 0.5)
        value = low + (k + fraction) / HISTOGRAM_BINS * (high - low)
        bad = (total == 0) | (outside > _MAX_OUTSIDE * np.maximum(total, 1)) | (
            target < 0) | (target > counts.sum(axis=-1))
        return np.where(bad, np.nan, value)


def over_draws(reduce, stack: np.ndarray, least: int = 1, **options) -> np.ndarray:
    """
    ``reduce(stack, axis=0, **options)`` (a NaN-ignoring numpy reduction over the draws, axis
    0) for each pixel with at least ``least`` draws that have a reading (not NaN); NaN for the
    others, as their flag — without numpy's warnings about empty slices, which then never
    arise.

    Examples
    --------
    >>> stack = np.array([[1.0, np.nan], [3.0, np.nan]])
    >>> over_draws(np.nanstd, stack, 2, ddof=1)
    array([1.41421356,        nan])
    """
    counts = np.sum(~np.isnan(stack), axis=0)
    out = np.full(stack.shape[1:], np.nan)
    enough = counts >= least
    if enough.any():
        out[enough] = reduce(stack[:, enough], axis=0, **options)
    return out

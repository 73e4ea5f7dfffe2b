"""
The numpy references of the compiled kernels (float64 throughout, the integrator's reduceat
arithmetic): :func:`pixel_mean_reference`, :func:`accumulate_reference` and
:func:`accumulate_merged_reference`. They are the tests' oracle and the path the compiled
kernels take for pixel rows holding samples colder than the radiance table.
"""

from __future__ import annotations

import numpy as np

from radiosim.kernels.codes import STATUS_BELOW_TABLE, STATUS_OK
from radiosim.kernels.layout import (KernelAxis, frame_region, kernel_axis, merged_arguments,
                                     per_pixel)
from radiosim.kernels.messages import check_samples
from radiosim.kernels.table import SignalTable

__all__ = ["pixel_mean_reference", "accumulate_reference", "Members",
           "accumulate_merged_reference", "accumulate_bands_reference", "identity_axes"]


def on_pieces(field: np.ndarray, rows: KernelAxis, cols: KernelAxis,
              dtype=np.float64) -> np.ndarray:
    """A field on the region grid, on the piece grid (a copy, in ``dtype``)."""
    return np.asarray(np.asarray(field)[rows.source][:, cols.source], dtype=dtype)


def weighted_mean(values: np.ndarray, rows: KernelAxis, cols: KernelAxis) -> np.ndarray:
    """Area-weighted mean of piece values over each pixel (the integrator's pixel_mean)."""
    weighted = np.add.reduceat(values * rows.weight[:, None], rows.starts, axis=0)
    return np.add.reduceat(weighted * cols.weight[None, :], cols.starts, axis=1)


def pixel_mean_reference(frame, rows, cols, *, frame_index: int = 0,
                         threads: int | None = None) -> np.ndarray:
    """:func:`pixel_mean` in plain numpy (float64 throughout): the oracle (``threads`` accepted
    and unused)."""
    rows, cols = kernel_axis(rows, "row"), kernel_axis(cols, "column")
    frame2d = frame_region(frame, rows, cols)
    check_samples(frame2d, rows, cols, frame_index, None)
    return weighted_mean(on_pieces(frame2d, rows, cols), rows, cols)


def accumulate_numpy(frame2d, rows: KernelAxis, cols: KernelAxis, time_weight, reference, dev,
                     sq, tmax, signal_acc, response):
    t = on_pieces(frame2d, rows, cols)  # [K], float64, on the piece grid
    deviation = t - np.repeat(np.repeat(reference, np.diff(rows.bounds), axis=0),
                              np.diff(cols.bounds), axis=1)
    dev += time_weight * weighted_mean(deviation, rows, cols)
    sq += time_weight * weighted_mean(deviation * deviation, rows, cols)
    peak = np.maximum.reduceat(np.maximum.reduceat(t, rows.starts, axis=0), cols.starts, axis=1)
    np.maximum(tmax, peak, out=tmax)
    if response is not None:
        grey = None if response.grey_scalar is not None else on_pieces(response.grey, rows, cols)
        index = None if response.index is None else on_pieces(response.index, rows, cols, np.intp)
        signal_acc += time_weight * weighted_mean(response.signal(t, grey, index), rows, cols)


def checked_arguments(frame, rows, cols, reference, dev, sq, tmax, signal_acc, response):
    """The axes and the 2-D frame of an accumulation, its per-pixel arrays checked."""
    rows, cols = kernel_axis(rows, "row"), kernel_axis(cols, "column")
    frame2d = frame_region(frame, rows, cols)
    shape = (rows.n_pixels, cols.n_pixels)
    for name, array in (("reference", reference), ("dev", dev), ("sq", sq), ("tmax", tmax)):
        per_pixel(array, shape, name)
    if response is not None:
        per_pixel(signal_acc, shape, "signal_acc")
    return rows, cols, frame2d


def accumulate_reference(frame, rows, cols, time_weight: float, reference: np.ndarray,
                         dev: np.ndarray, sq: np.ndarray, tmax: np.ndarray,
                         signal_acc: np.ndarray | None = None,
                         response: SignalTable | None = None, *,
                         frame_index: int = 0, threads: int | None = None) -> int:
    """:func:`accumulate` in plain numpy (float64, the integrator's reduceat arithmetic): the
    oracle, and the path for frames with samples below the radiance table. Same arguments
    (``threads`` accepted and unused), checks, errors and return value."""
    rows, cols, frame2d = checked_arguments(frame, rows, cols, reference, dev, sq, tmax, signal_acc,
                                   response)
    if response is not None:
        response.check_maps(frame2d.shape)
    below = check_samples(frame2d, rows, cols, frame_index, response)
    accumulate_numpy(frame2d, rows, cols, float(time_weight), reference, dev, sq, tmax,
                      signal_acc, response)
    return STATUS_BELOW_TABLE if below else STATUS_OK


class Members:
    """
    The accumulators of the jobs that share a footprint group in the engines'
    pass (:func:`accumulate_merged`): per job b, the merged mean [K], M2 [K²] (sum of the
    weights × squared deviations), maximum [K] and time-weighted signal of each pixel, stacked
    as (jobs, pixel rows, pixel columns), and the total weight n_b merged so far.
    """

    def __init__(self, n_jobs: int, shape: tuple[int, int]):
        self.mean = np.zeros((n_jobs, *shape))
        self.m2 = np.zeros((n_jobs, *shape))
        self.max = np.full((n_jobs, *shape), -np.inf)
        self.signal = np.zeros((n_jobs, *shape))
        self.count = np.zeros(n_jobs)


def merge_numpy(rows, d, v1, t_max, s, reference, moments, weight, count, signal_weight, mean,
                m2, peak, signal):
    """Merge a frame's sums over pixel ``rows`` (d = Σ w (T − c), v1 = Σ w (T − c)², the
    maximum, s = Σ w S) into the jobs' moments as the compiled kernel does (Chan, Golub &
    LeVeque 1979; per job b of time weight ``weight[b]`` and count ``count[b]`` before the
    frame), add ``signal_weight[b]`` × s to their signals, and set the reference rows to the
    frame's means (with ``moments``)."""
    for b in range(weight.size):
        if signal_weight[b] > 0:
            signal[b, rows] += signal_weight[b] * s
    if moments:
        frame_mean = reference[rows] + d
        frame_var = np.maximum(v1 - d * d, 0.0)
        for b in range(weight.size):
            w = weight[b]
            if w > 0:
                n_b = count[b]
                total = n_b + w
                delta = frame_mean - mean[b, rows]
                m2[b, rows] += w * frame_var + delta * delta * (n_b * w / total)
                mean[b, rows] += delta * (w / total)
                peak[b, rows] = np.maximum(peak[b, rows], t_max)
        reference[rows] = frame_mean


def accumulate_merged_reference(frame, rows, cols, reference: np.ndarray, members: Members,
                                weight: np.ndarray, signal_weight: np.ndarray,
                                response: SignalTable | None = None, *,
                                moments: bool = True, keep_moments: bool = False,
                                frame_index: int = 0, threads: int | None = None) -> int:
    """:func:`~radiosim.kernels.launch.accumulate_merged` in plain numpy: each frame's sums by
    :func:`accumulate_reference`, merged by :func:`merge_numpy`. Same arguments (``threads``
    and ``keep_moments`` are accepted and unused: numpy's moments do not depend on the
    response), checks, errors and return value."""
    rows, cols, block, weight, signal_weight, counts = merged_arguments(
        frame, rows, cols, members, weight, signal_weight, moments)
    n_frames = block.shape[0]
    shape = reference.shape
    every = np.arange(shape[0])
    status = STATUS_OK
    for f in range(n_frames):
        dev, sq, signal = np.zeros(shape), np.zeros(shape), np.zeros(shape)
        peak = np.full(shape, -np.inf)
        status |= accumulate_reference(block[f], rows, cols, 1.0, reference, dev, sq, peak,
                                       None if response is None else signal, response,
                                       frame_index=frame_index + f)
        merge_numpy(every, dev, sq, peak, signal, reference, bool(moments), weight[f],
                    counts[f], signal_weight[f], members.mean, members.m2, members.max,
                    members.signal)
    if moments:
        members.count[...] = counts[-1]
    return status


class _Identity:
    """An axis of n pixels, each one whole sample (the image stage's sample resolution)."""

    def __init__(self, n: int):
        self.source = np.arange(n)
        self.weight = np.ones(n)
        self.starts = np.arange(n)


_IDENTITY: dict[tuple[int, int], tuple[KernelAxis, KernelAxis]] = {}


def identity_axes(shape: tuple[int, int]) -> tuple[KernelAxis, KernelAxis]:
    """The row and column axes of one pixel per sample on a region of ``shape`` (kept per
    shape)."""
    axes = _IDENTITY.get(tuple(shape))
    if axes is None:
        _IDENTITY.clear()
        axes = _IDENTITY[tuple(shape)] = (KernelAxis.of(_Identity(shape[0]), "row"),
                                          KernelAxis.of(_Identity(shape[1]), "column"))
    return axes


def accumulate_bands_reference(block, weights, tables: list[SignalTable], out: np.ndarray, *,
                               frame_index: int = 0) -> int:
    """:func:`~radiosim.kernels.bands.accumulate_bands` in plain numpy, the oracle: each
    sub-band on its own, frame by frame (``out[b] += weights[f] · S_b(T_f)`` per sample, by
    :func:`accumulate_reference` with one pixel per sample), with its checks and errors.
    Returns STATUS_BELOW_TABLE if some samples were below a table (exact radiance), else
    STATUS_OK."""
    block = np.asarray(block)
    if block.ndim == 2:
        block = block[None]
    weights = np.asarray(weights, dtype=np.float64).reshape(-1)
    shape = block.shape[1:]
    rows, cols = identity_axes(shape)
    zero = np.zeros(shape)
    dev, sq, tmax = np.zeros(shape), np.zeros(shape), np.full(shape, -np.inf)
    status = STATUS_OK
    for f in range(block.shape[0]):
        for b, table in enumerate(tables):
            status |= accumulate_reference(block[f], rows, cols, float(weights[f]), zero, dev,
                                           sq, tmax, out[b], table,
                                           frame_index=frame_index + f)
    return status

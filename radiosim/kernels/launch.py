"""
Launching the compiled kernel: the public entry points :func:`pixel_mean`, :func:`accumulate`
and :func:`accumulate_merged` (argument checks, the table's arrays, per-thread buffers, blocks
of pixel rows, several frames per call) and the handling of a flagged frame (raise with the
sample's message, or redo the rows below the table in numpy). The pixel rows run in fixed
blocks on radiosim's threads (:func:`~radiosim.kernels.threads.run_blocks`), as many as numba's
thread count (:func:`thread_count`, so that ``numba.set_num_threads`` limits radiosim too).
"""

from __future__ import annotations

import threading

import numba
import numpy as np

from radiosim.errors import RadiosimError
from radiosim.kernels.bundles import Accumulators, Merging, RowPieces, ThreadBuffers
from radiosim.kernels.codes import (STATUS_ABOVE_TABLE, STATUS_BAD_INDEX, STATUS_BAD_SAMPLE,
                                    STATUS_BELOW_TABLE, STATUS_OK)
from radiosim.kernels.layout import (KernelAxis, frame_bundle, kernel_axis, merged_arguments,
                                     read_only)
from radiosim.kernels.messages import raise_above_table, raise_bad_index, raise_bad_sample
from radiosim.kernels.packing import NO_TABLES, emissivity, pack
from radiosim.kernels.reference import (Members, accumulate_numpy, checked_arguments,
                                        merge_numpy)
from radiosim.kernels.rows import accumulate_kernel
from radiosim.kernels.sweeps import MAX_ROWS
from radiosim.kernels.table import SignalTable
from radiosim.kernels.threads import run_blocks

__all__ = ["thread_count", "pixel_mean", "accumulate", "Members", "accumulate_merged"]

def thread_count() -> int:
    """numba's current number of threads (``numba.get_num_threads()``): radiosim asks through
    this function only."""
    return numba.get_num_threads()


_DUMMY_SIGNAL = np.zeros((1, 1))


_BUFFERS = threading.local()


def _buffers(n_blocks: int, size: int, n_slots: int, index_dtype) -> ThreadBuffers:
    """Per-thread buffers (:class:`~radiosim.kernels.bundles.ThreadBuffers`) for the duplicate
    slots' samples (frame rows, grey map row, index map row), each as a writeable array and a
    read-only view of it, and the running maximum and minimum of every slot: float64 for either
    frame dtype (one compiled kernel takes both; a float32 sample widens exactly)."""
    key = (n_blocks, size, n_slots, np.dtype(index_dtype))
    cache = _BUFFERS.__dict__.setdefault("cache", {})  # per calling thread
    cached = cache.get(key)
    if cached is None:
        rows = np.empty((n_blocks, MAX_ROWS, size))
        grey = np.empty((n_blocks, size))
        index = np.empty((n_blocks, size), dtype=index_dtype)
        cached = ThreadBuffers(rows, read_only(rows), grey, read_only(grey), index,
                               read_only(index), np.empty((n_blocks, n_slots)),
                               np.empty((n_blocks, n_slots)))
        if len(cache) > 8:
            cache.clear()
        cache[key] = cached
    return cached


#: Samples a launch needs per thread (unless its ``threads`` are given): a
#: block on another thread costs about 0.05 ms to hand over and collect, the time the kernel
#: takes for some 10⁵ samples, so smaller launches (a small crop's single frames) run on the
#: calling thread alone. The blocks write disjoint rows: the result is the same bits.
SAMPLES_PER_THREAD = 1 << 17


def _blocks(n_rows: int, threads: int | None = None) -> int:
    """Blocks of pixel rows: one per thread."""
    if threads is None:
        threads = thread_count()
    elif not 1 <= int(threads) <= numba.config.NUMBA_NUM_THREADS:
        raise RadiosimError(f"threads must be in 1–{numba.config.NUMBA_NUM_THREADS}, got "
                            f"{threads!r}")
    return max(1, min(n_rows, int(threads)))


def pixel_mean(frame, rows, cols, *, frame_index: int = 0,
               threads: int | None = None) -> np.ndarray:
    """
    Area-weighted mean of a frame region over each pixel's footprint [K] (the per-pixel
    reference c of an integration, from its first frame), checking every sample it reads.

    It is :func:`accumulate` with c = 0 and time weight 1 (the same compiled kernel).

    Parameters
    ----------
    frame
        The frame region (float32 or float64, 2-D; read in place), starting at each axis'
        first piece sample.
    rows, cols
        :class:`~radiosim.integrator.AxisFootprints` of the row and column axes.
    frame_index
        Frame index k, for error messages.
    threads
        As for :func:`accumulate`.

    Returns
    -------
    numpy.ndarray
        (pixel rows, pixel columns), float64.
    """
    rows, cols = kernel_axis(rows, "row"), kernel_axis(cols, "column")
    shape = (rows.n_pixels, cols.n_pixels)
    mean, sq, tmax = np.zeros(shape), np.zeros(shape), np.full(shape, -np.inf)
    accumulate(frame, rows, cols, 1.0, _zeros(shape), mean, sq, tmax, frame_index=frame_index,
               threads=threads)
    return mean


_ZEROS: dict[tuple[int, int], np.ndarray] = {}


def _zeros(shape: tuple[int, int]) -> np.ndarray:
    """A read-only per-pixel array of zeros (kept per shape)."""
    zeros = _ZEROS.get(shape)
    if zeros is None:
        _ZEROS.clear()
        zeros = _ZEROS[shape] = read_only(np.zeros(shape))
    return zeros


def accumulate(frame, rows, cols, time_weight: float, reference: np.ndarray, dev: np.ndarray,
               sq: np.ndarray, tmax: np.ndarray, signal_acc: np.ndarray | None = None,
               response: SignalTable | None = None, *, frame_index: int = 0,
               threads: int | None = None) -> int:
    """
    Accumulate one frame into the per-pixel tensor statistics, in one pass over its pieces.

    Per pixel: ``dev += w_t Σ w (T − c)``, ``sq += w_t Σ w (T − c)²``,
    ``tmax = max(tmax, max T)`` and, with a ``response``, ``signal_acc += w_t Σ w S(T)``, where
    w are the pieces' area weights and w_t is ``time_weight``.

    Parameters
    ----------
    frame
        The frame region (float32 or float64, 2-D; read in place, never copied to float64).
    rows, cols
        :class:`~radiosim.integrator.AxisFootprints` of the row and column axes.
    time_weight
        The frame's weight in the window.
    reference
        Per-pixel reference c [K] (:func:`pixel_mean` of the window's first frame).
    dev, sq, tmax, signal_acc
        Per-pixel accumulators, float64 C-contiguous (pixel rows, pixel columns), updated in
        place; ``signal_acc`` only with a ``response``.
    response
        :class:`~radiosim.kernels.table.SignalTable` (with the frame's emissivity maps), or
        ``None`` for no signal (the linear response: the signal is T).
    frame_index
        Frame index k, for error messages.
    threads
        Threads (blocks of pixel rows) for this call; ``None``: numba's current number
        (``numba.get_num_threads()``), at most one per :data:`SAMPLES_PER_THREAD` samples of
        the call. On a machine whose cores are busy with other work (e.g. a thread preparing
        the next frame), one thread can be faster: the call waits for its slowest block.

    Returns
    -------
    int
        :data:`STATUS_OK`, or :data:`STATUS_BELOW_TABLE` if some pixel rows held samples below
        the radiance table and were accumulated by the numpy reference instead (exact
        quadrature for those samples).

    Raises
    ------
    RadiosimError
        A sample is NaN, infinite or ≤ 0 K (message as ``check_frame``: frame, row and column
        in full-scene coordinates, value, count), above its table, or has an index that is no
        entry. The accumulators are then partly updated: discard them.
    """
    rows, cols, frame2d = checked_arguments(frame, rows, cols, reference, dev, sq, tmax, signal_acc,
                                   response)
    if not reference.flags.writeable:  # the kernel takes one array type (it writes it only
        reference = reference.copy()  # when merging)
    def handle(f, launched):
        return _finish(launched, frame2d, rows, cols, frame_index, response,
                       float(time_weight), reference, dev, sq, tmax, signal_acc, None)

    return _launch(frame2d[None], rows, cols, float(time_weight), reference, dev, sq, tmax,
                   signal_acc, response, None, threads, handle)


def accumulate_merged(frame, rows, cols, reference: np.ndarray, members: Members,
                      weight: np.ndarray, signal_weight: np.ndarray,
                      response: SignalTable | None = None, *, moments: bool = True,
                      keep_moments: bool = False, frame_index: int = 0,
                      threads: int | None = None) -> int:
    """
    One frame into the accumulators of several jobs on the same footprints, in one pass: the
    frame's per-pixel mean m = c + Σ w (T − c) and variance v = Σ w (T − c)² − (Σ w (T − c))²
    (c = ``reference``, the previous frame's means) are merged into job b with its time weight
    ``weight[b]`` (0: the frame is not in its window) by the update of Chan, Golub & LeVeque
    (1979), its maximum raised, and ``signal_weight[b]`` × the frame's mean signal added to its
    signal. ``reference`` then holds m. With ``moments`` off, only the signals are added (a
    second response on the same footprints) and ``reference`` is kept. ``members.count`` is
    updated here. Checks, errors and return value as :func:`accumulate`.

    A pixel row with samples below the response's table is redone in numpy (exact quadrature);
    with ``keep_moments`` only its signal is: its moments are the kernel's, exactly those a
    pass without the response gives (one pass then serves a linear and a radiometric job,
    with the results of two).

    ``frame`` may also be several consecutive frames (3-D: frames, rows, columns; frame
    indices ``frame_index``, ``frame_index + 1``, …) with ``weight`` and ``signal_weight`` one
    row per frame: they are merged one after the other, exactly as frame by frame, in one call
    (no per-frame Python or thread start-up).
    """
    rows, cols, block, weight, signal_weight, counts = merged_arguments(
        frame, rows, cols, members, weight, signal_weight, moments)
    keep = bool(moments and keep_moments and response is not None)
    merged = Merging(True, bool(moments), keep, weight, counts[:-1], signal_weight,
                     members.mean, members.m2, members.max, members.signal)

    def handle(f, launched):
        # Rows kept by the kernel (keep) merged their moments there: numpy adds the signal.
        one = (bool(moments) and not keep, weight[f], counts[f], signal_weight[f],
               members.mean, members.m2, members.max, members.signal)
        return _finish(launched, block[f], rows, cols, frame_index + f, response, 1.0,
                       reference, None, None, None, None, (one, members))

    shape = reference.shape
    status = _launch(block, rows, cols, 1.0, reference, _scratch(shape, 0), _scratch(shape, 1),
                     _scratch(shape, 2), _scratch(shape, 3), response, merged, threads, handle)
    if moments:
        members.count[...] = counts[-1]
    return status


_NO_MEMBERS = Merging(False, False, False, np.zeros((1, 1)), np.zeros((1, 1)),
                      np.zeros((1, 1)), np.zeros((1, 1, 1)), np.zeros((1, 1, 1)),
                      np.zeros((1, 1, 1)), np.zeros((1, 1, 1)))


_SCRATCH: dict = {}


def _scratch(shape, which: int) -> np.ndarray:
    """Per-pixel arrays the merging kernel takes but does not use (kept per shape)."""
    key = (shape, which)
    array = _SCRATCH.get(key)
    if array is None:
        if len(_SCRATCH) > 16:
            _SCRATCH.clear()
        array = _SCRATCH[key] = np.zeros(shape)
    return array


def _launch(block, rows: KernelAxis, cols: KernelAxis, time_weight, reference, dev, sq, tmax,
            signal_acc, response, merged, threads, handle) -> int:
    """Run the compiled kernel on the frames of ``block`` (3-D; several only when merging,
    with ``merged``'s weights one row per frame). A frame with a status stops the blocks of
    pixel rows that saw it; in frame order, ``handle(f, (OR of its rows' bits, the rows'
    status array, the table))`` deals with it (raises, or redoes the flagged rows) and returns
    a status, and those blocks go on from the next frame. Returns the OR of the handled
    statuses (STATUS_OK if none). The kernel's arguments travel in the named bundles of
    :mod:`radiosim.kernels.bundles`."""
    shape = (rows.n_pixels, cols.n_pixels)
    frames = frame_bundle(block)
    n_frames = block.shape[0]
    if response is None:
        signal, tables = _DUMMY_SIGNAL, NO_TABLES
    else:
        tables = pack(response)  # the engine's own format of the response's tables
        signal = signal_acc if signal_acc is not None else _scratch(shape, 3)
    signs = emissivity(response, block.shape[1:])
    acc = Accumulators(time_weight, reference, dev, sq, tmax, signal)
    status = np.zeros((n_frames, rows.n_pixels), dtype=np.int64)
    slots = cols.slots
    available = thread_count() if threads is None else threads  # (numba's getter: ~0.1 ms)
    n_blocks = _blocks(rows.n_pixels, available)
    if threads is None:  # a thread for every SAMPLES_PER_THREAD samples at least
        n_blocks = max(1, min(n_blocks, block.size // SAMPLES_PER_THREAD))
    buffers = _buffers(n_blocks, max(1, slots.dup_source.size), slots.weight.size,
                       signs.index_map.dtype)
    members = merged if merged is not None else _NO_MEMBERS
    row_pieces = RowPieces(rows.source, rows.weight, rows.bounds)
    start = np.zeros(n_blocks, dtype=np.int64)
    pending = np.full(n_blocks, -1, dtype=np.int64)  # a frame whose status awaits handling
    handled = STATUS_OK
    while True:
        run = np.where(pending >= 0, n_frames, start)
        stopped = np.array(run_blocks(accumulate_kernel, n_blocks, n_blocks, run, frames,
                                      row_pieces, slots, acc, members, tables, signs, buffers,
                                      status))
        ran = run < n_frames
        pending[ran & (stopped < n_frames)] = stopped[ran & (stopped < n_frames)]
        start[ran] = np.minimum(stopped[ran] + 1, n_frames)
        if not np.any(pending >= 0):
            return handled
        # The earliest frame with a status: every block has either passed it cleanly or
        # stopped at or after it, so its flagged rows are handled in frame order.
        f = int(pending[pending >= 0].min())
        result = int(np.bitwise_or.reduce(status[f]))
        handled |= handle(f, (result, status[f], response))
        pending[pending == f] = -1


def _finish(launched, frame2d, rows: KernelAxis, cols: KernelAxis, frame_index, response,
            time_weight, reference, dev, sq, tmax, signal_acc, merged):
    """Raise for a flagged frame, or redo its pixel rows with samples below the table in numpy
    (exact quadrature for those samples); returns STATUS_BELOW_TABLE."""
    result, status, table = launched
    if result & STATUS_BAD_SAMPLE:
        raise_bad_sample(frame2d, rows, cols, frame_index)
    if result & STATUS_BAD_INDEX:
        raise_bad_index(frame2d, rows, cols, frame_index, table)
    if result & STATUS_ABOVE_TABLE:
        raise_above_table(frame2d, rows, cols, frame_index, table)
    # Samples below the table: those pixel rows were left untouched; redo them in numpy.
    shape = (rows.n_pixels, cols.n_pixels)
    flagged = np.flatnonzero(status)
    start, stop = int(flagged[0]), int(flagged[-1]) + 1
    part = rows.pixels(start, stop)
    n = stop - start
    part_dev, part_sq, part_signal = (np.zeros((n, shape[1])) for _ in range(3))
    part_max = np.full((n, shape[1]), -np.inf)
    accumulate_numpy(frame2d, part, cols, time_weight, reference[start:stop], part_dev,
                      part_sq, part_max, part_signal, response)
    local = flagged - start
    if merged is None:
        dev[flagged] += part_dev[local]
        sq[flagged] += part_sq[local]
        signal_acc[flagged] += part_signal[local]
        tmax[flagged] = np.maximum(tmax[flagged], part_max[local])
        return STATUS_BELOW_TABLE
    (moments, weight, count, signal_weight, mean, m2, peak, signal), _ = merged
    merge_numpy(flagged, part_dev[local], part_sq[local], part_max[local], part_signal[local],
                reference, moments, weight, count, signal_weight, mean, m2, peak, signal)
    return STATUS_BELOW_TABLE

"""
All spectral sub-bands of a response from one table lookup per sample: the window mean, at
sample resolution, of each sub-band's signal S_b(T) = L_b,e(T) · grey_e,b · grey (the image
stage's per-sample radiance, :func:`radiosim.imaging.sample_signals`).

The sub-bands' :class:`~radiosim.kernels.table.SignalTable` share their temperature grid (the
same range and intervals per octave): :func:`stack` interleaves their cubic coefficients, the
sub-bands' rows of one interval next to each other (one interval's data for every sub-band in
four cache lines), so that a sample's interval and position are found once (the bits of T,
:func:`~radiosim.kernels.radiance._locate`) and every sub-band's cubic is read at that
interval (eight samples at a time, as the other kernels). :func:`accumulate_bands` takes
several frames per call, each pixel row's sums kept in its thread until the block's frames are
done. Tables that cannot
share lookups go to the reference (:func:`stack` returns ``None``).

The numpy reference (the oracle) is
:func:`radiosim.kernels.reference.accumulate_bands_reference`: each sub-band's
:meth:`SignalTable.signal <radiosim.kernels.table.SignalTable.signal>`, frame by frame.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from radiosim.errors import RadiosimError
from radiosim.kernels.bundles import Emissivity
from radiosim.kernels.codes import (SIGNAL_INDEX, STATUS_ABOVE_TABLE, STATUS_BAD_INDEX,
                                    STATUS_BAD_SAMPLE, STATUS_BELOW_TABLE, STATUS_OK)
from radiosim.kernels.intrinsics import INF, INNER, JIT, _cubic8_grey, _cubic8_map
from radiosim.kernels.layout import frame_bundle, read_only, rows_of
from radiosim.kernels.packing import _ones, _uint8_index
from radiosim.kernels.radiance import _cubic1, _locate, cubic
from radiosim.kernels.reference import accumulate_bands_reference
from radiosim.kernels.table import SignalTable
from radiosim.kernels.threads import run_blocks


__all__ = ["StackedTables", "stack", "launch_bands", "accumulate_bands", "band_kernel",
           "WIDEN_BYTES"]

#: Most bytes of float32 frames :func:`accumulate_bands` widens to float64 for one kernel call.
WIDEN_BYTES = 1 << 24


class StackedTables(NamedTuple):
    """The radiance tables of several sub-bands on one grid, interleaved: the distinct tables'
    intervals one after the other (distinct table j's interval k is interval ``offset[j] + k``),
    and interval n's rows of the B sub-bands next to each other: sub-band b's row of interval n
    is row ``n · B + b`` of ``coef`` (four coefficients a row, highest power of T − T_k first)."""

    #: float64, read-only: the interleaved coefficients.
    coef: np.ndarray
    #: Per distinct table: bit key of its first node (int64), bits below the keys (uint64),
    #: its last interval (int64), its first interval in ``coef`` (uint64), its range [K].
    key0: np.ndarray
    shift: np.ndarray
    last: np.ndarray
    offset: np.ndarray
    t_min: np.ndarray
    t_max: np.ndarray
    #: intp per entry: its table.
    entry_table: np.ndarray
    #: float64 (entries, sub-bands): each entry's grey factor per sub-band.
    entry_grey: np.ndarray


def _same_grid(a, b) -> bool:
    return (a.key0 == b.key0 and a.shift == b.shift and a.intervals == b.intervals
            and tuple(a.temperature_range) == tuple(b.temperature_range))


def stack(tables: list[SignalTable]) -> StackedTables | None:
    """
    The sub-bands' tables interleaved (:class:`StackedTables`), or ``None`` when they cannot
    share lookups (a different entry structure, or a distinct table whose grid differs between
    sub-bands). Kept in the first table's ``engine_data`` (shared by its per-frame copies).
    """
    first = tables[0]
    key = ("stacked",) + tuple(id(t.engine_data) for t in tables)
    cached = first.engine_data.get(key)
    if cached is not None:
        return cached
    n_unique = len(first.unique_tables)
    for t in tables[1:]:
        if (len(t.unique_tables) != n_unique or t.n_entries != first.n_entries
                or not np.array_equal(t.entry_table, first.entry_table)
                or not all(_same_grid(u, v) for u, v in zip(first.unique_tables,
                                                            t.unique_tables))):
            return None
    blocks = [np.concatenate([t.unique_tables[j].coefficients for j in range(n_unique)])
              for t in tables]  # per sub-band, its distinct tables' rows one after the other
    unique = first.unique_tables
    rows = np.stack([b.reshape(-1, 4) for b in blocks], axis=1)  # (intervals, sub-bands, 4)
    stacked = StackedTables(
        coef=read_only(np.ascontiguousarray(rows.reshape(-1))),
        key0=np.array([u.key0 for u in unique], dtype=np.int64),
        shift=np.array([u.shift for u in unique], dtype=np.uint64),
        last=np.array([u.intervals - 1 for u in unique], dtype=np.int64),
        offset=np.cumsum([0] + [u.intervals for u in unique[:-1]]).astype(np.uint64),
        t_min=np.ascontiguousarray(first.t_min, dtype=np.float64),
        t_max=np.ascontiguousarray(first.t_max, dtype=np.float64),
        entry_table=np.ascontiguousarray(first.entry_table, dtype=np.intp),
        entry_grey=np.ascontiguousarray(np.stack([t.entry_grey for t in tables], axis=1)))
    if len(first.engine_data) > 64:
        first.engine_data.clear()
    first.engine_data[key] = stacked
    return stacked


@numba.njit(**INNER)
def _band_pass(coef, interval, position, grey_map, g0, w, grey, use_map, acc, out0, n):
    """acc[out0 + q] += the sub-band's signal at samples q < n (their intervals and positions
    in ``interval`` and ``position``, the sub-band's table from ``coef``): w · (v · (grey ·
    map)) with a grey map (``grey_map[g0 + q]``), else v · w (w the frame's weight times the
    grey factors); eight samples at a time (:func:`_cubic8_grey`, :func:`_cubic8_map`), the
    rest one by one with the same operations."""
    q = 0
    if use_map:
        while q + 8 <= n:
            _cubic8_map(coef, interval, position, grey_map, g0, w, grey, acc, out0, q)
            q += 8
        for k in range(q, n):
            acc[out0 + k] += w * (_cubic1(coef, interval[k], position[k])
                                  * (grey * grey_map[g0 + k]))
    else:
        while q + 8 <= n:
            _cubic8_grey(coef, interval, position, grey_map, g0, w, grey, acc, out0, q)
            q += 8
        for k in range(q, n):
            acc[out0 + k] += _cubic1(coef, interval[k], position[k]) * w


def band_kernel(block, n_blocks, frames, weight, tables, emissivity, out, status):
    """out[b, i, j] += Σ_f weight[f] · S_b(T_f[i, j]) for the frames of ``frames``
    (:class:`~radiosim.kernels.bundles.FrameBlock`) and every sub-band b of ``tables``
    (:class:`StackedTables`): per pixel row of block ``block`` of ``n_blocks`` (one block per
    thread, :func:`~radiosim.kernels.threads.run_blocks`) and frame, each sample's interval
    and position once (and its entry; the interval kept as its first row of ``coef``, times
    the sub-bands), then each sub-band's cubics, eight samples at a time, from its row of that
    interval (``coef`` from the sub-band's offset), accumulated. A row's sums
    are kept until the block's frames are done and added only if none of its samples has a
    status (``status[i]``: bits of :mod:`radiosim.kernels.codes`)."""
    n_bands, n_rows, n_cols = out.shape
    base = frames.base
    coef = tables.coef
    entry_table = tables.entry_table
    entry_grey = tables.entry_grey
    n_entries = entry_table.size
    grey_map = emissivity.grey_map
    index_map = emissivity.index_map
    use_map = emissivity.use_map
    indexed = emissivity.mode == SIGNAL_INDEX
    one = np.uint64(1)
    nb = np.uint64(n_bands)  # interval n, sub-band b: row n · nb + b of coef
    j0 = entry_table[0]  # the one table without an index map
    shift = tables.shift[j0]
    key0 = tables.key0[j0]
    mask = ~((one << shift) - one)
    last = np.uint64(tables.last[j0])
    offset = tables.offset[j0]
    t_min = tables.t_min[j0]
    t_max = tables.t_max[j0]
    for i in range(block * n_rows // n_blocks, (block + 1) * n_rows // n_blocks):
        acc = np.zeros(n_bands * n_cols)
        interval = np.empty(n_cols, dtype=np.uint64)
        position = np.empty(n_cols)
        value = np.empty(n_cols)
        entry = np.zeros(n_cols, dtype=np.int64)
        row_status = 0
        m_off = i * emissivity.map_length
        for f in range(frames.n_frames):
            w = weight[f]
            x0 = f * frames.frame_stride + i * frames.row_length
            if indexed:  # each sample's entry, its table's range and interval
                for j in range(n_cols):
                    t = np.float64(base[x0 + j])
                    e = np.int64(index_map[m_off + j])
                    if e >= n_entries:
                        row_status |= STATUS_BAD_INDEX
                        e = 0
                    entry[j] = e
                    if not t > 0.0 or t == INF:  # NaN, ≤ 0 K, +inf
                        row_status |= STATUS_BAD_SAMPLE
                    jt = entry_table[e]
                    if t < tables.t_min[jt]:
                        row_status |= STATUS_BELOW_TABLE
                    if t > tables.t_max[jt]:
                        row_status |= STATUS_ABOVE_TABLE
                    s = tables.shift[jt]
                    k, d = _locate(t, tables.key0[jt], s, ~((np.uint64(1) << s) - one),
                                   np.uint64(tables.last[jt]))
                    interval[j] = (k + tables.offset[jt]) * nb
                    position[j] = d
            else:  # one table: its range checked by counts (a vector loop; NaN counts as bad)
                n_bad = 0
                n_low = 0
                n_high = 0
                for j in range(n_cols):
                    t = np.float64(base[x0 + j])
                    n_bad += np.int64(not t > 0.0) + np.int64(t == INF)  # NaN, ≤ 0 K, +inf
                    n_low += np.int64(t < t_min)
                    n_high += np.int64(t > t_max)
                    k, d = _locate(t, key0, shift, mask, last)
                    interval[j] = (k + offset) * nb
                    position[j] = d
                if n_bad:
                    row_status |= STATUS_BAD_SAMPLE
                if n_low:
                    row_status |= STATUS_BELOW_TABLE
                if n_high:
                    row_status |= STATUS_ABOVE_TABLE
            if row_status != 0:
                break
            for b in range(n_bands):
                table = coef[np.uint64(4 * b):]
                if indexed:  # each sample's entry: its own grey factor
                    cubic(table, interval, position, value, n_cols)
                    for j in range(n_cols):
                        g = grey_map[m_off + j] if use_map else emissivity.grey
                        acc[b * n_cols + j] += w * (value[j] * (entry_grey[entry[j], b] * g))
                elif use_map:
                    _band_pass(table, interval, position, grey_map, m_off, w, entry_grey[0, b],
                               use_map, acc, b * n_cols, n_cols)
                else:  # the same argument types as above: one compilation of _band_pass
                    _band_pass(table, interval, position, grey_map, np.int64(0),
                               w * (entry_grey[0, b] * emissivity.grey), 1.0, use_map, acc,
                               b * n_cols, n_cols)
        status[i] = row_status
        if row_status == 0:
            for b in range(n_bands):
                for j in range(n_cols):
                    out[b, i, j] += acc[b * n_cols + j]


#: One compiled variant, for float64 frames: :func:`accumulate_bands` widens float32 ones (a
#: copy of the block, exact; the kernel widens every sample it reads all the same). The
#: kernel's work per sample (a lookup and a cubic per sub-band) costs more than the copy, and
#: a second variant would cost a compilation.
band_kernel = numba.njit(**JIT)(band_kernel)


def _emissivity(table: SignalTable, shape) -> Emissivity:
    """The kernel's emissivity maps for a frame region of ``shape``: S = L · grey_e · (grey
    map or scalar grey), the entry e from the index map (else 0)."""
    table.check_maps(shape)
    use_map = table.grey_scalar is None
    grey_map, map_length = rows_of(table.grey) if use_map else (_ones(1), 0)
    if table.index is not None:
        index_map, map_length = rows_of(_uint8_index(table.index, table.n_entries))
        mode = SIGNAL_INDEX
    else:
        index_map, mode = read_only(np.zeros(1, dtype=np.uint8)), 0
    return Emissivity(mode, 1.0 if use_map else float(table.grey_scalar), grey_map, index_map,
                      map_length, use_map)


def launch_bands(block, weights, tables: list[SignalTable], out: np.ndarray, *,
                 frame_index: int = 0) -> tuple[int, np.ndarray]:
    """
    out[b] += Σ_f weights[f] · S_b(T_f) per sample, for every sub-band's table ``tables[b]``
    (with the block's emissivity maps) and the frames of ``block`` (2-D, or 3-D: consecutive
    frames sharing those maps; float64 read in place, float32 widened first), from one table
    lookup per sample (:func:`band_kernel`).

    Returns ``(status, rows)``: :data:`~radiosim.kernels.codes.STATUS_OK` and no rows when the
    kernel took every pixel row; else the OR of the status bits of the rows it left untouched
    and those rows (−1 and every row when the tables cannot be stacked, :func:`stack`). The
    caller redoes them with :func:`radiosim.kernels.reference.accumulate_bands_reference`
    (exact quadrature below the tables, the references' errors otherwise).
    """
    from radiosim.kernels.launch import thread_count

    block = np.asarray(block)
    if block.ndim == 2:
        block = block[None]
    weights = np.ascontiguousarray(weights, dtype=np.float64).reshape(-1)
    if block.dtype not in (np.float32, np.float64) or weights.size != block.shape[0]:
        raise RadiosimError(f"accumulate_bands takes float32 or float64 frames and one weight "
                            f"per frame, got {block.dtype} {block.shape} and {weights.size}")
    if out.shape != (len(tables), *block.shape[1:]) or out.dtype != np.float64 \
            or not out.flags.c_contiguous:
        raise RadiosimError(f"out must be float64 C-contiguous of shape "
                            f"{(len(tables), *block.shape[1:])}, got {out.dtype} {out.shape}")
    stacked = stack(tables)
    signs = _emissivity(tables[0], block.shape[1:])
    if stacked is None or signs.index_map.dtype != np.uint8:
        return -1, np.arange(block.shape[1])  # the caller takes the reference
    if block.dtype != np.float64:  # float32: widened, for the kernel's one variant
        block = block.astype(np.float64)
    status = np.zeros(block.shape[1], dtype=np.int64)
    n_blocks = max(1, min(thread_count(), block.shape[1]))
    run_blocks(band_kernel, n_blocks, n_blocks,
               frame_bundle(block), weights, stacked,
               signs, out, status)
    flagged = np.flatnonzero(status)
    result = int(np.bitwise_or.reduce(status[flagged])) if flagged.size else STATUS_OK
    return result, flagged


def accumulate_bands(block, weights, tables: list[SignalTable], out: np.ndarray, *,
                     frame_index: int = 0) -> int:
    """
    out[b] += Σ_f weights[f] · S_b(T_f) per sample, for every sub-band's table ``tables[b]``
    (with the block's emissivity maps) and the frames of ``block`` (2-D, or 3-D: consecutive
    frames sharing those maps), from one table lookup per sample (:func:`launch_bands`); the
    pixel rows the kernel leaves (samples below a table, bad samples) redone by the numpy
    reference (:func:`~radiosim.kernels.reference.accumulate_bands_reference`: exact radiance
    below the tables, its errors otherwise). The compiled engine's ``accumulate_bands``.

    Float32 frames are widened for the kernel a few at a time (at most :data:`WIDEN_BYTES`).

    Returns
    -------
    int
        :data:`~radiosim.kernels.codes.STATUS_OK`, or
        :data:`~radiosim.kernels.codes.STATUS_BELOW_TABLE` if some rows were redone.
    """
    block = np.asarray(block)
    if block.ndim == 2:
        block = block[None]
    per_call = max(1, WIDEN_BYTES // (8 * max(1, block[0].size)))
    if block.dtype != np.float64 and block.shape[0] > per_call:
        weights = np.asarray(weights, dtype=np.float64).reshape(-1)
        status = STATUS_OK
        for lo in range(0, block.shape[0], per_call):
            status |= accumulate_bands(block[lo:lo + per_call], weights[lo:lo + per_call],
                                       tables, out, frame_index=frame_index + lo)
        return status
    status, flagged = launch_bands(block, weights, tables, out, frame_index=frame_index)
    if status == STATUS_OK or not flagged.size:
        return STATUS_OK
    lo, hi = int(flagged[0]), int(flagged[-1]) + 1
    part = np.zeros((len(tables), hi - lo, block.shape[2]))
    cut = [_rows_of_table(t, lo, hi) for t in tables]
    result = accumulate_bands_reference(block[:, lo:hi], weights, cut, part,
                                        frame_index=frame_index)
    redo = flagged - lo if status != -1 else slice(None)
    out[:, lo:hi][:, redo] += part[:, redo]
    return result


def _rows_of_table(table: SignalTable, lo: int, hi: int) -> SignalTable:
    """The table with its maps cut to rows ``lo`` … ``hi − 1``."""
    grey = table.grey if table.grey_scalar is not None else table.grey[lo:hi]
    index = None if table.index is None else table.index[lo:hi]
    return table.with_maps(grey=grey, index=index)

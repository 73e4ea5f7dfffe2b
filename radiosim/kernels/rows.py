"""
The integrator's kernel: pixel rows in one block per thread (:mod:`radiosim.kernels.threads`),
each row's sample rows swept (:mod:`radiosim.kernels.sweeps`) with their radiance
(:mod:`radiosim.kernels.radiance`), the slots reduced to pixels and checked, and the pixels
committed to the accumulators, or merged into several jobs' moments (Chan et al.).
:func:`accumulate_kernel` takes several frames per call. Launched by
:mod:`radiosim.kernels.launch`.
"""

from __future__ import annotations

import numba
import numpy as np

from radiosim.kernels.codes import (SIGNAL_INDEX, SIGNAL_MAP, SIGNAL_NONE, SIGNAL_SCALAR,
                                    STATUS_BELOW_TABLE)
from radiosim.kernels.intrinsics import FRAME_DTYPES, INF, INNER, JIT
from radiosim.kernels.radiance import _signal_row, _signal_rows
from radiosim.kernels.sweeps import CHUNK, MAX_ROWS, _gather, _lin

__all__ = ["accumulate_kernel", "ACCUMULATE_KERNELS"]


@numba.njit(**INNER)
def _setup_row(reference, i, slot_runs, with_signal, ce, a3):
    """Start pixel row i: ce = the reference c of each slot's pixel (run by run: slots
    ``slot_runs[r, 0]`` to ``slot_runs[r, 1] − 1`` belong to pixel ``slot_runs[r, 2]``), the
    signal cleared (the row's first sweep writes the other accumulators)."""
    for r in range(slot_runs.shape[0]):
        c = reference[i, slot_runs[r, 2]]
        for k in range(slot_runs[r, 0], slot_runs[r, 1]):
            ce[k] = c
    if with_signal:
        for k in range(ce.size):
            a3[k] = 0.0


@numba.njit(**INNER)
def _pixel_done(j, v1, v2, v3, m, n, t_low, t_high, s1, s2, s3, sm):
    """Store pixel j's sums and maximum (m, n: its extremes) and return its status bits: 1 a
    bad sample (NaN in Σ w (T − c), +inf, ≤ 0 K), 2 one below ``t_low``, 4 one above
    ``t_high``."""
    s1[j], s2[j], s3[j], sm[j] = v1, v2, v3, m
    bad = np.int64(n <= 0.0) | np.int64(m == INF) | np.int64(v1 != v1)
    return bad | (np.int64(n < t_low) << 1) | (np.int64(m > t_high) << 2)


@numba.njit(**INNER)
def _pixel_sums(a1, a2, a3, am, an, slot_weight, slot_of_piece, col_bounds, identity,
                with_signal, t_low, t_high, s1, s2, s3, sm):
    """Per pixel j: s1, s2, s3 = Σ w a1, Σ w a2, Σ w a3 and sm = max am over the slots of its
    pieces (``identity``: slot q is piece q), in one pass; returns the OR of the pixels'
    status bits (:func:`_pixel_done`). The slot update is written out here and in
    :func:`_pixel_sums_regular`: as a shared function returning a tuple it made the
    reductions a third slower."""
    n_pixels = col_bounds.size - 1
    status = 0
    for j in range(n_pixels):  # one pass over the slots the pixels' pieces read
        v1 = 0.0
        v2 = 0.0
        v3 = 0.0
        first = col_bounds[j]
        k = first if identity else slot_of_piece[first]
        m = am[k]  # extremes (float64: a float32 sample widened exactly)
        n = an[k]
        for q in range(first, col_bounds[j + 1]):
            k = q if identity else slot_of_piece[q]
            w = slot_weight[k]
            v1 += a1[k] * w
            v2 += a2[k] * w
            if with_signal:
                v3 += a3[k] * w
            a = am[k]
            m = a if a > m else m
            a = an[k]
            n = a if a < n else n
        status |= _pixel_done(j, v1, v2, v3, m, n, t_low, t_high, s1, s2, s3, sm)
    return status


@numba.njit(**INNER)
def _pixel_sums_regular(a1, a2, a3, am, an, slot_weight, slot_of_piece, col_bounds, identity,
                        with_signal, t_low, t_high, s1, s2, s3, sm):
    """:func:`_pixel_sums` for a layout whose pixels' interior pieces (all but the first and
    the last) lie on consecutive slots with one weight (whole samples): the interior is summed
    unweighted and weighted once, in a short loop without indirection."""
    n_pixels = col_bounds.size - 1
    status = 0
    one = np.uint64(1)
    for j in range(n_pixels):  # one pass over the slots the pixels' pieces read
        first = col_bounds[j]
        stop = col_bounds[j + 1]
        # A pixel's first and last pieces have their own weights (edges inside samples); its
        # interior pieces are whole samples of one weight, on consecutive slots.
        k = first if identity else slot_of_piece[first]
        w = slot_weight[k]
        v1 = a1[k] * w
        v2 = a2[k] * w
        v3 = a3[k] * w if with_signal else 0.0
        m = am[k]  # extremes (float64: a float32 sample widened exactly)
        n = an[k]
        if stop - first > one:
            k = stop - one if identity else slot_of_piece[stop - one]
            w = slot_weight[k]
            v1 += a1[k] * w
            v2 += a2[k] * w
            if with_signal:
                v3 += a3[k] * w
            a = am[k]
            m = a if a > m else m
            a = an[k]
            n = a if a < n else n
        if stop - first > np.uint64(2):
            lo = first + one if identity else slot_of_piece[first + one]
            hi = lo + (stop - first - np.uint64(2))
            t1 = 0.0
            t2 = 0.0
            t3 = 0.0
            for q in range(lo, hi):  # (LLVM takes the test on with_signal out of the loop)
                t1 += a1[q]
                t2 += a2[q]
                if with_signal:
                    t3 += a3[q]
                a = am[q]
                m = a if a > m else m
                a = an[q]
                n = a if a < n else n
            w = slot_weight[lo]
            v1 += t1 * w
            v2 += t2 * w
            v3 += t3 * w
        status |= _pixel_done(j, v1, v2, v3, m, n, t_low, t_high, s1, s2, s3, sm)
    return status


@numba.njit(**INNER, inline="always")
def _row_sums(a1, a2, a3, am, an, cols, with_signal, t_low, t_high, s1, s2, s3, sm):
    """Add the pieces to the row's pixels and check the slots they read (NaN propagates into
    a1, +inf into am, T ≤ 0 and T below the table show in an), in one pass
    (:func:`_pixel_sums_regular` or :func:`_pixel_sums`, as ``cols.layout`` allows: bit 0, slot
    q is piece q; bit 1, each pixel's interior pieces lie on consecutive slots with one
    weight); returns the pixels' status bits. ``cols``:
    :class:`~radiosim.kernels.bundles.ColumnSlots`; s1, s2, s3, sm: per-pixel sums."""
    layout = cols.layout
    identity = (layout & 1) != 0
    if (layout & 2) != 0:
        return _pixel_sums_regular(a1, a2, a3, am, an, cols.weight, cols.of_piece, cols.bounds,
                                   identity, with_signal, t_low, t_high, s1, s2, s3, sm)
    return _pixel_sums(a1, a2, a3, am, an, cols.weight, cols.of_piece, cols.bounds, identity,
                       with_signal, t_low, t_high, s1, s2, s3, sm)


@numba.njit(**INNER)
def _commit_row(i, n_pixels, acc, members, f, with_signal, s1, s2, s3, sm, status):
    """Commit pixel row ``i``'s sums (s1, s2, s3 and the maximum sm of its ``n_pixels``
    pixels, :func:`_row_sums`) unless the row has a status (``status``: its bits). Returns the
    row's status.

    Without ``members.merge``: dev, sq, signal += time_weight × the frame's Σ w (T − c),
    Σ w (T − c)², Σ w S, and tmax = max(tmax, max T) (row i of ``acc``,
    :class:`~radiosim.kernels.bundles.Accumulators`). With it
    (:class:`~radiosim.kernels.bundles.Merging`, frame ``f``'s row of weights): the frame's
    mean m = c + Σ w (T − c) and variance v = max(Σ w (T − c)² − (Σ w (T − c))², 0) are merged
    into every member job b of weight w_b = weight[f, b] > 0 (Chan et al.: δ = m − mean,
    M2 += w_b v + δ² n_b w_b / n', mean += δ w_b / n', n' = n_b + w_b; the maximum), unless
    ``moments`` is off; signals add signal_weight[f, b] × Σ w S; and the reference row becomes
    m (the next frame's c). With ``members.keep_moments``, a row whose only status is samples
    below the table merges its moments and reference all the same (not its signal) and
    returns that status."""
    reference = acc.reference
    kept = (status == STATUS_BELOW_TABLE and members.merge and members.moments
            and members.keep_moments)
    if status and not kept:
        return status
    if not members.merge:  # the accumulators indexed [i, j], [b, i, j]: no row views (a view
        # of an array is a reference count, an atomic operation the threads would share)
        time_weight = acc.time_weight
        dev = acc.dev
        sq = acc.sq
        tmax = acc.tmax
        signal = acc.signal
        for j in range(n_pixels):
            dev[i, j] += time_weight * s1[j]
            sq[i, j] += time_weight * s2[j]
            m = tmax[i, j]
            tmax[i, j] = sm[j] if sm[j] > m else m
        if with_signal:
            for j in range(n_pixels):
                signal[i, j] += time_weight * s3[j]
        return 0
    member_weight = members.weight
    member_count = members.count
    signal_weight = members.signal_weight
    m_mean = members.mean
    m_m2 = members.m2
    m_max = members.max
    m_signal = members.signal
    for b in range(member_weight.shape[1]):
        w = signal_weight[f, b]
        if with_signal and w > 0.0 and not kept:
            for j in range(n_pixels):
                m_signal[b, i, j] += w * s3[j]
    if members.moments:
        for j in range(n_pixels):  # the frame's mean and variance over each footprint
            v = s2[j] - s1[j] * s1[j]
            s2[j] = v if v > 0.0 else 0.0
            s1[j] = reference[i, j] + s1[j]
        for b in range(member_weight.shape[1]):
            w = member_weight[f, b]
            if w > 0.0:
                n = member_count[f, b]
                total = n + w
                share = w / total
                spread = n * w / total
                for j in range(n_pixels):
                    delta = s1[j] - m_mean[b, i, j]
                    m_m2[b, i, j] += w * s2[j] + delta * delta * spread
                    m_mean[b, i, j] += delta * share
                    m = m_max[b, i, j]
                    m_max[b, i, j] = sm[j] if sm[j] > m else m
        for j in range(n_pixels):
            reference[i, j] = s1[j]
    return status  # 0, or STATUS_BELOW_TABLE for a row whose signal the caller redoes


def accumulate_kernel(b, n_blocks, start, frames, rows, cols, acc, members, tables, emissivity,
                      buffers, status):
    """Block ``b`` of the frames' pixel rows in ``n_blocks`` contiguous blocks, one per thread
    (:func:`~radiosim.kernels.threads.run_blocks`; block b uses row b of ``buffers``); frame
    f starts at ``frames.base[f * frames.frame_stride]`` (``frames.base32`` for float32 frames:
    ``frames.narrow``), and the merging weights (``members``) and ``status`` have one row per
    frame. The block takes frames start[b] … n_frames − 1 of its rows, one after the other,
    without waiting for the other blocks (no barrier per frame), and stops after its first
    frame with a status. Returns that frame, or n_frames. The bundles:
    :mod:`radiosim.kernels.bundles`.

    One compiled entry point serves both frame dtypes. What reads samples takes both arrays
    and reads the float32 one where ``narrow``, widening each sample (exact): the sweeps
    (:func:`~radiosim.kernels.sweeps._lin`) and the radiance pass (:func:`_signal_rows`,
    :func:`_signal_row`), each with a loop of its own per dtype, and here the duplicate slots'
    gathers and the index-map rows' slices. Everything after the samples is float64.

    Row b of the :class:`~radiosim.kernels.bundles.ThreadBuffers` (``buffers``) holds the
    block's buffers for the duplicate slots' samples, each written through the first array and
    read through the second (a read-only view of the same memory, so that the gathered frame
    rows have the type of float64 frame rows: one compilation serves the frame's rows and the
    gathered ones), and the running maximum and minimum per slot (float64).

    Each pixel row is swept along the columns in chunks of CHUNK slots, up to MAX_ROWS sample
    rows per sweep (all of them, for pixels of up to MAX_ROWS pieces), so the accumulators are
    read and written once per chunk while the frame's rows stream through."""
    n_frames = frames.n_frames
    narrow = frames.narrow
    frame_stride = frames.frame_stride
    row_length = frames.row_length
    n_rows = rows.bounds.size - 1
    first_row = b * n_rows // n_blocks
    stop_row = (b + 1) * n_rows // n_blocks
    row_source = rows.source
    row_weight = rows.weight
    row_bounds = rows.bounds
    slot_weight = cols.weight
    dup_source = cols.dup_source
    reference = acc.reference
    mode = emissivity.mode
    grey = emissivity.grey
    grey_map = emissivity.grey_map
    index_map = emissivity.index_map
    map_length = emissivity.map_length
    use_map = emissivity.use_map
    rows_w = buffers.rows_w[b]
    rows_r = buffers.rows_r[b]
    grey_w = buffers.grey_w[b]
    grey_r = buffers.grey_r[b]
    index_w = buffers.index_w[b]
    index_r = buffers.index_r[b]
    am = buffers.am[b]
    an = buffers.an[b]
    n_slots = slot_weight.size
    ns = cols.n_samples
    n_dups = dup_source.size
    n_pixels = cols.bounds.size - 1
    with_signal = mode != SIGNAL_NONE
    # The slot accumulators in one buffer, their starts 576 bytes apart modulo 4096: loads of
    # one and stores to another never alias in the address bits the CPU compares first.
    # The Planck pass's scratch (interval, position: per chunk) likewise, 4 kB each.
    stride = (max(n_slots, 2 * CHUNK) + 511) // 512 * 512 + 72
    slots = np.empty(6 * stride)
    a1 = slots[:n_slots]
    a2 = slots[stride:stride + n_slots]
    a3 = slots[2 * stride:2 * stride + n_slots]
    ce = slots[3 * stride:3 * stride + n_slots]
    u = slots[4 * stride:4 * stride + 2 * CHUNK]
    interval = slots[5 * stride:5 * stride + 2 * CHUNK].view(np.uint64)
    value = np.empty(CHUNK)
    sums = np.empty(CHUNK)  # a sweep's Σ w (T − c) per slot (sweeps._lin)
    factor = np.empty(CHUNK)
    s1 = np.empty(n_pixels)
    s2 = np.empty(n_pixels)
    s3 = np.empty(n_pixels)
    sm = np.empty(n_pixels)
    table = tables.entry_table[0]
    one_table = mode == SIGNAL_SCALAR or mode == SIGNAL_MAP
    t_low = tables.t_min[table] if one_table else -INF
    t_high = tables.t_max[table] if one_table else INF
    # SIGNAL_SCALAR and SIGNAL_MAP: the one table's rows and grid.
    table_rows = tables.coef[np.uint64(tables.offset[table]) * np.uint64(4):]
    table_key0 = tables.key0[table]
    table_shift = np.uint64(tables.shift[table])
    table_last = np.uint64(tables.last[table])
    # Slot bounds and offsets as uint64 (the sweeps index with them).
    zero = np.uint64(0)
    samples_u = np.uint64(ns)
    slots_u = np.uint64(n_slots)
    chunk = np.uint64(CHUNK)
    dup_rows = rows_r.reshape(-1)
    size = np.uint64(rows_r.shape[1])
    dup_offsets = np.empty(MAX_ROWS, np.uint64)
    for h in range(MAX_ROWS):
        dup_offsets[h] = np.uint64(h) * size - samples_u
    # A sweep's sample rows: their offsets in the frame (o) and in the grey map (mo), and their
    # weights (ws); entries past its n rows repeat the last (the sweeps never read them).
    o = np.empty(MAX_ROWS, np.uint64)
    mo = np.empty(MAX_ROWS, np.uint64)
    ws = np.empty(MAX_ROWS)
    # The pixel rows' pass, frame by frame, written here (numba's inlining of a helper would
    # copy its IR and type it again: about a second of compile).
    for f in range(start[b], n_frames):
        # Frame f's samples, rows row_length apart: float64 (``frame``) or float32 (``frame32``,
        # when ``narrow``), each read in place; the other, sliced from a one-element
        # placeholder, is never read.
        frame = frames.base[f * frame_stride:]
        frame32 = frames.base32[f * frame_stride:]
        frame_status = status[f]  # per pixel row
        for i in range(first_row, stop_row):
            _setup_row(reference, i, cols.runs, with_signal, ce, a3)
            row_status = np.int64(0)  # not a literal: one compilation of _commit_row
            p = row_bounds[i]
            first_p = p
            stop = row_bounds[i + 1]
            while p < stop:
                n = min(MAX_ROWS, stop - p)
                for h in range(MAX_ROWS):  # offsets as uint64
                    source = row_source[p + min(h, n - 1)]
                    o[h] = np.uint64(source * row_length)
                    mo[h] = np.uint64(source * map_length)
                    ws[h] = row_weight[p + min(h, n - 1)]
                # Part 0: the sample slots, along the frame's rows; part 1: the duplicate
                # slots, along rows gathered into the buffers (row h at h · size − n_samples,
                # so that slot q reads sample q − n_samples of it).
                for part in range(2 if n_dups else 1):
                    if part == 1:  # gathered rows in float64 (a float32 sample widens exactly)
                        for h in range(n):
                            if narrow:
                                _gather(frame32[o[h]:], dup_source, rows_w[h])
                            else:
                                _gather(frame[o[h]:], dup_source, rows_w[h])
                    first, end = (zero, samples_u) if part == 0 else (samples_u, slots_u)
                    src = frame if part == 0 else dup_rows
                    narrow_src = narrow and part == 0  # the float32 frame read in place
                    offsets = o if part == 0 else dup_offsets
                    for lo in range(first, end, chunk):
                        hi = min(end, lo + chunk)
                        _lin(n, p == first_p, lo, hi, frame32, src, narrow_src, offsets, ws, ce,
                             a1, a2, am, an, sums)
                        if with_signal and part == 0 and mode != SIGNAL_INDEX:
                            _signal_rows(n, lo, hi, frame32, src, narrow_src, offsets, ws,
                                         grey_map, mo, use_map, grey, table_rows, table_key0,
                                         table_shift, table_last, interval, u, a3)
                        elif with_signal:
                            lo_i, hi_i = np.int64(lo), np.int64(hi)
                            for h in range(n):
                                m_off = row_source[p + h] * map_length
                                if part == 0:
                                    x = frame[o[h] + lo:]
                                    x32 = frame32[o[h] + lo:]
                                    g = grey_map[m_off + lo_i:]
                                    e = index_map[m_off + lo_i:]
                                else:
                                    x = rows_r[h][lo_i - ns:]
                                    x32 = frame32  # not read
                                    dups = dup_source[lo_i - ns:hi_i - ns]
                                    if use_map or mode != SIGNAL_INDEX:  # scalar: the ones
                                        _gather(grey_map[m_off:], dups, grey_w[:hi_i - lo_i])
                                    if mode == SIGNAL_INDEX:
                                        _gather(index_map[m_off:], dups, index_w[:hi_i - lo_i])
                                    g = grey_r
                                    e = index_r
                                row_status |= _signal_row(
                                    x32, x, narrow_src, g, e, slot_weight[lo_i:hi_i], ws[h],
                                    mode, grey, use_map, tables, interval, u, value, factor,
                                    a3[lo_i:hi_i])
                p += n
            row_status |= _row_sums(a1, a2, a3, am, an, cols, with_signal, t_low, t_high, s1, s2,
                                    s3, sm)
            frame_status[i] = _commit_row(i, n_pixels, acc, members, f, with_signal, s1, s2, s3,
                                          sm, row_status)
        bad = 0
        for i in range(first_row, stop_row):
            bad |= frame_status[i]
        if bad != 0:
            return f
    return n_frames


accumulate_kernel = numba.njit(**JIT)(accumulate_kernel)
#: The kernel each frame dtype launches ({"float32": …, "float64": …}): one compiled entry
#: point for both (:class:`~radiosim.kernels.bundles.FrameBlock` carries either dtype).
ACCUMULATE_KERNELS = {dtype: accumulate_kernel for dtype in FRAME_DTYPES}

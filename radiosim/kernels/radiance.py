"""
The radiance pass of the compiled kernels: each sample's interval and position in its
:class:`~radiosim.radiometry.BandRadianceTable` (bits of T, no division or logarithm), its
cubic (eight samples at a time by :mod:`radiosim.kernels.intrinsics`), weighted by the grey
factor, grey map or indexed entry (:mod:`radiosim.kernels.codes` ``SIGNAL_*``) and added to
the signal slots.
"""

from __future__ import annotations

import numba
import numpy as np

from radiosim.kernels.codes import (SIGNAL_MAP, SIGNAL_SCALAR, STATUS_ABOVE_TABLE,
                                    STATUS_BAD_INDEX, STATUS_BELOW_TABLE)
from radiosim.kernels.intrinsics import (INNER, JIT, _cubic8, _cubic8_grey, _cubic8_map,
                                         _cubic8_pair, _fma)
from radiosim.kernels.sweeps import CHUNK

__all__ = ["cubic", "cubic_from_python"]


def _cubic_rows(coef, interval, position, out, n):
    """out[q] = the cubic of row interval[q] of ``coef`` at position[q], q < n (eight at a time
    by :func:`_cubic8`, the rest one by one with the same operations)."""
    q = 0
    while q + 8 <= n:
        _cubic8(coef, interval, position, out, 0, 1.0, 1.0, out, 0, q)
        q += 8
    for k in range(q, n):
        out[k] = _cubic1(coef, interval[k], position[k])


#: :func:`_cubic_rows` as the kernels call it (no Python wrapper to compile), and as Python
#: calls it (the tests).
cubic = numba.njit(**INNER)(_cubic_rows)
cubic_from_python = numba.njit(**dict(JIT, cache=False))(_cubic_rows)


@numba.njit(**INNER)
def _locate(t, key0, shift, node_mask, last):
    """Interval index k and d = T − T_k [K] of a sample T [K] (float64): k = (bits(T) >> shift)
    − key0, clamped to ``last`` unsigned (a sample below the table, ≤ 0 or NaN wraps round and
    reads the last row: the checks flag it), and d = T − (bits(T) & node_mask). Inside the
    table's range this is :meth:`BandRadianceTable.evaluate_reference`'s interval and position,
    exactly. ``shift``, ``node_mask``, ``last``: uint64."""
    bits = np.float64(t).view(np.uint64)
    k = (bits >> shift) - np.uint64(key0)
    return (k if k < last else last), t - np.uint64(bits & node_mask).view(np.float64)


@numba.njit(**INNER)
def _cubic1(coef, i, r):
    """The cubic of row i of ``coef`` at r, as one lane of :func:`_cubic8`: Horner with fused
    multiply-adds, ((a r + b) r + c) r + d each step rounded once."""
    i = i * np.uint64(4)
    return _fma(_fma(_fma(coef[i], r, coef[i + 1]), r, coef[i + 2]), r, coef[i + 3])


@numba.njit(**INNER)
def _signal_one(src32, src, narrow, xo, g, go, w, use_map, grey, coef, key0, shift, node_mask,
                last, interval, u, a3, lo, hi):
    """a3[q] += w · S(src[xo + q]) (``src32``, float32, when ``narrow``: the samples widened)
    for the slots lo ≤ q < hi of one sample row (modes SIGNAL_SCALAR and SIGNAL_MAP:
    S = L(T) · grey, or L(T) · (grey · g[go + q]) with ``g`` the grey map). Two loops: the
    intervals and positions (:func:`_locate`, vectorised), into the scratch ``interval``
    and ``u`` (from 0); then the cubics, accumulated eight at a time (:func:`_cubic8_grey`,
    :func:`_cubic8_map`), the rest one by one with the same operations. ``coef``: the table's rows;
    offsets, bounds, ``last``, ``shift``, ``node_mask``: uint64."""
    nq = hi - lo
    x0 = xo + lo
    if narrow:
        for q in range(nq):
            interval[q], u[q] = _locate(np.float64(src32[x0 + q]), key0, shift, node_mask, last)
    else:
        for q in range(nq):
            interval[q], u[q] = _locate(np.float64(src[x0 + q]), key0, shift, node_mask, last)
    q = np.uint64(0)
    eight = np.uint64(8)
    if use_map:
        g0 = go + lo
        while q + eight <= nq:
            _cubic8_map(coef, interval, u, g, g0, w, grey, a3, lo, q)
            q += eight
        for k in range(q, nq):
            a3[lo + k] += w * (_cubic1(coef, interval[k], u[k]) * (grey * g[g0 + k]))
    else:
        wg = w * grey
        while q + eight <= nq:
            _cubic8_grey(coef, interval, u, g, lo, wg, grey, a3, lo, q)
            q += eight
        for k in range(q, nq):
            a3[lo + k] += _cubic1(coef, interval[k], u[k]) * wg


@numba.njit(**INNER, inline="always")
def _signal_rows(n, lo, hi, src32, src, narrow, o, ws, g, go, use_map, grey, coef, key0, shift,
                 last, interval, u, a3):
    """a3[q] += Σₕ ws[h] · S(src[o[h] + q]) (``src32`` when ``narrow``) over the sample rows
    h < n of a sweep and its slots lo ≤ q < hi (modes SIGNAL_SCALAR and SIGNAL_MAP; grey map
    row h at ``g[go[h]:]``): with a grey factor, two rows at a time (:func:`_signal_two`), else
    row by row (:func:`_signal_one`).
    ``interval`` and ``u``: scratch of two chunks."""
    node_mask = ~((np.uint64(1) << shift) - np.uint64(1))
    h = 0
    if not use_map:
        while h + 1 < n:
            _signal_two(src32, src, narrow, o[h], o[h + 1], ws[h] * grey, ws[h + 1] * grey,
                        coef, key0, shift, node_mask, last, interval, u, a3, lo, hi)
            h += 2
    while h < n:
        _signal_one(src32, src, narrow, o[h], g, go[h], ws[h], use_map, grey, coef, key0, shift,
                    node_mask, last, interval, u, a3, lo, hi)
        h += 1


@numba.njit(**INNER)
def _signal_two(src32, src, narrow, xo, yo, wx, wy, coef, key0, shift, node_mask, last,
                interval, u, a3, lo, hi):
    """a3[q] += wx · L(src[xo + q]) + wy · L(src[yo + q]) (``src32`` when ``narrow``) for
    lo ≤ q < hi (two sample rows of a grey scene, weights times the grey factor): the
    intervals and positions of both rows into the scratch (the second's from CHUNK on), then
    their cubics eight at a time (:func:`_cubic8_pair`), the rest one by one with the same
    operations."""
    nq = hi - lo
    second = np.uint64(CHUNK)
    x0 = xo + lo
    y0 = yo + lo
    if narrow:
        for q in range(nq):
            interval[q], u[q] = _locate(np.float64(src32[x0 + q]), key0, shift, node_mask, last)
        for q in range(nq):
            interval[second + q], u[second + q] = _locate(np.float64(src32[y0 + q]), key0,
                                                          shift, node_mask, last)
    else:
        for q in range(nq):
            interval[q], u[q] = _locate(np.float64(src[x0 + q]), key0, shift, node_mask, last)
        for q in range(nq):
            interval[second + q], u[second + q] = _locate(np.float64(src[y0 + q]), key0,
                                                          shift, node_mask, last)
    q = np.uint64(0)
    eight = np.uint64(8)
    while q + eight <= nq:
        _cubic8_pair(coef, interval, u, second, wx, wy, a3, lo, q)
        q += eight
    for k in range(q, nq):
        a3[lo + k] += _fma(_cubic1(coef, interval[second + k], u[second + k]), wy,
                           _cubic1(coef, interval[k], u[k]) * wx)


@numba.njit(**INNER)
def _signal_row(x32, x, narrow, g, e, used, w, mode, grey, use_map, tables, interval, u, value,
                factor, a3):
    """a3 += w · S(T) along one row of pieces ``x`` (``x32``, float32, when ``narrow``; grey
    map row ``g``, index map row ``e``), with S = L(T) · grey (SIGNAL_SCALAR),
    L(T) · (grey · map) (SIGNAL_MAP) or L_e(T) · grey_e (· map) with e from the index map
    (SIGNAL_INDEX); L the cubic of the sample's table (a row of the flat
    ``coef``, from the table's ``offset``) at its interval and position (:func:`_locate`). Modes
    1–2: :func:`_signal_one` (the rows of the sample slots go through :func:`_signal_rows` instead,
    a sweep at a time); SIGNAL_INDEX: three loops, the entry, checks and interval per sample, the
    cubics (:func:`cubic`, eight samples at a time), the accumulation. Returns the status bits of
    the row's per-sample checks (SIGNAL_INDEX: table range and index; SIGNAL_SCALAR and SIGNAL_MAP
    check the range from the row's min and max instead; ``used`` > 0 marks the slots a piece reads,
    the only ones checked). ``tables``: :class:`~radiosim.kernels.bundles.PackedTables`;
    ``interval``, ``u``, ``value``, ``factor``: scratch."""
    coef = tables.coef
    key0 = tables.key0
    shift = tables.shift
    last = tables.last
    offset = tables.offset
    t_min = tables.t_min
    t_max = tables.t_max
    entry_table = tables.entry_table
    entry_grey = tables.entry_grey
    nq = a3.size
    status = 0
    if mode == SIGNAL_SCALAR or mode == SIGNAL_MAP:
        j = entry_table[0]
        s = np.uint64(shift[j])
        node_mask = ~((np.uint64(1) << s) - np.uint64(1))
        _signal_one(x32, x, narrow, np.uint64(0), g, np.uint64(0), w, use_map, grey,
                    coef[np.uint64(offset[j]) * np.uint64(4):], key0[j], s, node_mask,
                    np.uint64(last[j]), interval, u, a3, np.uint64(0), np.uint64(nq))
        return status
    else:
        n_entries = entry_table.size
        n_low = 0
        n_high = 0
        n_index = 0
        for q in range(nq):
            t = np.float64(x32[q]) if narrow else np.float64(x[q])
            h = np.int64(e[q])
            checked = np.int64(used[q] > 0.0)
            n_index += checked * (np.int64(h < 0) + np.int64(h >= n_entries))
            h = h if h >= 0 else 0
            h = np.uint64(h if h < n_entries else 0)
            j = np.uint64(entry_table[h])
            n_low += checked * np.int64(t < t_min[j])
            n_high += checked * np.int64(t > t_max[j])
            factor[q] = entry_grey[h] * g[q] if use_map else entry_grey[h] * grey
            s = np.uint64(shift[j])
            i, r = _locate(t, key0[j], s, ~((np.uint64(1) << s) - np.uint64(1)),
                           np.uint64(last[j]))
            interval[q] = i + np.uint64(offset[j])
            u[q] = r
        if n_low:
            status |= STATUS_BELOW_TABLE
        if n_high:
            status |= STATUS_ABOVE_TABLE
        if n_index:
            status |= STATUS_BAD_INDEX
        cubic(coef, interval, u, value, nq)
        for q in range(nq):
            a3[q] += w * (value[q] * factor[q])
        return status

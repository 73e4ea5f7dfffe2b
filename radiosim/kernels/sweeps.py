"""
The row sweeps: up to :data:`MAX_ROWS` sample rows swept at once along the columns into the
slot accumulators of a pixel row (Σ w (T − c), Σ w (T − c)², maximum, minimum): :func:`_lin`
takes them four at a time (:func:`_rows4`), then one at a time (:func:`_rows1`), each a loop
along the columns that the compiler vectorises; the partial sum Σ w (T − c) of the sweep runs
in a scratch row, so every slot's sums take the rows in the same order, one rounding each,
whatever their number.
"""

from __future__ import annotations

import numba
import numpy as np

from radiosim.kernels.intrinsics import INF, JIT, _fma

__all__ = ["MAX_ROWS", "CHUNK"]

# Columns are swept in sample space: the helpers run along contiguous rows of samples (the
# region's columns 0 … extent − 1), accumulating into one slot per sample, which holds the first
# column piece reading that sample. A sample read by a second piece (a pixel edge inside it)
# gets a second slot after the samples' ("duplicate" slots), filled from rows of those samples
# gathered into small per-thread buffers. Samples no piece reads (gaps of a fill factor < 1)
# have slots of weight 0, which nothing reads. Index arrays are unsigned (uintp), so that
# indexing skips numba's negative-index wraparound.


@numba.njit(**JIT)
def _gather(row, cols, out):
    """out[q] = row[cols[q]]."""
    for q in range(out.size):
        out[q] = row[cols[q]]


#: Most sample rows one sweep along the columns takes (a pixel row of more pieces takes several
#: sweeps): each sweep reads and writes the column accumulators once.
MAX_ROWS = 12
#: Slots per sweep: the accumulators of a chunk stay in the L1 cache while its rows stream by.
CHUNK = 512


@numba.njit(**JIT)
def _rows4(lo, hi, src, o0, o1, o2, o3, w0, w1, w2, w3, ce, s, a2, am, an):
    """Four sample rows (row h: ``src[oh + q]``, weight ``wh``) into the slots lo ≤ q < hi:
    s[q − lo] += w (T − c) row by row, a2[q] += w (T − c)² (fused multiply-adds, row by row),
    am[q] = max(am[q], T), an[q] = min(an[q], T) in the frame's own dtype (exact). Offsets and
    bounds are uint64: indexed, not sliced (a slice is a reference count, an atomic operation
    both threads would share)."""
    for q in range(lo, hi):
        c = ce[q]
        x0 = src[o0 + q]
        x1 = src[o1 + q]
        x2 = src[o2 + q]
        x3 = src[o3 + q]
        d0 = np.float64(x0) - c
        d1 = np.float64(x1) - c
        d2 = np.float64(x2) - c
        d3 = np.float64(x3) - c
        e0 = w0 * d0
        e1 = w1 * d1
        e2 = w2 * d2
        e3 = w3 * d3
        k = q - lo
        s[k] = s[k] + e0 + e1 + e2 + e3
        a2[q] = _fma(e3, d3, _fma(e2, d2, _fma(e1, d1, _fma(e0, d0, a2[q]))))
        m = am[q]
        m = x0 if x0 > m else m
        m = x1 if x1 > m else m
        m = x2 if x2 > m else m
        am[q] = x3 if x3 > m else m
        n = an[q]
        n = x0 if x0 < n else n
        n = x1 if x1 < n else n
        n = x2 if x2 < n else n
        an[q] = x3 if x3 < n else n


@numba.njit(**JIT)
def _rows1(lo, hi, src, o0, w0, ce, s, a2, am, an):
    """One sample row as :func:`_rows4` takes four."""
    for q in range(lo, hi):
        x0 = src[o0 + q]
        d0 = np.float64(x0) - ce[q]
        e0 = w0 * d0
        k = q - lo
        s[k] = s[k] + e0
        a2[q] = _fma(e0, d0, a2[q])
        m = am[q]
        am[q] = x0 if x0 > m else m
        n = an[q]
        an[q] = x0 if x0 < n else n


@numba.njit(**JIT)
def _lin(n, first, lo, hi, src, o, ws, ce, a1, a2, am, an, s):
    """The sweep of ``n`` (1 … MAX_ROWS) sample rows (row h: ``src[o[h] + q]``, weight
    ``ws[h]``) into the column accumulators of slots lo ≤ q < hi: a1 += Σₕ w (T − c) (the
    rows' sum first, in scratch ``s``, then added), a2 += Σₕ w (T − c)², am = max(am, T),
    an = min(an, T); with ``first`` (a pixel row's first sweep) the accumulators start from
    0, 0, −∞ and +∞ instead of their contents."""
    for k in range(hi - lo):
        s[k] = 0.0
    if first:
        for q in range(lo, hi):
            a2[q] = 0.0
            am[q] = -INF
            an[q] = INF
    h = 0
    while h + 4 <= n:
        _rows4(lo, hi, src, o[h], o[h + 1], o[h + 2], o[h + 3], ws[h], ws[h + 1], ws[h + 2],
               ws[h + 3], ce, s, a2, am, an)
        h += 4
    while h < n:
        _rows1(lo, hi, src, o[h], ws[h], ce, s, a2, am, an)
        h += 1
    if first:
        for q in range(lo, hi):
            a1[q] = s[q - lo]
    else:
        for q in range(lo, hi):
            a1[q] += s[q - lo]

"""
The row sweeps: up to :data:`MAX_ROWS` sample rows swept at once along the columns into the
slot accumulators of a pixel row (Σ w (T − c), Σ w (T − c)², maximum, minimum). :func:`_lin`
takes them in blocks of :data:`BLOCKS` rows (eight, four, then one at a time: ``_rows8``,
``_rows4``, ``_rows1``), each block a loop along the columns that the compiler vectorises; the
sweep's partial sum Σ w (T − c) runs in a scratch row, so every slot's sums take the rows in the
same order, one rounding each, however the rows are grouped into blocks.
"""

from __future__ import annotations

import numba
import numpy as np

from radiosim.kernels.intrinsics import INF, INNER, _fma

__all__ = ["MAX_ROWS", "CHUNK", "BLOCKS"]

# Columns are swept in sample space: the helpers run along contiguous rows of samples (the
# region's columns 0 … extent − 1), accumulating into one slot per sample, which holds the first
# column piece reading that sample. A sample read by a second piece (a pixel edge inside it)
# gets a second slot after the samples' ("duplicate" slots), filled from rows of those samples
# gathered into small per-thread buffers. Samples no piece reads (gaps of a fill factor < 1)
# have slots of weight 0, which nothing reads. Index arrays are unsigned (uintp), so that
# indexing skips numba's negative-index wraparound.


@numba.njit(**INNER)
def _gather(row, cols, out):
    """out[q] = row[cols[q]]."""
    for q in range(out.size):
        out[q] = row[cols[q]]


#: Most sample rows one sweep along the columns takes (a pixel row of more pieces takes several
#: sweeps): each sweep reads and writes the column accumulators once.
MAX_ROWS = 12  # below 16: _lin takes one block of eight rows at most, from row 0
#: Slots per sweep: the accumulators of a chunk stay in the L1 cache while its rows stream by.
CHUNK = 512
#: The rows one loop along the columns takes at once, largest first (a sweep of n rows takes
#: as many of the largest as fit, then of the next): each loop reads and writes the slots'
#: sums once, so fewer loops cost less, and each size is one more compiled function.
BLOCKS = (8, 4, 1)


def _rows_source(k: int) -> str:
    """Source of ``_rows{k}``: k sample rows (row h: ``src[o{h} + q]``, weight ``w{h}``; read
    from ``src32``, float32, when ``narrow``) into the slots lo ≤ q < hi: s[q − lo] += w (T − c)
    row by row, a2[q] += w (T − c)² (fused multiply-adds, row by row), am[q] = max(am[q], T),
    an[q] = min(an[q], T) (float64 for either dtype: a float32 sample widens exactly). Two
    loops, one per frame dtype, the same operations: one compiled function reads either in
    place. Offsets and bounds are uint64: indexed, not sliced (a slice is a reference count,
    an atomic operation both threads would share)."""
    rows = range(k)
    lines = [f"def _rows{k}(lo, hi, src32, src, narrow, o, ws, h, ce, s, a2, am, an):"]
    lines += [f"    o{r} = o[h + {r}]" for r in rows] + [f"    w{r} = ws[h + {r}]" for r in rows]

    def loop(array):
        body = ["for q in range(lo, hi):", "    c = ce[q]"]
        body += [f"    x{r} = np.float64({array}[o{r} + q])" for r in rows]
        body += [f"    d{r} = x{r} - c" for r in rows]
        body += [f"    e{r} = w{r} * d{r}" for r in rows]
        body.append("    k = q - lo")
        body.append("    s[k] = s[k] + " + " + ".join(f"e{r}" for r in rows))
        square = "a2[q]"
        for r in rows:
            square = f"_fma(e{r}, d{r}, {square})"
        body.append(f"    a2[q] = {square}")
        body.append("    m = am[q]")
        body.append("    n = an[q]")
        for r in rows:
            body.append(f"    m = x{r} if x{r} > m else m")
            body.append(f"    n = x{r} if x{r} < n else n")
        body += ["    am[q] = m", "    an[q] = n"]
        return body

    body = ["if narrow:"] + ["    " + line for line in loop("src32")]
    body += ["else:"] + ["    " + line for line in loop("src")]
    return "\n".join(lines + ["    " + line for line in body]) + "\n"


def _make_blocks():
    # Compiled with this file's name, so that numba's on-disk cache finds (and invalidates)
    # them with the module; generated because each block size is its own unrolled loop body.
    namespace = {"np": np, "_fma": _fma, "__name__": __name__}
    exec(compile("".join(_rows_source(k) for k in BLOCKS), __file__, "exec"), namespace)
    return tuple(numba.njit(**INNER)(namespace[f"_rows{k}"]) for k in BLOCKS)


_rows8, _rows4, _rows1 = _make_blocks()


@numba.njit(**INNER, inline="always")
def _lin(n, first, lo, hi, src32, src, narrow, o, ws, ce, a1, a2, am, an, s):
    """The sweep of ``n`` (1 … MAX_ROWS) sample rows (row h: ``src[o[h] + q]``, weight
    ``ws[h]``; ``o`` and ``ws`` arrays of MAX_ROWS) into the column accumulators of slots
    lo ≤ q < hi: a1 += Σₕ w (T − c) (the rows' sum first, in scratch ``s``, then added),
    a2 += Σₕ w (T − c)², am = max(am, T), an = min(an, T) (float32 rows when ``narrow``:
    ``src32``, widened); with ``first`` (a pixel row's first sweep) the accumulators start
    from 0, 0, −∞ and +∞ instead of their contents. The same additions in the same order as
    one loop over all n rows per slot."""
    for k in range(hi - lo):
        s[k] = 0.0
    if first:
        for q in range(lo, hi):
            a2[q] = 0.0
            am[q] = -INF
            an[q] = INF
    # At most one block of eight (n ≤ MAX_ROWS < 16), rows 0 to 7: its first row a literal 0,
    # so the block's row offsets are static (10-20 % of the sweep's time) and _rows8 has one
    # compiled variant.
    h = 0
    if n >= 8:
        _rows8(lo, hi, src32, src, narrow, o, ws, 0, ce, s, a2, am, an)
        h = 8
    while h + 4 <= n:
        _rows4(lo, hi, src32, src, narrow, o, ws, h, ce, s, a2, am, an)
        h += 4
    while h < n:
        _rows1(lo, hi, src32, src, narrow, o, ws, h, ce, s, a2, am, an)
        h += 1
    if first:
        for q in range(lo, hi):
            a1[q] = s[q - lo]
    else:
        for q in range(lo, hi):
            a1[q] += s[q - lo]

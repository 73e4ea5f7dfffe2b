"""
The generated row sweeps: up to :data:`MAX_ROWS` sample rows swept at once along the columns
into the slot accumulators of a pixel row (Σ w (T − c), Σ w (T − c)², maximum, minimum), one
unrolled function per row count (``_lin1`` … ``_lin12``), dispatched by ``_lin``.
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


def _lin_source(k: int) -> str:
    """Source of ``_lin{k}``: k sample rows (row h: ``src[o[h] + q]``, weight ``ws[h]``) into
    the column accumulators of slots lo ≤ q < hi: a1 += Σ w (T − c), a2 += Σ w (T − c)² (fused
    multiply-adds), am = max(am, T), an = min(an, T), the maximum and minimum taken in the
    frame's own dtype (exact); with ``first`` (a pixel row's first sweep) the accumulators
    start from 0, 0, −∞ and +∞ instead of their contents (written, not read). Offsets and
    bounds are uint64: indexed, not sliced (a slice is a reference count, an atomic operation
    both threads would share)."""
    lines = [f"def _lin{k}(first, lo, hi, src, o, ws, ce, a1, a2, am, an):"]
    lines += [f"    o{h} = o[{h}]" for h in range(k)]
    lines += [f"    w{h} = ws[{h}]" for h in range(k)]
    for start in (True, False):
        lines.append("    if first:" if start else "    else:")
        body = ["for q in range(lo, hi):", "    c = ce[q]"]
        for h in range(k):
            body.append(f"    x{h} = src[o{h} + q]")
            body.append(f"    d{h} = np.float64(x{h}) - c")
            body.append(f"    e{h} = w{h} * d{h}")
        total = " + ".join(f"e{h}" for h in range(k))
        body.append(f"    a1[q] = {total}" if start else f"    a1[q] += {total}")
        square = "0.0" if start else "a2[q]"
        for h in range(k):
            square = f"_fma(e{h}, d{h}, {square})"
        body.append(f"    a2[q] = {square}")
        body.append("    m = x0")
        body.append("    n = m")
        for h in range(1, k):
            body.append(f"    m = x{h} if x{h} > m else m")
            body.append(f"    n = x{h} if x{h} < n else n")
        body.append("    o = -INF" if start else "    o = am[q]")
        body.append("    am[q] = m if m > o else o")
        body.append("    o = INF" if start else "    o = an[q]")
        body.append("    an[q] = n if n < o else o")
        lines += ["        " + line for line in body]
    return "\n".join(lines) + "\n"


def _lin_dispatch_source() -> str:
    """Source of ``_lin``: the sweep of ``n`` rows (1 … MAX_ROWS) by ``_lin{n}``."""
    lines = ["def _lin(n, first, lo, hi, src, o, ws, ce, a1, a2, am, an):"]
    for k in range(1, MAX_ROWS + 1):
        lines.append(f"    {'if' if k == 1 else 'elif'} n == {k}:")
        lines.append(f"        _lin{k}(first, lo, hi, src, o, ws, ce, a1, a2, am, an)")
    return "\n".join(lines) + "\n"


def _make_sweeps():
    # Compiled with this file's name, so that numba's on-disk cache finds (and invalidates) them
    # with the module; generated because each row count needs its own unrolled loop body.
    namespace = {"np": np, "_fma": _fma, "INF": INF, "__name__": __name__}
    source = "".join(_lin_source(k) for k in range(1, MAX_ROWS + 1)) + _lin_dispatch_source()
    exec(compile(source, __file__, "exec"), namespace)
    for k in range(1, MAX_ROWS + 1):
        namespace[f"_lin{k}"] = numba.njit(**JIT)(namespace[f"_lin{k}"])
    return numba.njit(**JIT)(namespace["_lin"]), [namespace[f"_lin{k}"] for k in
                                                    range(1, MAX_ROWS + 1)]


_lin, _LIN_SWEEPS = _make_sweeps()

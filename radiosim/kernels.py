"""
Compiled one-pass streaming kernels for the integrator's hot loop, with their numpy oracles.

Each frame of an integration window is read once: in one pass over its footprint pieces the
kernel :func:`accumulate` adds, per pixel, the time-weighted area means of T − c, of (T − c)²
and (optionally) of the response signal S(T) = ε·L(T), raises the per-pixel maximum of T, and
checks every sample it reads (finite, > 0 K, inside the radiance table). :func:`pixel_mean`
gives the per-pixel reference c from the first frame. The layout is the one of
:mod:`radiosim.integrator`: pieces of each axis (:class:`~radiosim.integrator.AxisFootprints`),
2-D piece weight = row weight × column weight, the frame region starting at each axis' first
piece sample (``span.start``).

Every kernel has a plain numpy implementation beside it (:func:`pixel_mean_reference`,
:func:`accumulate_reference`), written like the integrator's own arithmetic; they are the
tests' oracle (agreement to 1e-12 relative, the maximum exactly) and the path the kernel falls
back to for a frame holding samples colder than the radiance table, which get the exact
quadrature (:func:`~radiosim.radiometry.band_radiance`).

How the kernels are fast (see ``benchmarks/bench_kernels.py``):

-   pixel rows are split in one contiguous block per thread (``numba.prange``); a pixel row
    writes only its own output row, so there are no races, and the result does not depend on
    the number of threads. Several frames go in one call (:func:`accumulate_merged` with a
    3-D block): each thread takes its rows through all of them without waiting for the other
    (no barrier per frame), and stops at its first frame with a status; those are handled in
    frame order, and the stopped threads go on;
-   within a pixel row, the sample rows of its pieces are swept up to 12 at a time (all of a
    pixel row of up to 12 pieces; generated sweeps ``_lin1`` … ``_lin12``), in chunks of 512
    slots that stay in the L1 cache, along the
    columns, in sample space: one accumulator slot per sample (holding the first column piece
    that reads it), plus a slot per "duplicate" piece (a pixel edge inside a sample: the
    second piece reading it, filled from a small gathered row). The loops are contiguous and
    vectorised; float32 frames are read as float32 and widened per sample, never copied; rows
    are reached by uint64 offsets into the frame, not slices (a slice is a reference count,
    an atomic operation both threads would share). A pixel row's first sweep writes the
    accumulators (no clearing pass); the slots are reduced to pixels, and checked, in one pass
    per pixel row (for the integrator's regular footprints, whose interior pieces are whole
    samples of one weight, the interior summed unweighted); the accumulators and the Planck
    scratch sit in one buffer, their starts 576 bytes apart modulo 4 kB (no false
    store-to-load aliasing between them);
-   the checks are fused: NaN propagates into the sums, +inf into the maximum, and a running
    minimum per slot catches T ≤ 0 and T below the table, so a clean frame costs one vector
    max and one min per sample;
-   the radiance is the table's (:class:`~radiosim.radiometry.BandRadianceTable`) cubic of L in
    T on a grid whose nodes are the floats with only their top mantissa bits set: no division,
    no logarithm, no exponential. Per sample row, two loops: the interval and position
    (vectorised: a shift, a subtraction, an unsigned minimum and a mask of the bits of T),
    into a small scratch; then the interval's four coefficients, loaded as one 32-byte row for
    each of eight samples and transposed into vectors by shuffles (:func:`_cubic8_grey`,
    :func:`_cubic8_map`: LLVM intrinsics; LLVM would otherwise make four scalar loads per
    sample, or slow gathers), a vector Horner step and the accumulation, in registers; for a
    grey scene two sample rows at a time (:func:`_cubic8_pair`: two independent chains, one
    accumulator update). The table (160 kB for the nist-ir band) is read where the scene's
    temperatures are, which stays in the L1/L2 cache;
-   ``fastmath`` is off: no reassociation, no automatic contraction into FMA, IEEE semantics;
    where the kernels fuse a multiply-add they say so (the moments' squares, the cubic's
    Horner steps: one rounding instead of two, which also takes a quarter of the Planck pass's
    time); the radiance takes the Horner steps of
    :meth:`~radiosim.radiometry.BandRadianceTable.evaluate_reference`, its numpy oracle, in
    the same order, so the two agree to a few units in the last place inside the table.

Nothing is compiled at import (importing costs numba's own import). The first call with a new
frame dtype (float32, float64) or index-map dtype (uint8, intp) compiles the one kernel that
serves linear, Planck and every emissivity form (about 35 s on a 2-core machine, most of it
the twelve generated sweeps) and caches it on disk
(``cache=True``, in ``radiosim/__pycache__`` or ``NUMBA_CACHE_DIR``); later processes load it in
about 0.3 s.
"""

from __future__ import annotations

import contextlib
import math
import threading
import weakref
from collections.abc import Mapping
from dataclasses import dataclass

import numba
import numpy as np
from llvmlite import ir as llvm_ir
from numba import prange
from numba.core import types
from numba.extending import intrinsic

from radiosim.checks import bad_sample_message
from radiosim.errors import RadiosimError
from radiosim.radiometry import BandRadianceTable, band_radiance

__all__ = [
    "fast_exp",
    "parallel_launch",
    "STATUS_OK",
    "STATUS_BAD_SAMPLE",
    "STATUS_BELOW_TABLE",
    "STATUS_ABOVE_TABLE",
    "STATUS_BAD_INDEX",
    "RadianceKernelTable",
    "pixel_mean",
    "pixel_mean_reference",
    "accumulate",
    "accumulate_reference",
    "Members",
    "accumulate_merged",
]

#: Status bits the compiled kernels return (OR-ed over pixel rows).
STATUS_OK = 0
#: A sample is NaN, ±inf or ≤ 0 K: :func:`accumulate` raises (the message of ``check_frame``).
STATUS_BAD_SAMPLE = 1
#: A sample is below its radiance table: :func:`accumulate` redoes those pixel rows with the
#: numpy reference, which integrates them exactly (the frame is still accumulated).
STATUS_BELOW_TABLE = 2
#: A sample is above its radiance table: :func:`accumulate` raises, naming value and range.
STATUS_ABOVE_TABLE = 4
#: A table-index map value is not an entry of the :class:`RadianceKernelTable`: raises.
STATUS_BAD_INDEX = 8

# Signal modes of the kernel.
_SIGNAL_NONE, _SIGNAL_SCALAR, _SIGNAL_MAP, _SIGNAL_INDEX = 0, 1, 2, 3

_JIT = dict(cache=True, fastmath=False, nogil=True, error_model="numpy")
_INF = np.inf

# exp(x) = 2^k · exp(r), r = x − k ln 2 (Cody & Waite, with fdlibm's split of ln 2: k·LN2_HI is
# exact for |k| < 2^20), exp(r) by its Taylor polynomial of degree 12 on |r| ≤ ln(2)/2
# (truncation < 2e-16), evaluated with fused multiply-adds.
_LOG2E = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_F2, _F3, _F4, _F5, _F6, _F7, _F8, _F9, _F10, _F11, _F12 = (
    1.0 / math.factorial(n) for n in range(2, 13))


# -- compiled kernels --------------------------------------------------------------------------


@intrinsic
def _fma(typingctx, a, b, c):
    """a·b + c rounded once (llvm.fma: vectorisable, exact to one rounding)."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, sig, args):
        double = llvm_ir.DoubleType()
        fn = builder.module.declare_intrinsic(
            "llvm.fma", [double], llvm_ir.FunctionType(double, [double] * 3))
        return builder.call(fn, args)

    return signature, codegen


@numba.njit(**_JIT)
def _exp(x):
    """exp(x) for x in [−708, 709] (clamped there), vectorisable (no libm call): relative
    error below 4e-16 (two roundings and the 2e-16 truncation of the polynomial)."""
    x = x if x > -708.0 else -708.0  # also maps NaN (rejected samples) to a finite value
    x = x if x < 709.0 else 709.0
    k = np.floor(x * _LOG2E + 0.5)
    r = _fma(-k, _LN2_LO, _fma(-k, _LN2_HI, x))
    p = _fma(_F12, r, _F11)
    p = _fma(p, r, _F10)
    p = _fma(p, r, _F9)
    p = _fma(p, r, _F8)
    p = _fma(p, r, _F7)
    p = _fma(p, r, _F6)
    p = _fma(p, r, _F5)
    p = _fma(p, r, _F4)
    p = _fma(p, r, _F3)
    p = _fma(p, r, _F2)
    p = _fma(p, r, 1.0)
    p = _fma(p, r, 1.0)
    return p * np.int64((np.int64(k) + 1023) << 52).view(np.float64)


#: exp(x) for the compiled kernels of other modules (the chip scene's moving terms).
fast_exp = _exp

_LAUNCH = threading.Lock()


@contextlib.contextmanager
def parallel_launch():
    """
    Around every launch of a parallel kernel. numba's OpenMP and TBB threading layers take
    launches from several threads at once (the integrator on the main thread, the chip scene on
    the prefetch thread); its fallback layer, workqueue (e.g. on a machine without OpenMP),
    aborts the process if two launches overlap, so there they are serialised.
    """
    try:
        serialise = numba.threading_layer() == "workqueue"
    except ValueError:  # no parallel kernel has run yet: the first launch picks the layer
        serialise = True
    if serialise:
        with _LAUNCH:
            yield
    else:
        yield


# Columns are swept in sample space: the helpers run along contiguous rows of samples (the
# region's columns 0 … extent − 1), accumulating into one slot per sample, which holds the first
# column piece reading that sample. A sample read by a second piece (a pixel edge inside it)
# gets a second slot after the samples' ("duplicate" slots), filled from rows of those samples
# gathered into small per-thread buffers. Samples no piece reads (gaps of a fill factor < 1)
# have slots of weight 0, which nothing reads. Index arrays are unsigned (uintp), so that
# indexing skips numba's negative-index wraparound.


@numba.njit(**_JIT)
def _gather(row, cols, out):
    """out[q] = row[cols[q]]."""
    for q in range(out.size):
        out[q] = row[cols[q]]


#: Most sample rows one sweep along the columns takes (a pixel row of more pieces takes several
#: sweeps): each sweep reads and writes the column accumulators once.
_MAX_ROWS = 12
#: Slots per sweep: the accumulators of a chunk stay in the L1 cache while its rows stream by.
_CHUNK = 512


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
        body.append("    o = -_INF" if start else "    o = am[q]")
        body.append("    am[q] = m if m > o else o")
        body.append("    o = _INF" if start else "    o = an[q]")
        body.append("    an[q] = n if n < o else o")
        lines += ["        " + line for line in body]
    return "\n".join(lines) + "\n"


def _lin_dispatch_source() -> str:
    """Source of ``_lin``: the sweep of ``n`` rows (1 … _MAX_ROWS) by ``_lin{n}``."""
    lines = ["def _lin(n, first, lo, hi, src, o, ws, ce, a1, a2, am, an):"]
    for k in range(1, _MAX_ROWS + 1):
        lines.append(f"    {'if' if k == 1 else 'elif'} n == {k}:")
        lines.append(f"        _lin{k}(first, lo, hi, src, o, ws, ce, a1, a2, am, an)")
    return "\n".join(lines) + "\n"


def _make_sweeps():
    # Compiled with this file's name, so that numba's on-disk cache finds (and invalidates) them
    # with the module; generated because each row count needs its own unrolled loop body.
    namespace = {"np": np, "_fma": _fma, "_INF": _INF, "__name__": __name__}
    source = "".join(_lin_source(k) for k in range(1, _MAX_ROWS + 1)) + _lin_dispatch_source()
    exec(compile(source, __file__, "exec"), namespace)
    for k in range(1, _MAX_ROWS + 1):
        namespace[f"_lin{k}"] = numba.njit(**_JIT)(namespace[f"_lin{k}"])
    return numba.njit(**_JIT)(namespace["_lin"]), [namespace[f"_lin{k}"] for k in
                                                    range(1, _MAX_ROWS + 1)]


_lin, _LIN_SWEEPS = _make_sweeps()


def _data(context, builder, array_type, array):
    """Data pointer of a numba array argument of an intrinsic."""
    return context.make_array(array_type)(context, builder, array).data


def _mask(*lanes):
    """A constant vector of i32 lane numbers (a shuffle mask)."""
    i32 = llvm_ir.IntType(32)
    return llvm_ir.Constant(llvm_ir.VectorType(i32, len(lanes)),
                            [llvm_ir.Constant(i32, k) for k in lanes])


def _transpose8(builder, rows):
    """Four vectors (a, b, c, e) of eight doubles from eight rows of four (by shuffles): rows
    paired (0, 2), (1, 3), (4, 6), (5, 7) into 8-vectors, unpacked within 128-bit lanes into
    (a, c) and (b, e) pairs, then gathered by 128-bit lanes (4 cross-lane shuffles, not 8)."""
    pairs = [builder.shuffle_vector(rows[j], rows[k], _mask(*range(8)))
             for j, k in ((0, 2), (1, 3), (4, 6), (5, 7))]
    low, high = _mask(0, 8, 2, 10, 4, 12, 6, 14), _mask(1, 9, 3, 11, 5, 13, 7, 15)
    ac_lo, be_lo = (builder.shuffle_vector(pairs[0], pairs[1], m) for m in (low, high))
    ac_hi, be_hi = (builder.shuffle_vector(pairs[2], pairs[3], m) for m in (low, high))
    even, odd = _mask(0, 1, 4, 5, 8, 9, 12, 13), _mask(2, 3, 6, 7, 10, 11, 14, 15)
    return (builder.shuffle_vector(ac_lo, ac_hi, even), builder.shuffle_vector(be_lo, be_hi, even),
            builder.shuffle_vector(ac_lo, ac_hi, odd), builder.shuffle_vector(be_lo, be_hi, odd))


def _horner8(builder, table, index, position, q):
    """The cubics of the eight samples q … q + 7 (interval ``index[q + k]``, position
    ``position[q + k]``; pointers): their rows loaded whole, transposed (:func:`_transpose8`),
    Horner by fused multiply-adds; a vector of eight doubles."""
    double, i64 = llvm_ir.DoubleType(), llvm_ir.IntType(64)
    row4, vec8 = llvm_ir.VectorType(double, 4), llvm_ir.VectorType(double, 8)
    rows = []
    for k in range(8):
        i = builder.load(builder.gep(index, [builder.add(q, llvm_ir.Constant(i64, k))]))
        first = builder.gep(table, [builder.mul(i, llvm_ir.Constant(i64, 4))])
        rows.append(builder.load(builder.bitcast(first, row4.as_pointer()), align=8))
    a, b, c, d = _transpose8(builder, rows)
    r = builder.load(builder.bitcast(builder.gep(position, [q]), vec8.as_pointer()), align=8)
    fma = builder.module.globals.get("llvm.fma.v8f64") or llvm_ir.Function(
        builder.module, llvm_ir.FunctionType(vec8, [vec8] * 3), "llvm.fma.v8f64")
    value = builder.call(fma, [a, r, b])
    value = builder.call(fma, [value, r, c])
    return builder.call(fma, [value, r, d])


@intrinsic
def _cubic8_pair(typingctx, coef, interval, position, second, w0, w1, out, out0, q):
    """For k = 0 … 7: out[out0 + q + k] += v₀ · w0 + v₁ · w1 (the second product fused into the
    sum), where v₀ is the cubic of sample q + k of a row and v₁ that of sample ``second`` +
    q + k of the next (:func:`_horner8`): two rows' samples at once, two independent chains,
    one update of the accumulators."""
    signature = types.void(coef, interval, position, second, w0, w1, out, out0, q)

    def codegen(context, builder, sig, args):
        i32 = llvm_ir.IntType(32)
        vec8 = llvm_ir.VectorType(llvm_ir.DoubleType(), 8)
        table, index, position, out = (_data(context, builder, sig.args[k], args[k])
                                       for k in (0, 1, 2, 6))
        second, w0, w1, out0, q = args[3], args[4], args[5], args[7], args[8]

        def splat(value):
            one = builder.insert_element(llvm_ir.Constant(vec8, llvm_ir.Undefined), value,
                                         llvm_ir.Constant(i32, 0))
            return builder.shuffle_vector(one, llvm_ir.Constant(vec8, None), _mask(*[0] * 8))

        v0 = _horner8(builder, table, index, position, q)
        v1 = _horner8(builder, table, index, position, builder.add(second, q))
        fma = builder.module.globals.get("llvm.fma.v8f64")
        term = builder.call(fma, [v1, splat(w1), builder.fmul(v0, splat(w0))])
        target = builder.bitcast(builder.gep(out, [builder.add(out0, q)]), vec8.as_pointer())
        builder.store(builder.fadd(builder.load(target, align=8), term), target, align=8)
        return context.get_dummy_value()

    return signature, codegen


def _make_cubic8(kind: str):
    """The intrinsic ``_cubic8`` (``kind`` "store"), ``_cubic8_grey`` ("grey") or
    ``_cubic8_map`` ("map"): eight samples' cubics, stored or accumulated."""

    def cubic8(typingctx, coef, interval, position, g, g0, w, grey, out, out0, q):
        signature = types.void(coef, interval, position, g, g0, w, grey, out, out0, q)

        def codegen(context, builder, sig, args):
            i32 = llvm_ir.IntType(32)
            vec8 = llvm_ir.VectorType(llvm_ir.DoubleType(), 8)
            table, index, position, factor, out = (_data(context, builder, sig.args[k], args[k])
                                                   for k in (0, 1, 2, 3, 7))
            g0, w, grey, out0, q = args[4], args[5], args[6], args[8], args[9]

            def vector(pointer, start=None):
                at = q if start is None else builder.add(start, q)
                return builder.bitcast(builder.gep(pointer, [at]), vec8.as_pointer())

            def splat(value):
                one = builder.insert_element(llvm_ir.Constant(vec8, llvm_ir.Undefined), value,
                                             llvm_ir.Constant(i32, 0))
                return builder.shuffle_vector(one, llvm_ir.Constant(vec8, None), _mask(*[0] * 8))

            value = _horner8(builder, table, index, position, q)
            if kind == "store":
                builder.store(value, vector(out, out0), align=8)
                return context.get_dummy_value()
            if kind == "map":
                factor = builder.fmul(splat(grey), builder.load(vector(factor, g0), align=8))
                term = builder.fmul(splat(w), builder.fmul(value, factor))
            else:
                term = builder.fmul(value, splat(w))
            target = vector(out, out0)
            builder.store(builder.fadd(builder.load(target, align=8), term), target, align=8)
            return context.get_dummy_value()

        return signature, codegen

    cubic8.__name__ = {"store": "_cubic8", "grey": "_cubic8_grey", "map": "_cubic8_map"}[kind]
    cubic8.__doc__ = (
        "For k = 0 … 7: " + {
            "store": "out[out0 + q + k] = v",
            "grey": "out[out0 + q + k] += v · w (w: the row weight times the grey factor)",
            "map": "out[out0 + q + k] += w · (v · (grey · g[g0 + q + k]))"}[kind]
        + """, where v = ((a r + b) r + c) r + d, with
    (a, b, c, d) = row ``interval[q + k]`` of the flat coefficient table ``coef`` (4 float64 per
    row) and r = ``position[q + k]``. The eight rows are loaded whole (32 bytes each) and
    transposed into four vectors of eight coefficients by shuffles, then Horner runs on the
    vectors with fused multiply-adds (one rounding per step, as :func:`_cubic1`): no gather,
    no scalar coefficient loads.""")
    return intrinsic(cubic8)


_cubic8 = _make_cubic8("store")
_cubic8_grey = _make_cubic8("grey")
_cubic8_map = _make_cubic8("map")


@numba.njit(**_JIT)
def _cubic(coef, interval, position, out, n):
    """out[q] = the cubic of row interval[q] of ``coef`` at position[q], q < n (eight at a time
    by :func:`_cubic8`, the rest one by one with the same operations)."""
    q = 0
    while q + 8 <= n:
        _cubic8(coef, interval, position, out, 0, 1.0, 1.0, out, 0, q)
        q += 8
    for k in range(q, n):
        out[k] = _cubic1(coef, interval[k], position[k])


@numba.njit(**_JIT)
def _locate(t, key0, shift, node_mask, last):
    """Interval index k and d = T − T_k [K] of a sample T [K] (float64): k = (bits(T) >> shift)
    − key0, clamped to ``last`` unsigned (a sample below the table, ≤ 0 or NaN wraps round and
    reads the last row: the checks flag it), and d = T − (bits(T) & node_mask). Inside the
    table's range this is :meth:`BandRadianceTable.evaluate_reference`'s interval and position,
    exactly. ``shift``, ``node_mask``, ``last``: uint64."""
    bits = np.float64(t).view(np.uint64)
    k = (bits >> shift) - np.uint64(key0)
    return (k if k < last else last), t - np.uint64(bits & node_mask).view(np.float64)


@numba.njit(**_JIT)
def _cubic1(coef, i, r):
    """The cubic of row i of ``coef`` at r, as one lane of :func:`_cubic8`: Horner with fused
    multiply-adds, ((a r + b) r + c) r + d each step rounded once."""
    i = i * np.uint64(4)
    return _fma(_fma(_fma(coef[i], r, coef[i + 1]), r, coef[i + 2]), r, coef[i + 3])


@numba.njit(**_JIT)
def _signal_one(src, xo, g, go, w, use_map, grey, coef, key0, shift, node_mask, last,
                interval, u, a3, lo, hi):
    """a3[q] += w · S(src[xo + q]) for the slots lo ≤ q < hi of one sample row (modes 1 and 2:
    S = L(T) · grey, or L(T) · (grey · g[go + q]) with ``g`` the grey map). Two loops: the
    intervals and positions (:func:`_locate`, vectorised), into the scratch ``interval`` and
    ``u`` (from 0); then the cubics, accumulated eight at a time (:func:`_cubic8_grey`,
    :func:`_cubic8_map`), the rest one by one with the same operations. ``coef``: the table's
    rows; offsets, bounds, ``last``, ``shift``, ``node_mask``: uint64."""
    nq = hi - lo
    x0 = xo + lo
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


@numba.njit(**_JIT)
def _signal_rows(n, lo, hi, src, o, ws, g, go, use_map, grey, coef, key0, shift, last,
                 interval, u, a3):
    """a3[q] += Σₕ ws[h] · S(src[o[h] + q]) over the sample rows h < n of a sweep and its slots
    lo ≤ q < hi (modes 1 and 2; grey map row h at ``g[go[h]:]``): with a grey factor, two rows
    at a time (:func:`_signal_two`), else row by row (:func:`_signal_one`). ``interval`` and
    ``u``: scratch of two chunks."""
    node_mask = ~((np.uint64(1) << shift) - np.uint64(1))
    h = 0
    if not use_map:
        while h + 1 < n:
            _signal_two(src, o[h], o[h + 1], ws[h] * grey, ws[h + 1] * grey, coef, key0, shift,
                        node_mask, last, interval, u, a3, lo, hi)
            h += 2
    while h < n:
        _signal_one(src, o[h], g, go[h], ws[h], use_map, grey, coef, key0, shift, node_mask,
                    last, interval, u, a3, lo, hi)
        h += 1


@numba.njit(**_JIT)
def _signal_two(src, xo, yo, wx, wy, coef, key0, shift, node_mask, last, interval, u, a3, lo,
                hi):
    """a3[q] += wx · L(src[xo + q]) + wy · L(src[yo + q]) for lo ≤ q < hi (two sample rows of
    a grey scene, weights times the grey factor): the intervals and positions of both rows
    into the scratch (the second's from _CHUNK on), then their cubics eight at a time
    (:func:`_cubic8_pair`), the rest one by one with the same operations."""
    nq = hi - lo
    second = np.uint64(_CHUNK)
    x0 = xo + lo
    y0 = yo + lo
    for q in range(nq):
        interval[q], u[q] = _locate(np.float64(src[x0 + q]), key0, shift, node_mask, last)
    for q in range(nq):
        interval[second + q], u[second + q] = _locate(np.float64(src[y0 + q]), key0, shift,
                                                      node_mask, last)
    q = np.uint64(0)
    eight = np.uint64(8)
    while q + eight <= nq:
        _cubic8_pair(coef, interval, u, second, wx, wy, a3, lo, q)
        q += eight
    for k in range(q, nq):
        a3[lo + k] += _fma(_cubic1(coef, interval[second + k], u[second + k]), wy,
                           _cubic1(coef, interval[k], u[k]) * wx)


@numba.njit(**_JIT)
def _signal_row(x, g, e, used, w, mode, grey, use_map, coef, key0, shift, last, offset, t_min,
                t_max, entry_table, entry_grey, interval, u, value, factor, a3):
    """a3 += w · S(T) along one row of pieces ``x`` (grey map row ``g``, index map row ``e``),
    with S = L(T) · grey (mode 1), L(T) · (grey · map) (mode 2) or L_e(T) · grey_e (· map)
    with e from the index map (mode 3); L the cubic of the sample's table (a row of the flat
    ``coef``, from the table's ``offset``) at its interval and position (:func:`_locate`).
    Modes 1–2: :func:`_signal_one` (the rows of the sample slots go through
    :func:`_signal_rows` instead, a sweep at a time); mode 3: three loops, the entry, checks
    and interval per sample, the cubics (:func:`_cubic`, eight samples at a time), the
    accumulation. Returns the status bits of the row's per-sample checks (mode 3: table range
    and index; modes 1–2 check the range from the row's min and max instead; ``used`` > 0
    marks the slots a piece reads, the only ones checked). ``interval``, ``u``, ``value``,
    ``factor``: scratch."""
    nq = a3.size
    status = 0
    if mode == 1 or mode == 2:
        j = entry_table[0]
        s = np.uint64(shift[j])
        node_mask = ~((np.uint64(1) << s) - np.uint64(1))
        _signal_one(x, np.uint64(0), g, np.uint64(0), w, use_map, grey,
                    coef[np.uint64(offset[j]) * np.uint64(4):], key0[j], s, node_mask,
                    np.uint64(last[j]), interval, u, a3, np.uint64(0), np.uint64(nq))
        return status
    else:
        n_entries = entry_table.size
        n_low = 0
        n_high = 0
        n_index = 0
        for q in range(nq):
            t = np.float64(x[q])
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
            status |= 2
        if n_high:
            status |= 4
        if n_index:
            status |= 8
        _cubic(coef, interval, u, value, nq)
        for q in range(nq):
            a3[q] += w * (value[q] * factor[q])
        return status


@numba.njit(**_JIT)
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


@numba.njit(**_JIT)
def _pixel_done(j, v1, v2, v3, m, n, t_low, t_high, s1, s2, s3, sm):
    """Store pixel j's sums and maximum (m, n: its extremes in the frame's dtype, widened
    here) and return its status bits: 1 a bad sample (NaN in Σ w (T − c), +inf, ≤ 0 K), 2 one
    below ``t_low``, 4 one above ``t_high``."""
    s1[j], s2[j], s3[j], sm[j] = v1, v2, v3, np.float64(m)
    bad = np.int64(n <= 0.0) | np.int64(np.float64(m) == _INF) | np.int64(v1 != v1)
    return bad | (np.int64(np.float64(n) < t_low) << 1) | (np.int64(np.float64(m) > t_high) << 2)


@numba.njit(**_JIT)
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
        m = am[k]  # extremes in the frame's dtype (exact), widened once
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


@numba.njit(**_JIT)
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
        m = am[k]  # extremes in the frame's dtype (exact), widened once
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


@numba.njit(**_JIT)
def _commit_row(i, a1, a2, a3, am, an, slot_weight, slot_of_piece, col_bounds, layout,
                time_weight, with_signal, t_low, t_high, reference, dev, sq, tmax, signal,
                merge, moments, member_weight, member_count, signal_weight, m_mean, m_m2,
                m_max, m_signal, s1, s2, s3, sm, status):
    """Add the pieces to the row's pixels (pixel row ``i``) and check the slots they read (NaN
    propagates into a1, +inf into am, T ≤ 0 and T below the table show in an), in one pass;
    commit them unless the row has a status (``status``: bits found so far). Returns the row's
    status.
    ``layout``: bit 0, slot q is piece q (the pieces are the samples); bit 1, each pixel's
    interior pieces (all but its first and last) lie on consecutive slots with one weight
    (:attr:`_Axis.slots`); s1, s2, s3, sm: per-pixel scratch.

    Without ``merge``: dev, sq, signal += time_weight × the frame's Σ w (T − c), Σ w (T − c)²,
    Σ w S, and tmax = max(tmax, max T) (row i of the per-pixel accumulators). With ``merge``:
    the frame's mean m = c + Σ w (T − c) and variance v = max(Σ w (T − c)² − (Σ w (T − c))², 0)
    are merged into every member job b of weight w_b = member_weight[b] > 0 (Chan et al.:
    δ = m − mean, M2 += w_b v + δ² n_b w_b / n', mean += δ w_b / n', n' = n_b + w_b; the
    maximum), unless ``moments`` is off; signals add signal_weight[b] × Σ w S; and the reference
    row becomes m (the next frame's c)."""
    n_pixels = col_bounds.size - 1
    identity = (layout & 1) != 0
    if (layout & 2) != 0:
        status |= _pixel_sums_regular(a1, a2, a3, am, an, slot_weight, slot_of_piece,
                                      col_bounds, identity, with_signal, t_low, t_high, s1, s2,
                                      s3, sm)
    else:
        status |= _pixel_sums(a1, a2, a3, am, an, slot_weight, slot_of_piece, col_bounds,
                              identity, with_signal, t_low, t_high, s1, s2, s3, sm)
    if status:
        return status
    if not merge:  # the accumulators indexed [i, j], [b, i, j]: no row views (a view of an
        # array is a reference count, an atomic operation the threads would share)
        for j in range(n_pixels):
            dev[i, j] += time_weight * s1[j]
            sq[i, j] += time_weight * s2[j]
            m = tmax[i, j]
            tmax[i, j] = sm[j] if sm[j] > m else m
        if with_signal:
            for j in range(n_pixels):
                signal[i, j] += time_weight * s3[j]
        return 0
    for b in range(member_weight.size):
        w = signal_weight[b]
        if with_signal and w > 0.0:
            for j in range(n_pixels):
                m_signal[b, i, j] += w * s3[j]
    if moments:
        for j in range(n_pixels):  # the frame's mean and variance over each footprint
            v = s2[j] - s1[j] * s1[j]
            s2[j] = v if v > 0.0 else 0.0
            s1[j] = reference[i, j] + s1[j]
        for b in range(member_weight.size):
            w = member_weight[b]
            if w > 0.0:
                n = member_count[b]
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
    return 0


@numba.njit(**_JIT)
def _rows12(row_source, p, n, length):
    """The uint64 offsets, in a flat array of rows of ``length`` elements, of sample rows
    ``row_source[p + h]`` for h < 12 (rows past n − 1 repeat the last)."""
    return (_row(row_source, p, 0, n, length), _row(row_source, p, 1, n, length),
            _row(row_source, p, 2, n, length), _row(row_source, p, 3, n, length),
            _row(row_source, p, 4, n, length), _row(row_source, p, 5, n, length),
            _row(row_source, p, 6, n, length), _row(row_source, p, 7, n, length),
            _row(row_source, p, 8, n, length), _row(row_source, p, 9, n, length),
            _row(row_source, p, 10, n, length), _row(row_source, p, 11, n, length))


@numba.njit(**_JIT)
def _row(row_source, p, h, n, length):
    """The uint64 offset of sample row ``row_source[p + min(h, n − 1)]`` in a flat array of
    rows of ``length`` elements."""
    return np.uint64(row_source[p + min(h, n - 1)] * length)


@numba.njit(**_JIT)
def _accumulate_rows(i_start, i_stop, base, row_length, row_source, row_weight, row_bounds,
                     n_samples, slot_runs, slot_weight, slot_of_piece, dup_source, col_bounds,
                     layout, time_weight, reference, dev, sq, tmax, signal, merge, moments,
                     member_weight, member_count, signal_weight, m_mean, m_m2, m_max, m_signal,
                     mode, coef, key0, shift, last, offset, t_min, t_max, entry_table, entry_grey,
                     grey,
                     grey_map, index_map, map_length, use_map, rows_w, rows_r, grey_w, grey_r,
                     index_w, index_r, am, an, status):
    """Pixel rows i_start to i_stop − 1 of :func:`_accumulate_kernel` (one thread's block).
    rows_w/rows_r, grey_w/grey_r, index_w/index_r: this thread's buffers for the duplicate
    slots' samples, each written through the first array and read through the second (a
    read-only view of the same memory, so that the gathered rows have the type of the frame's
    rows: one compilation serves both); am, an: this thread's running maximum and minimum per
    slot, in the frame's dtype.

    Each pixel row is swept along the columns in chunks of _CHUNK slots, up to _MAX_ROWS sample
    rows per sweep (all of them, for pixels of up to _MAX_ROWS pieces), so the accumulators are
    read and written once per chunk while the frame's rows stream through."""
    n_slots = slot_weight.size
    ns = n_samples
    n_dups = dup_source.size
    n_pixels = col_bounds.size - 1
    with_signal = mode != 0
    # The slot accumulators in one buffer, their starts 576 bytes apart modulo 4096: loads of
    # one and stores to another never alias in the address bits the CPU compares first.
    # The Planck pass's scratch (interval, position: per chunk) likewise, 4 kB each.
    stride = (max(n_slots, 2 * _CHUNK) + 511) // 512 * 512 + 72
    slots = np.empty(6 * stride)
    a1 = slots[:n_slots]
    a2 = slots[stride:stride + n_slots]
    a3 = slots[2 * stride:2 * stride + n_slots]
    ce = slots[3 * stride:3 * stride + n_slots]
    u = slots[4 * stride:4 * stride + 2 * _CHUNK]
    interval = slots[5 * stride:5 * stride + 2 * _CHUNK].view(np.uint64)
    value = np.empty(_CHUNK)
    factor = np.empty(_CHUNK)
    s1 = np.empty(n_pixels)
    s2 = np.empty(n_pixels)
    s3 = np.empty(n_pixels)
    sm = np.empty(n_pixels)
    table = entry_table[0]
    t_low = t_min[table] if (mode == 1 or mode == 2) else -_INF
    t_high = t_max[table] if (mode == 1 or mode == 2) else _INF
    # Modes 1 and 2: the one table's rows and grid.
    table_rows = coef[np.uint64(offset[table]) * np.uint64(4):]
    table_key0 = key0[table]
    table_shift = np.uint64(shift[table])
    table_last = np.uint64(last[table])
    # Slot bounds and offsets as uint64 (the sweeps index with them).
    zero = np.uint64(0)
    samples_u = np.uint64(ns)
    slots_u = np.uint64(n_slots)
    chunk = np.uint64(_CHUNK)
    dup_rows = rows_r.reshape(-1)
    size = np.uint64(rows_r.shape[1])
    dup_offsets = (zero - samples_u, size - samples_u, np.uint64(2) * size - samples_u,
                   np.uint64(3) * size - samples_u, np.uint64(4) * size - samples_u,
                   np.uint64(5) * size - samples_u, np.uint64(6) * size - samples_u,
                   np.uint64(7) * size - samples_u, np.uint64(8) * size - samples_u,
                   np.uint64(9) * size - samples_u, np.uint64(10) * size - samples_u,
                   np.uint64(11) * size - samples_u)
    for i in range(i_start, i_stop):
        _setup_row(reference, i, slot_runs, with_signal, ce, a3)
        row_status = np.int64(0)  # not a literal: one compilation of _commit_row
        p = row_bounds[i]
        start = p
        stop = row_bounds[i + 1]
        while p < stop:
            n = min(_MAX_ROWS, stop - p)
            # Rows past n repeat the last one (never read by _lin{n}); offsets as uint64.
            o = _rows12(row_source, p, n, row_length)
            ws = (row_weight[p], row_weight[p + min(1, n - 1)], row_weight[p + min(2, n - 1)],
                  row_weight[p + min(3, n - 1)], row_weight[p + min(4, n - 1)],
                  row_weight[p + min(5, n - 1)], row_weight[p + min(6, n - 1)],
                  row_weight[p + min(7, n - 1)], row_weight[p + min(8, n - 1)],
                  row_weight[p + min(9, n - 1)], row_weight[p + min(10, n - 1)],
                  row_weight[p + min(11, n - 1)])
            # The grey map's rows (modes 1 and 2).
            mo = _rows12(row_source, p, n, map_length)
            # Part 0: the sample slots, along the frame's rows; part 1: the duplicate slots,
            # along rows gathered into the buffers (row h at h · size − n_samples, so that
            # slot q reads sample q − n_samples of it).
            for part in range(2 if n_dups else 1):
                if part == 1:
                    for h in range(n):
                        _gather(base[o[h]:], dup_source, rows_w[h])
                first, end = (zero, samples_u) if part == 0 else (samples_u, slots_u)
                src = base if part == 0 else dup_rows
                offsets = o if part == 0 else dup_offsets
                for lo in range(first, end, chunk):
                    hi = min(end, lo + chunk)
                    _lin(n, p == start, lo, hi, src, offsets, ws, ce, a1, a2, am, an)
                    if with_signal and part == 0 and mode != 3:
                        _signal_rows(n, lo, hi, src, offsets, ws, grey_map, mo, use_map, grey,
                                     table_rows, table_key0, table_shift, table_last,
                                     interval, u, a3)
                    elif with_signal:
                        lo_i, hi_i = np.int64(lo), np.int64(hi)
                        for h in range(n):
                            m_off = row_source[p + h] * map_length
                            if part == 0:
                                x = base[o[h] + lo:]
                                g = grey_map[m_off + lo_i:]
                                e = index_map[m_off + lo_i:]
                            else:
                                x = rows_r[h][lo_i - ns:]
                                if use_map or mode != 3:  # mode 1: the row of ones
                                    _gather(grey_map[m_off:], dup_source[lo_i - ns:hi_i - ns],
                                            grey_w[:hi_i - lo_i])
                                if mode == 3:
                                    _gather(index_map[m_off:], dup_source[lo_i - ns:hi_i - ns],
                                            index_w[:hi_i - lo_i])
                                g = grey_r
                                e = index_r
                            row_status |= _signal_row(
                                x, g, e, slot_weight[lo_i:hi_i], ws[h], mode, grey, use_map,
                                coef, key0, shift, last, offset, t_min, t_max, entry_table,
                                entry_grey, interval, u, value, factor, a3[lo_i:hi_i])
            p += n
        status[i] = _commit_row(i, a1, a2, a3, am, an, slot_weight, slot_of_piece, col_bounds,
                                layout, time_weight, with_signal, t_low, t_high, reference,
                                dev, sq, tmax, signal,
                                merge, moments, member_weight, member_count, signal_weight,
                                m_mean, m_m2, m_max, m_signal, s1, s2, s3, sm, row_status)


@numba.njit(parallel=True, **_JIT)
def _accumulate_kernel(n_blocks, start, n_frames, frame_stride, base, row_length, row_source,
                       row_weight, row_bounds, n_samples, slot_runs, slot_weight, slot_of_piece,
                       dup_source, col_bounds, layout, time_weight, reference, dev, sq, tmax,
                       signal, merge, moments, member_weight, member_count, signal_weight,
                       m_mean, m_m2, m_max, m_signal, mode, coef, key0, shift, last, offset,
                       t_min, t_max, entry_table, entry_grey, grey, grey_map, index_map,
                       map_length, use_map, rows_w, rows_r, grey_w, grey_r, index_w, index_r, am,
                       an, status):
    """The frames' pixel rows in ``n_blocks`` contiguous blocks, one per thread (block b uses
    buffers [b]); frame f starts at ``base[f * frame_stride]``, and member_weight,
    member_count, signal_weight and status have one row per frame. Block b takes frames
    start[b] … n_frames − 1 of its rows, one after the other, without waiting for the other
    blocks (no barrier per frame), and stops after its first frame with a status. Returns,
    per block, that frame, or n_frames."""
    n_rows = row_bounds.size - 1
    stopped = np.full(n_blocks, n_frames, dtype=np.int64)
    for b in prange(n_blocks):
        first_row = b * n_rows // n_blocks
        stop_row = (b + 1) * n_rows // n_blocks
        for f in range(start[b], n_frames):
            row_status = status[f]
            _accumulate_rows(first_row, stop_row, base[f * frame_stride:], row_length,
                             row_source, row_weight, row_bounds, n_samples, slot_runs,
                             slot_weight, slot_of_piece, dup_source, col_bounds, layout,
                             time_weight, reference, dev, sq, tmax, signal, merge, moments,
                             member_weight[f], member_count[f], signal_weight[f], m_mean, m_m2,
                             m_max, m_signal, mode, coef, key0, shift, last, offset, t_min,
                             t_max, entry_table, entry_grey, grey, grey_map, index_map,
                             map_length, use_map, rows_w[b], rows_r[b], grey_w[b], grey_r[b],
                             index_w[b], index_r[b], am[b], an[b], row_status)
            bad = 0
            for i in range(first_row, stop_row):
                bad |= row_status[i]
            if bad != 0:
                stopped[b] = f
                break
    return stopped


# -- layouts ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Axis:
    """The pieces of one axis as the kernels take them (region-relative sample indices)."""

    source: np.ndarray  # intp, sample index of each piece minus ``offset``
    weight: np.ndarray  # float64, piece length / active width
    bounds: np.ndarray  # intp, n_pixels + 1: pieces of pixel j are bounds[j]:bounds[j + 1]
    pixel: np.ndarray  # intp, the pixel of each piece
    offset: int  # scene sample index of the region's first sample (span.start)
    identity: bool  # the pieces are the region's samples, in order, each once

    @property
    def slots(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """The kernels' column layout (see the comment on the compiled kernels): the runs of
        slots of one pixel (start, stop, pixel; slots are the samples 0 … extent − 1, then the
        duplicate pieces), the weight of each slot (0 for a sample no piece reads), the slot of
        each piece, the sample of each duplicate slot, the piece bounds of the pixels (the
        index arrays as uintp), and the layout code the reduction to pixels takes (bit 0: the
        pieces are the samples; bit 1: each pixel's interior pieces lie on consecutive slots
        with one weight)."""
        cached = self.__dict__.get("_slots")
        if cached is None:
            n = self.extent
            first = np.ones(self.source.size, dtype=bool)  # first piece reading its sample
            first[1:] = self.source[1:] != self.source[:-1]
            duplicate = np.flatnonzero(~first)
            slot_of_piece = np.where(first, self.source,
                                     n + np.cumsum(~first) - 1).astype(np.uintp)
            slot_pixel = np.zeros(n + duplicate.size, dtype=np.uintp)
            slot_weight = np.zeros(n + duplicate.size)
            slot_pixel[self.source[first]] = self.pixel[first]
            slot_weight[self.source[first]] = self.weight[first]
            slot_pixel[n:] = self.pixel[duplicate]
            slot_weight[n:] = self.weight[duplicate]
            change = np.flatnonzero(np.diff(slot_pixel) != 0) + 1
            starts, stops = np.append(0, change), np.append(change, slot_pixel.size)
            slot_runs = np.ascontiguousarray(
                np.stack([starts, stops, slot_pixel[starts]], axis=1).astype(np.uintp))
            # Regular: every pixel's interior pieces (not its first or last) lie on
            # consecutive slots and weigh the same (whole samples), as axis_footprints makes.
            position = np.arange(self.source.size) - self.bounds[self.pixel]
            count = np.diff(self.bounds)[self.pixel]
            interior = (position > 0) & (position < count - 1)
            pairs = interior[:-1] & interior[1:]
            regular = bool(np.all(np.diff(slot_of_piece.astype(np.int64))[pairs] == 1)
                           and np.all(self.weight[:-1][pairs] == self.weight[1:][pairs]))
            layout = int(self.identity) | (2 if regular else 0)
            cached = (slot_runs, slot_weight, slot_of_piece,
                      self.source[duplicate].astype(np.uintp), self.bounds.astype(np.uintp),
                      layout)
            object.__setattr__(self, "_slots", cached)
        return cached

    @property
    def n_pixels(self) -> int:
        return self.bounds.size - 1

    @property
    def starts(self) -> np.ndarray:
        return self.bounds[:-1]

    @property
    def extent(self) -> int:
        """Samples of the region the pieces need (the last piece's sample + 1)."""
        return int(self.source[-1]) + 1

    def pixels(self, start: int, stop: int) -> "_Axis":
        """The pieces of pixels ``start`` to ``stop - 1`` only (same region)."""
        a, b = int(self.bounds[start]), int(self.bounds[stop])
        return _Axis(self.source[a:b], self.weight[a:b], self.bounds[start:stop + 1] - a,
                     self.pixel[a:b] - start, self.offset, False)

    @classmethod
    def of(cls, axis, name: str) -> "_Axis":
        source = np.asarray(axis.source, dtype=np.intp)
        weight = np.array(axis.weight, dtype=np.float64)  # a writeable copy: one compilation
        starts = np.asarray(axis.starts, dtype=np.intp)
        if source.ndim != 1 or source.size == 0 or weight.shape != source.shape:
            raise RadiosimError(f"{name} footprints must have one weight per piece and at least "
                                f"one piece, got {source.size} pieces and {weight.size} weights")
        if not np.all((weight > 0) & np.isfinite(weight)):
            bad = weight[~((weight > 0) & np.isfinite(weight))][0]
            raise RadiosimError(f"{name} footprints: every piece's weight must be a finite "
                                f"number > 0 (a piece reads its sample), got {bad!r}")
        if starts.ndim != 1 or starts.size == 0 or starts[0] != 0 or np.any(
                np.diff(starts) <= 0) or starts[-1] >= source.size:
            raise RadiosimError(f"{name} footprints: starts must begin at 0 and increase "
                                f"strictly inside the {source.size} pieces")
        offset = int(source[0])
        relative = np.ascontiguousarray(source - offset)
        if np.any(relative < 0):
            raise RadiosimError(f"{name} footprints: the first piece must lie on the region's "
                                "first sample (span.start)")
        bounds = np.append(starts, source.size).astype(np.intp)
        pixel = np.repeat(np.arange(starts.size, dtype=np.intp), np.diff(bounds))
        if np.any(np.diff(relative) < 0):
            raise RadiosimError(f"{name} footprints: pieces must read non-decreasing samples")
        identity = bool(np.array_equal(relative, np.arange(relative.size)))
        return cls(relative, weight, bounds, pixel, offset, identity)


_LAYOUTS: dict[int, tuple[weakref.ref, _Axis]] = {}


def _axis(axis, name: str) -> _Axis:
    """The kernel layout of an AxisFootprints, prepared once per object."""
    if isinstance(axis, _Axis):
        return axis
    key = id(axis)
    cached = _LAYOUTS.get(key)
    if cached is not None and cached[0]() is axis:
        return cached[1]
    layout = _Axis.of(axis, name)
    try:
        ref = weakref.ref(axis, lambda _, key=key: _LAYOUTS.pop(key, None))
    except TypeError:  # not weak-referenceable: prepare it every call
        return layout
    _LAYOUTS[key] = (ref, layout)
    return layout


def _rows_of(array: np.ndarray) -> tuple[np.ndarray, int]:
    """A 2-D array whose rows are contiguous, as a read-only 1-D view and its row stride
    [elements], without copying (a region of a larger C-contiguous frame or memmap included)."""
    flat, row_length, _ = _frames_of(np.asarray(array)[None])
    return flat, row_length


def _frames_of(a: np.ndarray) -> tuple[np.ndarray, int, int]:
    """A 3-D array (frames, rows, columns) whose rows are contiguous, as a read-only 1-D view,
    its row stride and its frame stride [elements], without copying (a region of a stack of
    frames or of a memmap included); otherwise one copy, same dtype."""
    item = a.itemsize
    n_frames, n_rows, n_cols = a.shape
    if a.flags.c_contiguous:
        flat, row_length, frame_stride = a.reshape(-1), n_cols, n_rows * n_cols
    elif (n_rows > 0 and n_cols > 0 and a.strides[2] == item
          and a.strides[1] >= n_cols * item and a.strides[1] % item == 0
          and (n_frames == 1 or (a.strides[0] >= n_rows * a.strides[1]
                                 and a.strides[0] % item == 0))):
        row_length = a.strides[1] // item
        frame_stride = a.strides[0] // item if n_frames > 1 else n_rows * row_length
        size = (n_frames - 1) * frame_stride + (n_rows - 1) * row_length + n_cols
        flat = np.lib.stride_tricks.as_strided(a, shape=(size,), strides=(item,),
                                               writeable=False)
    else:  # rows not contiguous (a transposed view, a column step): one copy, same dtype
        a = np.ascontiguousarray(a)
        flat, row_length, frame_stride = a.reshape(-1), n_cols, n_rows * n_cols
    flat = flat.view()
    flat.flags.writeable = False
    return flat, int(row_length), int(frame_stride)


def _frame(frame, rows: _Axis, cols: _Axis) -> np.ndarray:
    """The frame region as a 2-D float32 or float64 array covering the pieces (not copied)."""
    a = np.asarray(frame)
    if a.ndim != 2:
        raise RadiosimError(f"a frame region must be 2-D, got shape {a.shape}")
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    if a.shape[0] < rows.extent or a.shape[1] < cols.extent:
        raise RadiosimError(
            f"frame region has shape {a.shape}, but the footprints need at least "
            f"({rows.extent}, {cols.extent}) samples from sample ({rows.offset}, {cols.offset})"
        )
    return a


def _frames(frames, rows: _Axis, cols: _Axis) -> np.ndarray:
    """One frame region (2-D) or several (3-D: frames, rows, columns), as a 3-D float32 or
    float64 array covering the pieces (not copied)."""
    a = np.asarray(frames)
    if a.ndim == 2:
        return _frame(a, rows, cols)[None]
    if a.ndim != 3 or a.shape[0] == 0:
        raise RadiosimError(f"frames must be one 2-D frame region or a non-empty 3-D stack "
                            f"(frames, rows, columns), got shape {a.shape}")
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    _frame(a[0], rows, cols)  # the shape check
    return a


def _per_pixel(array, shape, name: str):
    """Check a per-pixel array: float64, C-contiguous, ``shape``, writeable unless it is the
    reference."""
    writeable = name != "reference"
    if (not isinstance(array, np.ndarray) or array.dtype != np.float64
            or array.shape != shape or not array.flags.c_contiguous
            or (writeable and not array.flags.writeable)):
        raise RadiosimError(f"{name} must be a {'writeable ' if writeable else ''}C-contiguous "
                            f"float64 array of shape {shape} (one value per pixel)")
    return array


def _read_only(array: np.ndarray) -> np.ndarray:
    view = array.view()
    view.flags.writeable = False
    return view


# -- radiance tables ----------------------------------------------------------------------------

_UNCHANGED = object()


class RadianceKernelTable:
    """
    One or more :class:`~radiosim.radiometry.BandRadianceTable` packed for the kernels, with the
    emissivity of every sample: S(T) = L_e(T) · grey_e · grey, where e is the sample's *entry*.

    Emissivity forms:

    -   one entry, ``grey`` a scalar: a grey body (or a spectral curve, tabulated in the entry's
        table, with ``grey`` 1);
    -   one entry, ``grey`` a 2-D map on the frame region's sample grid: a grey map;
    -   several entries (e.g. per scene region: each a table and a grey factor) and ``index``,
        the entry of every sample (2-D integer map on the region grid), optionally with a
        ``grey`` map as well.

    Parameters
    ----------
    tables
        A table, or one table per entry (the same table object may serve several entries; it is
        packed once). All are evaluated exactly as :meth:`BandRadianceTable.__call__` does.
    exact
        The exact radiance of each entry for samples below its table: ``None`` (such samples
        raise), a mapping of :func:`~radiosim.radiometry.band_radiance` keyword arguments
        (``band``, ``quantity``, ``responsivity``, ``emissivity``), or a callable T [K] →
        radiance; one, or one per entry.
    grey
        Grey factor of every sample: a scalar, or a float map shaped like the frame region.
    index
        Entry of every sample, an integer map shaped like the frame region (needed, by
        :func:`accumulate`, with more than one entry). uint8 maps are used as they are; other
        integer types are converted to intp (a copy).
    entry_grey
        Grey factor of each entry (default 1).

    Examples
    --------
    >>> from radiosim.radiometry import BandRadianceTable
    >>> table = BandRadianceTable(temperature_range=(200.0, 1500.0), per_octave=64)
    >>> packed = RadianceKernelTable(table, exact={"band": table.band}, grey=0.9)
    >>> packed.n_entries, table.intervals, packed.coefficients.shape
    (1, 210, (840,))
    """

    def __init__(self, tables, exact=None, grey=1.0, index=None, entry_grey=None):
        if isinstance(tables, BandRadianceTable):
            tables = [tables]
        tables = list(tables)
        if not tables or not all(isinstance(t, BandRadianceTable) for t in tables):
            raise RadiosimError("tables must be one or more BandRadianceTable")
        n = len(tables)
        self.tables = tables
        unique: list[BandRadianceTable] = []
        entry_table = []
        for t in tables:
            for j, u in enumerate(unique):
                if u is t:
                    entry_table.append(j)
                    break
            else:
                entry_table.append(len(unique))
                unique.append(t)
        self.entry_table = np.array(entry_table, dtype=np.intp)
        if entry_grey is None:
            entry_grey = np.ones(n)
        self.entry_grey = np.array(entry_grey, dtype=np.float64).reshape(-1)
        if self.entry_grey.size != n or not np.all(np.isfinite(self.entry_grey)):
            raise RadiosimError(f"entry_grey must hold {n} finite values, got {entry_grey!r}")
        if exact is None or callable(exact) or isinstance(exact, Mapping):
            exact = [exact] * n
        exact = list(exact)
        if len(exact) != n:
            raise RadiosimError(f"exact must be one specification or {n}, got {len(exact)}")
        self.exact = exact
        # The tables' coefficient rows one after the other (table j's from row offset[j]), as
        # one flat array for the kernels: the cubic's coefficients of each interval, highest
        # power of T − T_k first.
        self.offset = np.cumsum([0] + [t.intervals for t in unique[:-1]]).astype(np.uint64)
        self.coefficients = np.concatenate([t.coefficients for t in unique]).reshape(-1)
        self.key0 = np.array([t.key0 for t in unique], dtype=np.int64)
        self.shift = np.array([t.shift for t in unique], dtype=np.uint64)
        self.last = np.array([t.intervals - 1 for t in unique], dtype=np.intp)
        self.t_min = np.array([t.temperature_range[0] for t in unique])
        self.t_max = np.array([t.temperature_range[1] for t in unique])
        self._set_maps(grey, index)

    @classmethod
    def build(cls, band=(3.8e-6, 5.1e-6), quantity: str = "photon", responsivity=None,
              emissivity=(1.0,), temperature_range=(150.0, 3000.0),
              per_octave: int | None = None, grey=1.0, index=None) -> "RadianceKernelTable":
        """
        Tables and exact radiances for a band and responsivity, one entry per emissivity
        (scalar: the blackbody table with that grey factor; spectral: its own table).
        """
        if not isinstance(emissivity, (list, tuple)):
            emissivity = [emissivity]
        tables, exact, entry_grey = [], [], []
        blackbody = None
        for value in emissivity:
            if np.isscalar(value):
                if blackbody is None:
                    blackbody = BandRadianceTable(band, quantity, responsivity, 1.0,
                                                  temperature_range, per_octave)
                tables.append(blackbody)
                exact.append(dict(band=band, quantity=quantity, responsivity=responsivity))
                entry_grey.append(float(value))
            else:
                tables.append(BandRadianceTable(band, quantity, responsivity, value,
                                                temperature_range, per_octave))
                exact.append(dict(band=band, quantity=quantity, responsivity=responsivity,
                                  emissivity=value))
                entry_grey.append(1.0)
        return cls(tables, exact, grey, index, entry_grey)

    def _set_maps(self, grey, index):
        if isinstance(grey, np.ndarray) and grey.ndim == 2:
            self.grey = np.ascontiguousarray(grey, dtype=np.float64)
            self.grey_scalar = None
        else:
            try:
                value = float(grey)
            except (TypeError, ValueError):
                raise RadiosimError(f"grey must be a number or a 2-D map, got {grey!r}") from None
            if not math.isfinite(value):
                raise RadiosimError(f"grey must be finite, got {grey!r}")
            self.grey, self.grey_scalar = value, value
        if index is None:
            self.index = None
        else:
            index = np.asarray(index)
            if index.ndim != 2 or not np.issubdtype(index.dtype, np.integer):
                raise RadiosimError(f"index must be a 2-D integer map, got {index.dtype} "
                                    f"shape {index.shape}")
            if index.dtype != np.uint8:
                index = index.astype(np.intp, copy=False)
            self.index = np.ascontiguousarray(index)
            if self.grey_scalar is None and self.grey.shape != self.index.shape:
                raise RadiosimError(f"grey map shape {self.grey.shape} and index map shape "
                                    f"{self.index.shape} differ")

    def with_maps(self, grey=_UNCHANGED, index=_UNCHANGED) -> "RadianceKernelTable":
        """The same tables with other grey and/or index maps (e.g. those of the next frame)."""
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        other._set_maps(self.grey if grey is _UNCHANGED else grey,
                        self.index if index is _UNCHANGED else index)
        return other

    @property
    def n_entries(self) -> int:
        return int(self.entry_table.size)

    def _mode(self) -> int:
        if self.index is not None:
            return _SIGNAL_INDEX
        return _SIGNAL_SCALAR if self.grey_scalar is not None else _SIGNAL_MAP

    def _check_maps(self, shape):
        if self.index is None and self.n_entries > 1:
            raise RadiosimError(f"{self.n_entries} radiance table entries need an index map "
                                "(the entry of every sample): see with_maps")
        for name, value in (("grey map", None if self.grey_scalar is not None else self.grey),
                            ("index map", self.index)):
            if value is not None and value.shape != tuple(shape):
                raise RadiosimError(f"{name} has shape {value.shape}, expected the frame "
                                    f"region's shape {tuple(shape)}")

    def _exact(self, entry: int, t: np.ndarray) -> np.ndarray:
        spec = self.exact[entry]
        if spec is None:
            lo = self.tables[entry].temperature_range[0]
            raise RadiosimError(
                f"temperature {t.min():g} K is below the radiance table's range (from {lo:g} K) "
                "and no exact radiance was given for it"
            )
        if isinstance(spec, Mapping):
            return band_radiance(t, **spec)
        return np.asarray(spec(t), dtype=float)

    def signal(self, temperature: np.ndarray, grey=None, index=None) -> np.ndarray:
        """
        S = L_e(T) · grey_e · grey of samples (numpy, the reference): the table inside its
        range, the exact radiance below it. ``grey`` and ``index`` are the values of the maps at
        those samples (default: the scalar grey, entry 0).
        """
        t = np.asarray(temperature, dtype=np.float64)
        out = np.empty(t.shape)
        entries = np.zeros(t.shape, dtype=np.intp) if index is None else np.asarray(index)
        factor_map = self.grey_scalar if grey is None else np.asarray(grey, dtype=np.float64)
        for e in np.unique(entries):
            here = entries == e
            te = t[here]
            table = self.tables[e]
            lo, hi = table.temperature_range
            radiance = np.empty(te.shape)
            cold = te < lo
            radiance[~cold] = table(te[~cold])
            if cold.any():
                radiance[cold] = self._exact(int(e), te[cold])
            if np.ndim(factor_map) == 0:
                factor = self.entry_grey[e] * factor_map
            else:
                factor = self.entry_grey[e] * factor_map[here]
            out[here] = radiance * factor
        return out


# -- checks and messages ------------------------------------------------------------------------


def _touched(frame2d: np.ndarray, rows: _Axis, cols: _Axis):
    """The samples the pieces read (unique rows × unique columns), as float64, with their
    region-relative row and column indices."""
    r = np.unique(rows.source)
    c = np.unique(cols.source)
    return np.asarray(frame2d[np.ix_(r, c)], dtype=np.float64), r, c


def _raise_bad_sample(frame2d, rows: _Axis, cols: _Axis, k: int):
    """The error of the first non-finite or ≤ 0 K sample the pieces read, in the format of
    :func:`radiosim.checks.check_frame` (row and column in full-scene coordinates)."""
    values, r, c = _touched(frame2d, rows, cols)
    bad = ~((values > 0) & (values < np.inf))
    if not bad.any():  # the samples are fine: the NaN came from the reference c
        raise RadiosimError(f"frame {k}: the per-pixel reference (pixel_mean of the first "
                            "frame) must be finite")
    i, j = (int(v) for v in np.argwhere(bad)[0])
    raise RadiosimError(bad_sample_message(float(values[i, j]), k, int(r[i]) + rows.offset,
                                           int(c[j]) + cols.offset, int(bad.sum())))


def _entries(response: RadianceKernelTable, r, c):
    if response.index is None:
        return np.zeros((r.size, c.size), dtype=np.intp)
    return np.asarray(response.index[np.ix_(r, c)], dtype=np.intp)


def _raise_bad_index(frame2d, rows: _Axis, cols: _Axis, k: int, response):
    r, c = np.unique(rows.source), np.unique(cols.source)
    entries = _entries(response, r, c)
    bad = (entries < 0) | (entries >= response.n_entries)
    i, j = (int(v) for v in np.argwhere(bad)[0])
    raise RadiosimError(
        f"frame {k}: table index {entries[i, j]} at row {r[i] + rows.offset}, column "
        f"{c[j] + cols.offset} is not an entry of the radiance table (0–"
        f"{response.n_entries - 1}; {int(bad.sum())} such sample(s) in this frame)"
    )


def _raise_above_table(frame2d, rows: _Axis, cols: _Axis, k: int, response):
    values, r, c = _touched(frame2d, rows, cols)
    table_of = response.entry_table[_entries(response, r, c)]
    above = values > response.t_max[table_of]
    i, j = (int(v) for v in np.argwhere(above)[0])
    lo, hi = response.t_min[table_of[i, j]], response.t_max[table_of[i, j]]
    raise RadiosimError(
        f"frame {k}: temperature {values[i, j]:g} K at row {r[i] + rows.offset}, column "
        f"{c[j] + cols.offset} is outside the radiance table's range {lo:g}–{hi:g} K (above "
        f"it; {int(above.sum())} such sample(s) in this frame)"
    )


def _check_samples(frame2d, rows: _Axis, cols: _Axis, k: int, response) -> bool:
    """Raise for bad samples, indices or samples above the table (the reference path's
    checks); True if some samples are below their table."""
    values, r, c = _touched(frame2d, rows, cols)
    if not np.all((values > 0) & (values < np.inf)):
        _raise_bad_sample(frame2d, rows, cols, k)
    if response is None:
        return False
    entries = _entries(response, r, c)
    if np.any((entries < 0) | (entries >= response.n_entries)):
        _raise_bad_index(frame2d, rows, cols, k, response)
    table_of = response.entry_table[entries]
    if np.any(values > response.t_max[table_of]):
        _raise_above_table(frame2d, rows, cols, k, response)
    return bool(np.any(values < response.t_min[table_of]))


# -- numpy references ---------------------------------------------------------------------------


def _pieces(field: np.ndarray, rows: _Axis, cols: _Axis, dtype=np.float64) -> np.ndarray:
    """A field on the region grid, on the piece grid (a copy, in ``dtype``)."""
    return np.asarray(np.asarray(field)[rows.source][:, cols.source], dtype=dtype)


def _weighted_mean(values: np.ndarray, rows: _Axis, cols: _Axis) -> np.ndarray:
    """Area-weighted mean of piece values over each pixel (the integrator's pixel_mean)."""
    weighted = np.add.reduceat(values * rows.weight[:, None], rows.starts, axis=0)
    return np.add.reduceat(weighted * cols.weight[None, :], cols.starts, axis=1)


def pixel_mean_reference(frame, rows, cols, *, frame_index: int = 0) -> np.ndarray:
    """:func:`pixel_mean` in plain numpy (float64 throughout): the oracle."""
    rows, cols = _axis(rows, "row"), _axis(cols, "column")
    frame2d = _frame(frame, rows, cols)
    _check_samples(frame2d, rows, cols, frame_index, None)
    return _weighted_mean(_pieces(frame2d, rows, cols), rows, cols)


def _accumulate_numpy(frame2d, rows: _Axis, cols: _Axis, time_weight, reference, dev, sq, tmax,
                      signal_acc, response):
    t = _pieces(frame2d, rows, cols)  # [K], float64, on the piece grid
    deviation = t - np.repeat(np.repeat(reference, np.diff(rows.bounds), axis=0),
                              np.diff(cols.bounds), axis=1)
    dev += time_weight * _weighted_mean(deviation, rows, cols)
    sq += time_weight * _weighted_mean(deviation * deviation, rows, cols)
    peak = np.maximum.reduceat(np.maximum.reduceat(t, rows.starts, axis=0), cols.starts, axis=1)
    np.maximum(tmax, peak, out=tmax)
    if response is not None:
        grey = None if response.grey_scalar is not None else _pieces(response.grey, rows, cols)
        index = None if response.index is None else _pieces(response.index, rows, cols, np.intp)
        signal_acc += time_weight * _weighted_mean(response.signal(t, grey, index), rows, cols)


def _checked(frame, rows, cols, reference, dev, sq, tmax, signal_acc, response):
    """The axes and the 2-D frame of an accumulation, its per-pixel arrays checked."""
    rows, cols = _axis(rows, "row"), _axis(cols, "column")
    frame2d = _frame(frame, rows, cols)
    shape = (rows.n_pixels, cols.n_pixels)
    for name, array in (("reference", reference), ("dev", dev), ("sq", sq), ("tmax", tmax)):
        _per_pixel(array, shape, name)
    if response is not None:
        _per_pixel(signal_acc, shape, "signal_acc")
    return rows, cols, frame2d


def accumulate_reference(frame, rows, cols, time_weight: float, reference: np.ndarray,
                         dev: np.ndarray, sq: np.ndarray, tmax: np.ndarray,
                         signal_acc: np.ndarray | None = None,
                         response: RadianceKernelTable | None = None, *,
                         frame_index: int = 0) -> int:
    """:func:`accumulate` in plain numpy (float64, the integrator's reduceat arithmetic): the
    oracle, and the path for frames with samples below the radiance table. Same arguments,
    checks, errors and return value."""
    rows, cols, frame2d = _checked(frame, rows, cols, reference, dev, sq, tmax, signal_acc,
                                   response)
    if response is not None:
        response._check_maps(frame2d.shape)
    below = _check_samples(frame2d, rows, cols, frame_index, response)
    _accumulate_numpy(frame2d, rows, cols, float(time_weight), reference, dev, sq, tmax,
                      signal_acc, response)
    return STATUS_BELOW_TABLE if below else STATUS_OK


# -- compiled entry points ----------------------------------------------------------------------

_DUMMY_MAP = _read_only(np.zeros(1))
_DUMMY_INDEX = _read_only(np.zeros(1, dtype=np.uint8))
_DUMMY_SIGNAL = np.zeros((1, 1))
# Table arguments of the kernel without a response (flat coefficients, k₀, shift, last interval,
# row offset, T_min, T_max, entry tables, entry grey factors).
_NO_TABLE = (np.zeros(4), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.uint64),
             np.zeros(1, dtype=np.intp),
             np.zeros(1, dtype=np.uint64), np.zeros(1), np.full(1, np.inf),
             np.zeros(1, dtype=np.intp), np.ones(1))


_BUFFERS = threading.local()


def _buffers(n_blocks: int, size: int, n_slots: int, dtype, index_dtype) -> tuple:
    """Per-thread buffers for the duplicate slots' samples (frame rows, grey map row, index map
    row), each as a writeable array and a read-only view of it, and the running maximum and
    minimum of every slot (frame dtype)."""
    key = (n_blocks, size, n_slots, np.dtype(dtype), np.dtype(index_dtype))
    cache = _BUFFERS.__dict__.setdefault("cache", {})  # per calling thread
    cached = cache.get(key)
    if cached is None:
        rows = np.empty((n_blocks, _MAX_ROWS, size), dtype=dtype)
        grey = np.empty((n_blocks, size))
        index = np.empty((n_blocks, size), dtype=index_dtype)
        extremes = (np.empty((n_blocks, n_slots), dtype=dtype),
                    np.empty((n_blocks, n_slots), dtype=dtype))
        cached = (rows, _read_only(rows), grey, _read_only(grey), index, _read_only(index),
                  *extremes)
        if len(cache) > 8:
            cache.clear()
        cache[key] = cached
    return cached


def _blocks(n_rows: int, threads: int | None = None) -> int:
    """Blocks of pixel rows: one per thread."""
    if threads is None:
        threads = numba.get_num_threads()
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
    rows, cols = _axis(rows, "row"), _axis(cols, "column")
    shape = (rows.n_pixels, cols.n_pixels)
    mean, sq, tmax = np.zeros(shape), np.zeros(shape), np.full(shape, -np.inf)
    accumulate(frame, rows, cols, 1.0, _zeros(shape), mean, sq, tmax, frame_index=frame_index,
               threads=threads)
    return mean


_ZEROS: dict[tuple[int, int], np.ndarray] = {}
_ONES: dict[int, np.ndarray] = {}


def _ones(n: int) -> np.ndarray:
    """A read-only row of n ones (the grey map row of a scalar grey factor)."""
    ones = _ONES.get(n)
    if ones is None:
        _ONES.clear()
        ones = _ONES[n] = _read_only(np.ones(n))
    return ones



def _zeros(shape: tuple[int, int]) -> np.ndarray:
    """A read-only per-pixel array of zeros (kept per shape)."""
    zeros = _ZEROS.get(shape)
    if zeros is None:
        _ZEROS.clear()
        zeros = _ZEROS[shape] = _read_only(np.zeros(shape))
    return zeros


def accumulate(frame, rows, cols, time_weight: float, reference: np.ndarray, dev: np.ndarray,
               sq: np.ndarray, tmax: np.ndarray, signal_acc: np.ndarray | None = None,
               response: RadianceKernelTable | None = None, *, frame_index: int = 0,
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
        :class:`RadianceKernelTable` (with the frame's emissivity maps), or ``None`` for no
        signal (the linear response: the signal is T).
    frame_index
        Frame index k, for error messages.
    threads
        Threads (blocks of pixel rows) for this call; ``None``: numba's current number
        (``numba.get_num_threads()``). On a machine whose cores are busy with other work
        (e.g. a thread preparing the next frame), one thread can be faster: a descheduled
        thread stalls the whole parallel region.

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
    rows, cols, frame2d = _checked(frame, rows, cols, reference, dev, sq, tmax, signal_acc,
                                   response)
    if not reference.flags.writeable:  # the kernel takes one array type (it writes it only
        reference = reference.copy()  # when merging)
    def handle(f, launched):
        return _finish(launched, frame2d, rows, cols, frame_index, response,
                       float(time_weight), reference, dev, sq, tmax, signal_acc, None)

    return _launch(frame2d[None], rows, cols, float(time_weight), reference, dev, sq, tmax,
                   signal_acc, response, None, threads, handle)


class Members:
    """
    The accumulators of the jobs that share a footprint group in the integrator's compiled
    engine (:func:`accumulate_merged`): per job b, the merged mean [K], M2 [K²] (sum of the
    weights × squared deviations), maximum [K] and time-weighted signal of each pixel, stacked
    as (jobs, pixel rows, pixel columns), and the total weight n_b merged so far.
    """

    def __init__(self, n_jobs: int, shape: tuple[int, int]):
        self.mean = np.zeros((n_jobs, *shape))
        self.m2 = np.zeros((n_jobs, *shape))
        self.max = np.full((n_jobs, *shape), -np.inf)
        self.signal = np.zeros((n_jobs, *shape))
        self.count = np.zeros(n_jobs)


_NO_MEMBERS = (False, False, np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)),
               np.zeros((1, 1, 1)), np.zeros((1, 1, 1)), np.zeros((1, 1, 1)),
               np.zeros((1, 1, 1)))


def _per_frame(values, n_frames: int, n_jobs: int, name: str) -> np.ndarray:
    """Per-frame, per-job weights as a C-contiguous (frames, jobs) float64 array."""
    try:
        a = np.asarray(values, dtype=np.float64)
        got = f"shape {a.shape}"
    except (TypeError, ValueError):
        a, got = np.zeros(0), "ragged or non-numeric values"
    if a.ndim == 1:
        a = a[None]
    if a.shape != (n_frames, n_jobs):
        raise RadiosimError(f"{name} must have shape ({n_jobs},) for one frame or "
                            f"({n_frames}, {n_jobs}) for {n_frames} frames (one weight per "
                            f"frame and job), got {got}")
    return np.ascontiguousarray(a)


def accumulate_merged(frame, rows, cols, reference: np.ndarray, members: Members,
                      weight: np.ndarray, signal_weight: np.ndarray,
                      response: RadianceKernelTable | None = None, *, moments: bool = True,
                      frame_index: int = 0, threads: int | None = None) -> int:
    """
    One frame into the accumulators of several jobs on the same footprints, in one pass: the
    frame's per-pixel mean m = c + Σ w (T − c) and variance v = Σ w (T − c)² − (Σ w (T − c))²
    (c = ``reference``, the previous frame's means) are merged into job b with its time weight
    ``weight[b]`` (0: the frame is not in its window) by the update of Chan, Golub & LeVeque
    (1979), its maximum raised, and ``signal_weight[b]`` × the frame's mean signal added to its
    signal. ``reference`` then holds m. With ``moments`` off, only the signals are added (a
    second response on the same footprints) and ``reference`` is kept. ``members.count`` is
    updated here. Checks, errors and return value as :func:`accumulate`.

    ``frame`` may also be several consecutive frames (3-D: frames, rows, columns; frame
    indices ``frame_index``, ``frame_index + 1``, …) with ``weight`` and ``signal_weight`` one
    row per frame: they are merged one after the other, exactly as frame by frame, in one call
    (no per-frame Python or thread start-up).
    """
    rows, cols = _axis(rows, "row"), _axis(cols, "column")
    block = _frames(frame, rows, cols)
    n_frames, n_jobs = block.shape[0], members.count.size
    weight = _per_frame(weight, n_frames, n_jobs, "weight")
    signal_weight = _per_frame(signal_weight, n_frames, n_jobs, "signal_weight")
    if not moments:
        weight = np.zeros_like(weight)
    # n_b before each frame, and after the last, added up frame by frame.
    counts = np.cumsum(np.vstack([members.count[None], weight]), axis=0)
    merged = (True, bool(moments), weight, counts[:-1], signal_weight, members.mean,
              members.m2, members.max, members.signal)

    def handle(f, launched):
        one = (True, bool(moments), weight[f], counts[f], signal_weight[f], members.mean,
               members.m2, members.max, members.signal)
        return _finish(launched, block[f], rows, cols, frame_index + f, response, 1.0,
                       reference, None, None, None, None, (one, members))

    shape = reference.shape
    status = _launch(block, rows, cols, 1.0, reference, _scratch(shape, 0), _scratch(shape, 1),
                     _scratch(shape, 2), _scratch(shape, 3), response, merged, threads, handle)
    if moments:
        members.count[...] = counts[-1]
    return status


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


def _launch(block, rows: _Axis, cols: _Axis, time_weight, reference, dev, sq, tmax,
            signal_acc, response, merged, threads, handle) -> int:
    """Run the compiled kernel on the frames of ``block`` (3-D; several only when merging,
    with ``merged``'s weights one row per frame). A frame with a status stops the blocks of
    pixel rows that saw it; in frame order, ``handle(f, (OR of its rows' bits, the rows'
    status array, the table))`` deals with it (raises, or redoes the flagged rows) and returns
    a status, and those blocks go on from the next frame. Returns the OR of the handled
    statuses (STATUS_OK if none)."""
    shape = (rows.n_pixels, cols.n_pixels)
    base, row_length, frame_stride = _frames_of(block)
    frame_shape = block.shape[1:]
    if response is None:
        mode, signal, table = _SIGNAL_NONE, _DUMMY_SIGNAL, None
        grey_map, index_map, map_length, use_map, grey = _DUMMY_MAP, _DUMMY_INDEX, 0, False, 1.0
        coef, key0, shift, last, offset, t_min, t_max, entry_table, entry_grey = _NO_TABLE
    else:
        if not isinstance(response, RadianceKernelTable):
            raise RadiosimError(f"response must be a RadianceKernelTable or None, got "
                                f"{type(response).__name__}")
        signal = signal_acc if signal_acc is not None else _scratch(shape, 3)
        response._check_maps(frame_shape)
        mode = response._mode()
        table = response
        use_map = response.grey_scalar is None
        # The kernel's grey factor: S = L · grey (mode 1), L · (grey · map) (mode 2),
        # L · grey_e · grey or L · grey_e · map (mode 3), as RadianceKernelTable.signal.
        if mode == _SIGNAL_SCALAR:
            grey = response.entry_grey[0] * response.grey_scalar
        elif mode == _SIGNAL_MAP:
            grey = response.entry_grey[0]
        else:
            grey = 1.0 if use_map else response.grey_scalar
        grey_map, map_length = (_rows_of(response.grey) if use_map
                                else (_ones(frame_shape[1]), 0))
        if response.index is not None:
            index_map, map_length = _rows_of(response.index)
        else:
            index_map = _DUMMY_INDEX
        coef, key0, shift, last, offset = (response.coefficients, response.key0,
                                           response.shift, response.last, response.offset)
        t_min, t_max = response.t_min, response.t_max
        entry_table, entry_grey = response.entry_table, response.entry_grey
    n_frames = block.shape[0]
    status = np.zeros((n_frames, rows.n_pixels), dtype=np.int64)
    slot_runs, slot_weight, slot_of_piece, dup_source, col_bounds, layout = cols.slots
    n_blocks = _blocks(rows.n_pixels, threads)
    buffers = _buffers(n_blocks, max(1, dup_source.size), slot_weight.size, base.dtype,
                       index_map.dtype)
    members = merged if merged is not None else _NO_MEMBERS
    start = np.zeros(n_blocks, dtype=np.int64)
    pending = np.full(n_blocks, -1, dtype=np.int64)  # a frame whose status awaits handling
    handled = STATUS_OK
    previous = numba.get_num_threads()
    if n_blocks != previous and n_blocks <= numba.config.NUMBA_NUM_THREADS:
        numba.set_num_threads(n_blocks)
    try:
        while True:
            run = np.where(pending >= 0, n_frames, start)
            with parallel_launch():
                stopped = _accumulate_kernel(
                    n_blocks, run, n_frames, frame_stride, base, row_length, rows.source,
                    rows.weight, rows.bounds, cols.extent, slot_runs, slot_weight,
                    slot_of_piece, dup_source, col_bounds, layout, time_weight, reference, dev,
                    sq, tmax, signal, *members, mode, coef, key0, shift, last, offset, t_min,
                    t_max, entry_table, entry_grey, float(grey), grey_map, index_map,
                    map_length, use_map, *buffers, status)
            ran = run < n_frames
            pending[ran & (stopped < n_frames)] = stopped[ran & (stopped < n_frames)]
            start[ran] = np.minimum(stopped[ran] + 1, n_frames)
            if not np.any(pending >= 0):
                return handled
            # The earliest frame with a status: every block has either passed it cleanly or
            # stopped at or after it, so its flagged rows are handled in frame order.
            f = int(pending[pending >= 0].min())
            result = int(np.bitwise_or.reduce(status[f]))
            handled |= handle(f, (result, status[f], table))
            pending[pending == f] = -1
    finally:
        if numba.get_num_threads() != previous:
            numba.set_num_threads(previous)


def _finish(launched, frame2d, rows: _Axis, cols: _Axis, frame_index, response, time_weight,
            reference, dev, sq, tmax, signal_acc, merged):
    """Raise for a flagged frame, or redo its pixel rows with samples below the table in numpy
    (exact quadrature for those samples); returns STATUS_BELOW_TABLE."""
    result, status, table = launched
    if result & STATUS_BAD_SAMPLE:
        _raise_bad_sample(frame2d, rows, cols, frame_index)
    if result & STATUS_BAD_INDEX:
        _raise_bad_index(frame2d, rows, cols, frame_index, table)
    if result & STATUS_ABOVE_TABLE:
        _raise_above_table(frame2d, rows, cols, frame_index, table)
    # Samples below the table: those pixel rows were left untouched; redo them in numpy.
    shape = (rows.n_pixels, cols.n_pixels)
    flagged = np.flatnonzero(status)
    start, stop = int(flagged[0]), int(flagged[-1]) + 1
    part = rows.pixels(start, stop)
    n = stop - start
    part_dev, part_sq, part_signal = (np.zeros((n, shape[1])) for _ in range(3))
    part_max = np.full((n, shape[1]), -np.inf)
    _accumulate_numpy(frame2d, part, cols, time_weight, reference[start:stop], part_dev,
                      part_sq, part_max, part_signal, response)
    local = flagged - start
    if merged is None:
        dev[flagged] += part_dev[local]
        sq[flagged] += part_sq[local]
        signal_acc[flagged] += part_signal[local]
        tmax[flagged] = np.maximum(tmax[flagged], part_max[local])
        return STATUS_BELOW_TABLE
    (_, moments, weight, count, signal_weight, mean, m2, peak, signal), _ = merged
    d, v1, s = part_dev[local], part_sq[local], part_signal[local]
    for b in range(weight.size):
        if signal_weight[b] > 0:
            signal[b, flagged] += signal_weight[b] * s
    if moments:
        frame_mean = reference[flagged] + d
        frame_var = np.maximum(v1 - d * d, 0.0)
        for b in range(weight.size):
            w = weight[b]
            if w > 0:
                n_b = count[b]
                total = n_b + w
                delta = frame_mean - mean[b, flagged]
                m2[b, flagged] += w * frame_var + delta * delta * (n_b * w / total)
                mean[b, flagged] += delta * (w / total)
                peak[b, flagged] = np.maximum(peak[b, flagged], part_max[local])
        reference[flagged] = frame_mean
    return STATUS_BELOW_TABLE

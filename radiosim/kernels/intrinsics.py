"""
LLVM intrinsics and inline arithmetic of the compiled kernels: a fused multiply-add
(``llvm.fma``), a vectorisable exp (:data:`fast_exp`), the eight-sample cubic evaluations
(rows of four coefficients loaded whole and transposed into vectors by shuffles, Horner by
vector fused multiply-adds) that the radiance pass uses (:mod:`radiosim.kernels.radiance`).

``JIT`` holds the options of the package's entry points (the integrator's kernel, one for both
frame dtypes), ``INNER`` those of the helpers they call.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir as llvm_ir
from numba.core import types
from numba.extending import intrinsic

__all__ = ["JIT", "INNER", "INF", "FRAME_DTYPES", "fast_exp"]

#: The options of a compiled entry point (a kernel launched from Python): kept in numba's
#: on-disk cache; a CPython wrapper, no C one (nothing calls the kernels from C).
JIT = dict(cache=True, fastmath=False, nogil=True, error_model="numpy", no_cfunc_wrapper=True)
#: A helper called only from compiled code: no CPython or C wrapper is generated for it (each
#: wrapper unboxes every argument: about a sixth of the compile time of the kernels), and not
#: cached on its own (its callers' cache holds it).
INNER = dict(JIT, cache=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
#: The frame dtypes the kernels read in place.
FRAME_DTYPES = ("float32", "float64")
INF = np.inf

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


@numba.njit(**JIT)
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

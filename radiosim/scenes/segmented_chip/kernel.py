"""
The segmented chip's moving terms, compiled (numba): one row-parallel pass writing a frame.

A frame is the static field plus the moving terms on four index sets of the region
(:class:`~.geometry.RegionData`): the travelling modulation (``periodic``), the released bands
(``chip``), the forming band (``forming``) and the free surface (``surface``), each stored as
runs of columns per row (:class:`~.compiled.KernelLayout`). :func:`moving_terms_kernel` writes
the frame in one pass over the region's rows (one block of rows of about equal work per
thread): each row is copied from the
static field and, while it is in cache, each term is applied to its runs in the reference's
order (modulation, released bands, forming band, surface), so every sample sees the reference's
(:mod:`.reference`) operations in the reference's order. The coordinates n, ζ, ξ of a sample are
recomputed from its (x, y) with :class:`~.geometry.Geometry`'s arithmetic (bitwise the same;
fastmath is off: no reassociation, no FMA contraction), so only the modulation's two fields are
read per sample besides the static field. exp is ``_exp`` below, not libm's, so that the loops
vectorise (relative error < 1e-15): the two implementations differ by rounding only (< 1e-15
relative in temperature, the region map identical).

The kernel's scalars travel in one named bundle, :class:`KernelConstants` (a numba-supported
named tuple of floats): the grid's constants, set once per region, and five set per frame; the
region's runs and fades in another, :class:`RunLayout` (no function takes over 20 arguments).
Everything here compiles on first use and is cached on disk; importing compiles nothing.

References
----------
-   Whitenton, E. P., Heigel, J. C. & Ivester, R. W. (2009). ASME MSEC2009-84319.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from radiosim.kernels import fast_exp

__all__ = ["KernelConstants", "RunLayout", "SET_PERIODIC", "SET_CHIP", "SET_FORMING", "SET_SURFACE",
           "PAD", "moving_terms_kernel", "kernel_coordinates"]

_JIT = dict(cache=True, fastmath=False, nogil=True, error_model="numpy", boundscheck=False,
            no_cfunc_wrapper=True)  # launched from Python only: no C wrapper
# Helpers called only from compiled code get no CPython or C wrapper (each unboxes every
# argument) and no cache files of their own (the kernel's hold them); small ones called from
# one place are inlined into it by numba (not compiled on their own and again inside their
# caller: about half the compile). numba's inlining copies the helper's IR and types it
# again, so the largest, the row pass, is written in the kernel itself.
_INNER = dict(_JIT, cache=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
_ONCE = dict(_INNER, inline="always")


class KernelConstants(NamedTuple):
    """The kernel's scalars (all float64): the grid's, and per frame the five marked *."""

    tip_x: float  #: tool tip x [m]
    tip_y: float  #: tool tip y [m]
    sin_a: float  #: sin α, rake angle
    cos_a: float  #: cos α
    cos_g: float  #: cos γ, clearance angle
    sin_g: float  #: sin γ
    tan_tb: float  #: tan θ_b, band angle
    sin_tb: float  #: sin θ_b
    cos: float  #: * cos of the modulation's angle
    sin: float  #: * sin of the modulation's angle
    step: float  #: step of the released bands' ζ profile grid [m]
    first: float  #: index of the profile grid's first node (ζ = first·step)
    log_base: float  #: * ln of the forming band's growth
    reach: float  #: * |ξ| reach of the forming band [m]
    exp_tip: float  #: the band exponent m at the tool tip
    exp_slope: float  #: 1 − m at the tool tip
    exp_reach: float  #: n where m reaches 1 [m]
    sigma: float  #: σ_rel, released band width [m]
    sigma_span: float  #: σ_init − σ_rel [m]
    amplitude: float  #: A, band amplitude [K]
    d: float  #: * chip displacement d [m]
    pitch: float  #: segment pitch p_c [m]
    min_t: float  #: h_min [m]
    span_t: float  #: h_max − h_min [m]
    ambient: float  #: air temperature [K]


class RunLayout(NamedTuple):
    """Where the moving terms act (:class:`~.compiled.KernelLayout`, once per region): the index
    sets as runs of columns per row, and the rake-face fade of each row's faded columns."""

    #: float64, columns + PAD: the columns' x coordinates [m], padded with finite values.
    x: np.ndarray
    #: int64 (4, rows + 1): the runs of index set s on row i are ``ptr[s, i]:ptr[s, i + 1]``.
    ptr: np.ndarray
    #: int64 (runs, 3): first column, end column, and (modulation) first field sample of a run.
    runs: np.ndarray
    #: float64: the fades of the faded columns, row after row.
    fade: np.ndarray
    #: int64 (rows + 1, 2): each row's first fade in ``fade`` and first faded column.
    fade_rows: np.ndarray


# Index sets, in the order the kernel applies them (rows of the layout's run pointers).
SET_PERIODIC, SET_CHIP, SET_FORMING, SET_SURFACE = range(4)

# The spans take views of a row's run of columns and loop from 0 to their size: the index is
# then known to be ≥ 0, which spares numba's negative-index wraparound and lets LLVM vectorise.
# The costly loops (exp, divisions) run over a multiple of PAD samples, writing scratch space:
# no sample is left to the scalar remainder loop; the x coordinates are padded for them.
PAD = 16

# exp(x) inline and vectorisable: the integrator kernels' (Cody–Waite reduction, Taylor
# polynomial), shared so both evaluate it alike.
_exp = fast_exp
_INF = np.inf


@numba.njit(**_INNER)
def _coordinates(xj, dyv, k):
    """(n, ζ) of the sample at x = ``xj``, y − y_tip = ``dyv``: Geometry's arithmetic."""
    dxv = xj - k.tip_x
    s = dxv * k.sin_a + dyv * k.cos_a
    u = dxv * k.cos_g + dyv * k.sin_g
    n = -u
    return n, s - n / k.tan_tb


@numba.njit(**_INNER)
def _padded(size):
    """``size`` rounded up to a multiple of PAD."""
    return (size + PAD - 1) // PAD * PAD


@numba.njit(**_INNER)
def _chip_span(row, x, dyv, k, profile, fade, faded, position):
    """Released bands on the samples of ``row`` (x coordinates ``x``, padded): the ζ profile
    interpolated, faded at the rake face (``faded``: by ``fade``). ``position`` is scratch."""
    step, first = k.step, k.first
    for j in range(_padded(row.size)):  # vectorised: the profile's fractional index
        n, zeta = _coordinates(x[j], dyv, k)
        position[j] = zeta / step - first  # ≥ 1: the grid starts a step before the region's ζ
    last, one = np.uintp(profile.size - 2), np.uintp(1)  # unsigned: no wraparound
    for j in range(row.size):  # the gather
        index = min(np.uintp(position[j]), last)
        frac = position[j] - index
        left = profile[index]
        excess = left + frac * (profile[index + one] - left)
        if faded:
            excess *= fade[j]
        row[j] += excess


@numba.njit(**_ONCE)
def _forming_values(excess, f, xi, x, dyv, k, count):
    """The forming band's exp(ξ²/(−2σ²))·f on ``count`` samples (x coordinates ``x``) into
    ``excess``, 0 where |ξ| is beyond its reach (so that adding it changes nothing); ``f`` and
    ``xi`` are scratch. Two loops: each exp's latency then overlaps the next sample's."""
    sin_tb, reach, log_base = k.sin_tb, k.reach, k.log_base
    tip, slope, reach_n = k.exp_tip, k.exp_slope, k.exp_reach
    sigma_b, span = k.sigma, k.sigma_span
    for j in range(count):
        n, zeta = _coordinates(x[j], dyv, k)
        xi[j] = zeta * sin_tb
        m = tip + slope * min(max(n / reach_n, 0.0), 1.0)
        f[j] = _exp(m * log_base)
    for j in range(count):
        sigma = (1.0 - f[j]) * (1.0 - f[j])
        sigma *= span
        sigma += sigma_b
        sigma *= sigma
        sigma *= -2.0
        value = _exp(xi[j] * xi[j] / sigma)
        value *= f[j]
        excess[j] = value if abs(xi[j]) < reach else 0.0


@numba.njit(**_ONCE)
def _forming_values_saturated(excess, x, dyv, k, count, f, sigma):
    """:func:`_forming_values` where every sample has n ≥ the exponent's reach: m = 1, so f
    and σ are the same for all (``f``, ``sigma``: computed as per sample, once)."""
    sin_tb, reach = k.sin_tb, k.reach
    for j in range(count):
        n, zeta = _coordinates(x[j], dyv, k)
        xi = zeta * sin_tb
        value = _exp(xi * xi / sigma)
        value *= f
        excess[j] = value if abs(xi) < reach else 0.0


@numba.njit(**_INNER)
def _forming_piece(excess, scratch_f, scratch_xi, x, dyv, k, count, saturated, f, sigma):
    """The forming band's values on a piece of a run, saturated or not."""
    if saturated:
        _forming_values_saturated(excess, x, dyv, k, _padded(count), f, sigma)
    else:
        _forming_values(excess, scratch_f, scratch_xi, x, dyv, k, _padded(count))


@numba.njit(**_INNER)
def _forming_add(row, excess, fade, faded, amplitude):
    """row += A·excess (·fade where ``faded``)."""
    for j in range(row.size):
        value = excess[j]
        if faded:
            value *= fade[j]
        row[j] += amplitude * value


@numba.njit(**_ONCE)
def _forming_run(row, x, dyv, k, scratch, fade, a, b, f, sigma):
    """The forming band on a run (x coordinates ``x``, padded; faded on its samples a … b − 1
    by ``fade``). The run is split where n crosses the exponent's reach (n is monotone along a
    row, so the samples beyond it lead or trail): f and σ are computed per sample only below
    it. ``scratch``: three rows of space."""
    size = row.size
    reach_n = k.exp_reach
    saturated = 0
    for j in range(size):
        saturated += _coordinates(x[j], dyv, k)[0] >= reach_n
    excess, scratch_f, scratch_xi = scratch[0], scratch[1], scratch[2]
    if saturated == 0 or saturated == size:
        _forming_piece(excess, scratch_f, scratch_xi, x, dyv, k, size, saturated > 0, f, sigma)
    else:
        leading = _coordinates(x[0], dyv, k)[0] >= reach_n
        split = saturated if leading else size - saturated
        _forming_piece(excess, scratch_f, scratch_xi, x, dyv, k, split, leading, f, sigma)
        _forming_piece(excess[split:], scratch_f, scratch_xi, x[split:], dyv, k, size - split,
                       not leading, f, sigma)
    amplitude = k.amplitude
    _forming_add(row[:a], excess[:a], fade, False, amplitude)
    _forming_add(row[a:b], excess[a:b], fade, True, amplitude)
    _forming_add(row[b:], excess[b:], fade, False, amplitude)


@numba.njit(**_ONCE)
def _surface_span(row, region_row, want_regions, x, dyv, k):
    """The saw-tooth free surface on the samples of ``row``: beyond it, air."""
    d, pitch, min_t, span_t = k.d, k.pitch, k.min_t, k.span_t
    ambient = k.ambient
    for j in range(row.size):
        n, zeta = _coordinates(x[j], dyv, k)
        a = (zeta - d) / pitch
        frac = a - np.trunc(a)  # fmod(a, 1) exactly; then numpy.mod's sign rule
        if frac < 0.0:
            frac += 1.0
        if n > min_t + span_t * (1.0 - frac):
            row[j] = ambient
            if want_regions:
                region_row[j] = 0  # REGIONS["air"]


@numba.njit(**_INNER)
def _copy(target, source):
    """target[:] = source (a loop from 0: vectorised, and no call into numpy's copy)."""
    for j in range(target.size):
        target[j] = source[j]


@numba.njit(**_ONCE)
def _modulation_span(row, cos_field, sin_field, ca, sa):
    """The travelling modulation on the samples of ``row``."""
    for j in range(row.size):
        row[j] += ca * cos_field[j] + sa * sin_field[j]


@numba.njit(**_JIT)
def band_profile(grid, terms, nodes, sin_b):
    """The released bands' profile on ``grid`` (:func:`~.reference.band_profile`'s arithmetic,
    with _exp), computed once per frame before the threads of :func:`moving_terms_kernel`
    start."""
    profile = np.zeros(grid.size)
    for band in range(terms.shape[0]):
        zk, sigma2, amplitude = terms[band, 0], terms[band, 1], terms[band, 2]
        values = profile[nodes[band, 0]:nodes[band, 1]]
        band_grid = grid[nodes[band, 0]:nodes[band, 1]]
        for j in range(values.size):
            dz = (band_grid[j] - zk) * sin_b
            values[j] += amplitude * _exp(-dz * dz / (2 * sigma2))
    return profile


@numba.njit(**_JIT)
def moving_terms_kernel(thread, bounds, static, regions_static, out, regions_out, want_regions,
                        forming, y, k, profile, cos_field, sin_field, layout, bad):
    """Thread ``thread``'s share (the threads each on its own thread:
    :func:`radiosim.kernels.run_blocks`) of the frame over the region: rows bounds[thread] …
    bounds[thread + 1] − 1; together the threads write ``out`` (and, with ``want_regions``,
    ``regions_out``) in full, each row once. ``layout`` (:class:`RunLayout`) holds
    the runs, the fades and the columns' x coordinates and PAD more (any finite values);
    ``k`` the scalars (:class:`KernelConstants`); ``profile`` the released bands' profile on
    the ζ grid (:func:`band_profile`). Each row: the static row, then the moving terms on
    the row's runs.
    ``bad[thread]`` (int64): how many of the values the thread wrote are not finite and
    > 0 K (NaN, ±0, negative, ±inf: the frame's check, each row checked as it is written)."""
    # f = base^m and σ where the exponent m has saturated at 1 (n beyond its reach), with the
    # arithmetic of _forming_values.
    f_saturated = _exp((k.exp_tip + k.exp_slope * 1.0) * k.log_base)
    sigma_saturated = (1.0 - f_saturated) * (1.0 - f_saturated)
    sigma_saturated *= k.sigma_span
    sigma_saturated += k.sigma
    sigma_saturated *= sigma_saturated
    sigma_saturated *= -2.0
    n_blocks = bounds.size - 1
    x = layout.x
    ptr = layout.ptr
    runs = layout.runs
    fade = layout.fade
    fade_rows = layout.fade_rows
    ca, sa = k.cos, k.sin
    scratch = np.empty((3, out.shape[1] + PAD))
    n_cols = out.shape[1]
    flagged = np.int64(0)
    for block in range(thread, n_blocks, bad.size):  # bad: one entry per thread
        for i in range(bounds[block], bounds[block + 1]):
            # Row i of the frame: the static row, then the moving terms on the row's runs.
            row = out[i]
            _copy(row, static[i])
            region_row = regions_out[0]
            if want_regions:
                region_row = regions_out[i]
                _copy(region_row, regions_static[i])
            dyv = y[i] - k.tip_y
            # Travelling modulation of the secondary zone.
            for q in range(ptr[SET_PERIODIC, i], ptr[SET_PERIODIC, i + 1]):
                j0, j1, at = runs[q, 0], runs[q, 1], runs[q, 2]
                _modulation_span(row[j0:j1], cos_field[at:at + j1 - j0],
                                 sin_field[at:at + j1 - j0], ca, sa)
            # The row's faded columns [fade_lo, fade_hi) near the rake face, their fades from
            # fade[f0].
            f0 = fade_rows[i, 0]
            fade_lo = fade_rows[i, 1]
            fade_hi = fade_lo + fade_rows[i + 1, 0] - f0
            # Released bands.
            for q in range(ptr[SET_CHIP, i], ptr[SET_CHIP, i + 1]):
                j0, j1 = runs[q, 0], runs[q, 1]
                a = min(max(fade_lo, j0), j1)
                b = min(max(fade_hi, a), j1)
                _chip_span(row[j0:a], x[j0:], dyv, k, profile, fade, False, scratch[0])
                _chip_span(row[a:b], x[a:], dyv, k, profile, fade[f0 + max(a - fade_lo, 0):],
                           True, scratch[0])
                _chip_span(row[b:j1], x[b:], dyv, k, profile, fade, False, scratch[0])
            # The forming band.
            if forming:
                for q in range(ptr[SET_FORMING, i], ptr[SET_FORMING, i + 1]):
                    j0, j1 = runs[q, 0], runs[q, 1]
                    a = min(max(fade_lo, j0), j1)
                    b = min(max(fade_hi, a), j1)
                    _forming_run(row[j0:j1], x[j0:], dyv, k, scratch,
                                 fade[f0 + max(a - fade_lo, 0):], a - j0, b - j0, f_saturated,
                                 sigma_saturated)
            # The free surface.
            for q in range(ptr[SET_SURFACE, i], ptr[SET_SURFACE, i + 1]):
                j0, j1 = runs[q, 0], runs[q, 1]
                _surface_span(row[j0:j1], region_row[j0:j1] if want_regions else region_row,
                              want_regions, x[j0:], dyv, k)
            for j in range(n_cols):  # the row's check, while it is in cache
                v = row[j]
                flagged += not ((v > 0.0) & (v < _INF))
    bad[thread] = flagged


@numba.njit(**_JIT)
def kernel_coordinates(x, y, k):
    """(n, ζ) of every sample of the region as the kernel computes them (for the tests)."""
    n = np.empty((y.size, x.size))
    zeta = np.empty((y.size, x.size))
    for i in range(y.size):
        dyv = y[i] - k.tip_y
        for j in range(x.size):
            n[i, j], zeta[i, j] = _coordinates(x[j], dyv, k)
    return n, zeta

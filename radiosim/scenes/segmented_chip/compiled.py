"""
The segmented chip's compiled moving terms, the Python side: each region's run layout for the
kernel (:class:`KernelLayout`) and :func:`evaluate_compiled`, which fills the per-frame
constants and launches :func:`~.kernel.moving_terms_kernel` (the kernel itself is in
:mod:`.kernel`, the numpy model it reproduces in :mod:`.reference`).

References
----------
-   Whitenton, E. P., Heigel, J. C. & Ivester, R. W. (2009). ASME MSEC2009-84319.
"""

from __future__ import annotations

import math

import numpy as np

from radiosim.kernels import run_blocks, thread_count
from radiosim.scenes.base import Region
from radiosim.scenes.segmented_chip.geometry import Geometry, RegionData, rake_fade_of
from radiosim.scenes.segmented_chip.kernel import (PAD, KernelConstants, RunLayout,
                                                   band_profile, moving_terms_kernel)
from radiosim.scenes.segmented_chip.parameters import ChipParameters
from radiosim.scenes.segmented_chip.profiles import FADE_REACH
from radiosim.scenes.segmented_chip.reference import band_terms, forming_base, forming_reach, phase

__all__ = ["KernelLayout", "evaluate_compiled"]

#: Work (the units of :attr:`KernelLayout.work`, about one per copied sample) a frame needs
#: per thread: a small region's frame (a pixel's crop) is made on the calling
#: thread alone, the hand-over to another thread costing more than its share of the work.
_WORK_PER_THREAD = 1 << 17

_NO_PROFILE = np.zeros(2)
_NO_TERMS = np.zeros((0, 3))
_NO_NODES = np.zeros((0, 2), dtype=np.int64)
_NO_REGIONS = np.zeros((1, 1), dtype=np.uint8)


def _runs(flat: np.ndarray, rows: int, cols: int):
    """Row-major flat indices (sorted) as runs of consecutive columns: per-row pointers
    (rows + 1) into the runs, and each run's first column, end column and first position in
    ``flat``."""
    flat = np.asarray(flat, dtype=np.int64)
    if flat.size == 0:
        return np.zeros(rows + 1, dtype=np.int64), np.zeros((0, 3), dtype=np.int64)
    row, col = np.divmod(flat, cols)
    breaks = np.flatnonzero((np.diff(flat) != 1) | (np.diff(row) != 0)) + 1
    first = np.concatenate([[0], breaks])
    last = np.concatenate([breaks, [flat.size]]) - 1
    runs = np.column_stack([col[first], col[last] + 1, first]).astype(np.int64)
    ptr = np.searchsorted(row[first], np.arange(rows + 1)).astype(np.int64)
    return ptr, runs


class KernelLayout:
    """The run layout of one region for :func:`moving_terms_kernel`: each index set of the
    region (RegionData) as runs of columns per row, the rake-face fade on each row's faded
    columns, the grid constants, and the rows' work for splitting them among threads."""

    def __init__(self, p: ChipParameters, g: Geometry, region: Region, r: RegionData):
        rows, cols = r.shape
        sets = [r.periodic, r.chip, np.sort(r.forming), r.surface]
        ptr = np.zeros((len(sets), rows + 1), dtype=np.int64)
        runs = []
        total = 0
        for which, flat in enumerate(sets):
            ptr_s, runs_s = _runs(flat, rows, cols)
            ptr[which] = ptr_s + total
            runs.append(runs_s)
            total += runs_s.shape[0]
        self.ptr = ptr
        self.runs = np.ascontiguousarray(np.concatenate(runs))
        # Faded columns (n < 10 fade lengths) of the chip and forming samples: per row, the
        # span from the first to the last, with the fade where n is below the threshold and 1
        # (an exact no-op) elsewhere, as both the reference's terms have it.
        rs, cs = region
        n_sub = g.n[rs, cs].reshape(-1)
        threshold = FADE_REACH * p.rake_fade
        near = np.zeros(rows * cols, dtype=bool)
        near[r.chip] = near[r.forming] = True
        near = np.flatnonzero(near & (n_sub < threshold))
        fade_rows = np.zeros((rows + 1, 2), dtype=np.int64)
        values = []
        if near.size:
            row_of = near // cols
            starts = np.searchsorted(row_of, np.arange(rows + 1))
            offset = 0
            for i in range(rows):
                fade_rows[i, 0] = offset
                if starts[i + 1] > starts[i]:
                    lo = int(near[starts[i]] - i * cols)
                    hi = int(near[starts[i + 1] - 1] - i * cols) + 1
                    span = slice(i * cols + lo, i * cols + hi)
                    values.append(np.where(n_sub[span] < threshold,
                                           rake_fade_of(p, n_sub[span]), 1.0))
                    fade_rows[i, 1] = lo
                    offset += hi - lo
            fade_rows[rows, 0] = offset
        self.fade = np.concatenate(values) if values else np.ones(1)
        self.fade_rows = fade_rows
        # Grid constants (the per-frame entries are set by each evaluation).
        a, gamma, tb = p.rake_angle, p.clearance_angle, p.band_angle
        chip = r.chip.size > 0
        k = KernelConstants(
            tip_x=float(p.tool_tip_x), tip_y=float(p.tool_tip_y),
            sin_a=math.sin(a), cos_a=math.cos(a), cos_g=math.cos(gamma), sin_g=math.sin(gamma),
            tan_tb=math.tan(tb), sin_tb=math.sin(tb),
            cos=0.0, sin=0.0,
            step=float(r.zeta_step) if chip else 0.0, first=float(r.zeta_first) if chip else 0.0,
            log_base=0.0, reach=0.0,
            exp_tip=float(p.band_exponent_tip), exp_slope=float(1 - p.band_exponent_tip),
            exp_reach=float(p.band_exponent_reach * p.chip_thickness),
            sigma=float(p.band_width), sigma_span=float(p.band_initial_width - p.band_width),
            amplitude=float(p.band_amplitude),
            d=0.0,
            pitch=float(p.segment_pitch), min_t=float(p.min_thickness),
            span_t=float(p.max_thickness - p.min_thickness),
            ambient=float(p.ambient_temperature))
        self.constants = k
        self.x = np.concatenate([r.x, np.full(PAD, r.x[-1] if r.x.size else 0.0)])  # padded
        #: The kernel's bundle of the above (:class:`~.kernel.RunLayout`).
        self.run_layout = RunLayout(self.x, self.ptr, self.runs, self.fade, self.fade_rows)
        # Work per row, summed, for blocks of rows of equal work: relative costs (fitted to
        # timings of row blocks on one core) of a copied sample 1, and of a sample of the
        # modulation 8 (its two fields come from memory), of the released bands 6, of the
        # forming band 6 where its exponent has saturated and 19 elsewhere, of the free surface
        # 2. Two sums: with and without the forming band (absent during the slip).
        def per_row(flat):
            return np.bincount(np.asarray(flat, dtype=np.int64) // cols, minlength=rows)

        forming_n = n_sub[r.forming]
        saturated = r.forming[forming_n >= k.exp_reach]
        free = r.forming[~(forming_n >= k.exp_reach)]
        work = (cols + 8 * per_row(r.periodic) + 6 * per_row(r.chip) + 2 * per_row(r.surface))
        forming_work = 6 * per_row(saturated) + 19 * per_row(free)
        self.work = {False: np.concatenate([[0], np.cumsum(work)]),
                     True: np.concatenate([[0], np.cumsum(work + forming_work)])}
        self._bounds: dict[tuple[int, bool], np.ndarray] = {}

    def blocks(self, forming: bool) -> tuple[int, np.ndarray]:
        """The number of threads (numba's, at most one per row and per _WORK_PER_THREAD of
        work) and the row bounds of one block of about equal work per thread."""
        work = self.work[forming]
        rows = work.size - 1
        shares = min(rows, int(work[-1] // _WORK_PER_THREAD))  # numba is asked only if > 1
        threads = max(1, min(thread_count(), shares)) if shares > 1 else 1
        bounds = self._bounds.get((threads, forming))
        if bounds is None:
            count = threads
            inner = np.searchsorted(work, work[-1] * np.arange(1, count) / count)
            bounds = np.concatenate([[0], inner, [rows]]).astype(np.int64)
            self._bounds[threads, forming] = bounds = np.maximum.accumulate(bounds)
        return threads, bounds


def evaluate_compiled(p: ChipParameters, r: RegionData, layout: KernelLayout, t: float,
                      want_regions: bool = False):
    """
    The frame at time t [s] over the region of ``r``: the moving terms in one fused,
    row-parallel pass of :func:`~.kernel.moving_terms_kernel` over the region's rows, writing
    into a fresh copy of the static field (same results as
    :func:`~.reference.evaluate_reference` to rounding; the region map exactly).

    Returns
    -------
    temperature : numpy.ndarray
        The frame [K].
    regions : numpy.ndarray or None
        The region map with ``want_regions``, else None.
    clean : bool
        Every value finite and > 0 K (the kernel's check of what it wrote).
    """
    tau, theta, d = phase(p, t)
    angle = 2 * np.pi * (theta - p.modulation_phase)
    base = forming_base(p, theta)
    forming = base > 0 and r.forming.size > 0
    if r.chip.size:
        grid, (terms, nodes) = r.zeta_grid, band_terms(p, r, tau, d)
    else:
        grid, terms, nodes = _NO_PROFILE, _NO_TERMS, _NO_NODES
    if forming:
        frame = layout.constants._replace(cos=math.cos(angle), sin=math.sin(angle), d=float(d),
                                          log_base=math.log(base),
                                          reach=float(forming_reach(p, base)))
    else:
        frame = layout.constants._replace(cos=math.cos(angle), sin=math.sin(angle), d=float(d))
    temperature = np.empty(r.shape)
    regions = np.empty(r.shape, dtype=np.uint8) if want_regions else _NO_REGIONS
    threads, blocks = layout.blocks(forming)
    bad = np.empty(threads, dtype=np.int64)  # per thread: values not finite and > 0 K
    profile = band_profile(grid, terms, nodes, frame.sin_tb)
    run_blocks(moving_terms_kernel, threads, blocks, r.static, r.regions, temperature,
               regions, want_regions, forming, r.y, frame, profile, r.cos_field, r.sin_field,
               layout.run_layout, bad)
    # Every value finite and > 0 K (see moving_terms_kernel): the frame's check is done.
    clean = not any(bad.tolist())  # (a list: no numpy call per frame)
    return temperature, (regions if want_regions else None), clean

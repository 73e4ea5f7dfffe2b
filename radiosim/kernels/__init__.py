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

-   pixel rows are split in one contiguous block per thread (:func:`run_blocks`: radiosim's
    own threads, the kernels releasing the GIL; numba's ``prange`` cost a second optimisation
    of everything the loop calls, half the compile time); a pixel row
    writes only its own output row, so there are no races, and the result does not depend on
    the number of threads. Several frames go in one call (:func:`accumulate_merged` with a
    3-D block): each thread takes its rows through all of them without waiting for the other
    (no barrier per frame), and stops at its first frame with a status; those are handled in
    frame order, and the stopped threads go on;
-   within a pixel row, the sample rows of its pieces are swept up to 12 at a time (all of a
    pixel row of up to 12 pieces; eight, four, then one row at a time, the sweep's partial sums
    in a scratch row so the order of additions does not depend on the grouping), in chunks of 512
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

Nothing is compiled at import (importing costs numba's own import). The first call compiles the
one kernel that serves both frame dtypes (float32, float64), linear, Planck and every emissivity
form (index maps are passed as uint8: other integer maps are converted, for tables of up to 255
entries) and caches it on disk (``cache=True``, in ``radiosim/kernels/__pycache__`` or
``NUMBA_CACHE_DIR``); later processes load it in about 0.3 s. The frames travel in a bundle
holding a float64 and a float32 array (:class:`~radiosim.kernels.bundles.FrameBlock`, the
frames in the one of their dtype): only the helpers that read samples (the sweeps' blocks, the
radiance pass's interval loops, the gathers) have a loop per dtype, so the entry point and
everything else compile once, not once per dtype. The helpers have no Python wrapper and no
cache files of their own (``INNER``), except the last ones the entry point's compile reaches
(``AHEAD``), which another process compiles meanwhile and the entry point loads
(:func:`~radiosim.kernels.compiling.compile_helpers_ahead`: 4–6 s off its compile); the pixel
rows' pass is written in the entry point (numba's inlining of a helper copies the helper's IR
and types it again), and a sweep's row offsets and weights are small arrays. The image stage's
sub-band kernel has one variant (float32 frames are widened for it).
Compiling every kernel costs about 20–24 s of CPU on a 2-core host
(``benchmarks/bench_compile.py`` lists it per function: most of it is the integrator's entry
point; about 60 % numba's typing and lowering, 40 % LLVM); ``radiosim warmup`` spreads it over
the cores (another process compiles the integrator, :mod:`~radiosim.kernels.compiling`, while
the command compiles its last helpers ahead of it, then the chip's and the sub-band kernels),
and ``radiosim run`` compiles the integrator while another process compiles its last helpers
ahead of it, then the chip's kernels (:func:`radiosim.warmup.compile_for_run`).
:func:`warmup` compiles every variant ahead of time in this process, and
:func:`compile_pending` tells, from the cache's index files, whether a launch would compile.

The package, one concept per module (imports flow down this list):

-   :mod:`~radiosim.kernels.codes`: status bits and signal modes;
-   :mod:`~radiosim.kernels.bundles`: the named bundles the kernel takes (frames, axes,
    accumulators, merging, packed tables, emissivity, thread buffers);
-   :mod:`~radiosim.kernels.intrinsics`: LLVM intrinsics (fused multiply-add, the eight-sample
    cubics by shuffles, the atomic block counter :func:`~.intrinsics.claim_block`) and
    :data:`fast_exp`;
-   :mod:`~radiosim.kernels.sweeps`: the generated row sweeps;
-   :mod:`~radiosim.kernels.radiance`: the radiance pass (interval, position, cubic, grey);
-   :mod:`~radiosim.kernels.rows`: the integrator's kernel (pixel rows, reduction to pixels,
    commit or merge);
-   :mod:`~radiosim.kernels.layout`: footprint layouts and frame views;
-   :mod:`~radiosim.kernels.table`: :class:`SignalTable`, the response's signal as tables
    (engine-neutral; :class:`RadianceKernelTable` is its former name);
-   :mod:`~radiosim.kernels.packing`: the compiled engine's format of a :class:`SignalTable`;
-   :mod:`~radiosim.kernels.messages`: the errors of a flagged frame;
-   :mod:`~radiosim.kernels.reference`: the numpy oracles;
-   :mod:`~radiosim.kernels.background`: the compiling processes a launch waits for;
-   :mod:`~radiosim.kernels.launch`: the entry points, buffers, thread settings;
-   :mod:`~radiosim.kernels.compiling`: compiling ahead of time (:func:`warmup`), and in
    other processes while this one works (:func:`compile_in_background`);
-   :mod:`~radiosim.kernels.engines`: the engines (compiled, numpy) and the choice between
    them. A GPU engine goes there: one new module and one entry in
    :data:`~radiosim.kernels.engines.ENGINES`;
-   :mod:`~radiosim.kernels.merging`: jobs sharing footprints, merged frame by frame (or block
    by block) through an engine (the integrator's compiled path).

numba's on-disk cache tracks each compiled function's own file only; :mod:`~radiosim.kernels.cache`
stamps every kernel with all the kernel sources instead, so editing ``intrinsics.py``,
``sweeps.py`` or ``radiance.py`` (or the chip's kernels) recompiles what inlined them.
"""

from radiosim.kernels import cache as _cache

_cache.register()  # before any kernel below is decorated with cache=True

from radiosim.kernels.codes import (SIGNAL_INDEX, SIGNAL_MAP, SIGNAL_NONE, SIGNAL_SCALAR,
                                    STATUS_ABOVE_TABLE, STATUS_BAD_INDEX, STATUS_BAD_SAMPLE,
                                    STATUS_BELOW_TABLE, STATUS_OK)
from radiosim.kernels.engines import ENGINES, Engine, compiled_selected, get_engine, set_engine
from radiosim.kernels.intrinsics import FRAME_DTYPES, fast_exp
from radiosim.kernels.compiling import (cache_location, compile_in_background, compile_pending,
                                        warmup, warmup_bands)
from radiosim.kernels.launch import (accumulate, accumulate_merged, apply_thread_settings,
                                     parallel_launch, pixel_mean, thread_count)
from radiosim.kernels.reference import (Members, accumulate_merged_reference,
                                        accumulate_reference, pixel_mean_reference)
from radiosim.kernels.table import RadianceKernelTable, SignalTable
from radiosim.kernels.threads import run_blocks

__all__ = [
    "FRAME_DTYPES",
    "fast_exp",
    "parallel_launch",
    "run_blocks",
    "apply_thread_settings",
    "thread_count",
    "STATUS_OK",
    "STATUS_BAD_SAMPLE",
    "STATUS_BELOW_TABLE",
    "STATUS_ABOVE_TABLE",
    "STATUS_BAD_INDEX",
    "SIGNAL_NONE",
    "SIGNAL_SCALAR",
    "SIGNAL_MAP",
    "SIGNAL_INDEX",
    "SignalTable",
    "RadianceKernelTable",
    "pixel_mean",
    "pixel_mean_reference",
    "accumulate",
    "accumulate_reference",
    "Members",
    "accumulate_merged",
    "accumulate_merged_reference",
    "Engine",
    "ENGINES",
    "get_engine",
    "set_engine",
    "compiled_selected",
    "dispatchers",
    "warmup",
    "warmup_bands",
    "compile_in_background",
    "compile_pending",
    "cache_location",
]


def dispatchers() -> tuple:
    """Every compiled (numba) function of the package, e.g. to count their compiled
    signatures."""
    import numba

    from radiosim.kernels import bands, intrinsics, radiance, rows, sweeps

    found = [*rows.ACCUMULATE_KERNELS.values(), bands.band_kernel]
    for module in (intrinsics, sweeps, radiance, rows, bands):
        found += [v for v in vars(module).values()
                  if isinstance(v, numba.core.registry.CPUDispatcher)]
    return tuple(dict.fromkeys(found))

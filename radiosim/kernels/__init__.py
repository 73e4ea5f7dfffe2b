"""
Compiled one-pass streaming kernels for the integrator's hot loop, with their numpy oracles.

Each frame of an integration window is read once: in one pass over its footprint pieces the
kernel :func:`accumulate` adds, per pixel, the time-weighted area means of T − c, of (T − c)²
and (optionally) of the response signal S(T) = ε·L(T), raises the per-pixel maximum of T, and
checks every sample it reads (finite, > 0 K, inside the radiance table). :func:`pixel_mean`
gives the per-pixel reference c from the first frame. Every kernel has a plain numpy
implementation beside it (:mod:`~radiosim.kernels.reference`), the tests' oracle and the path
for samples colder than the radiance table (exact quadrature).

The kernels are plain cached numba functions (``cache=True``): the first call compiles, later
processes load the machine code from numba's cache (:func:`cache_location`);
:func:`warmup` compiles every variant ahead of time. How they are fast, and why each design
choice was made, is in the developer notes (``docs/kernels.md``).

The package, one concept per module (imports flow down this list):

-   :mod:`~radiosim.kernels.codes`: status bits and signal modes;
-   :mod:`~radiosim.kernels.bundles`: the named bundles the kernel takes;
-   :mod:`~radiosim.kernels.intrinsics`: LLVM intrinsics and :data:`fast_exp`;
-   :mod:`~radiosim.kernels.sweeps`: the generated row sweeps;
-   :mod:`~radiosim.kernels.radiance`: the radiance pass (interval, position, cubic, grey);
-   :mod:`~radiosim.kernels.rows`: the integrator's kernel (pixel rows, reduction to pixels,
    commit or merge);
-   :mod:`~radiosim.kernels.layout`: footprint layouts and frame views;
-   :mod:`~radiosim.kernels.table`: :class:`SignalTable`, the response's signal as tables;
-   :mod:`~radiosim.kernels.packing`: the compiled engine's format of a :class:`SignalTable`;
-   :mod:`~radiosim.kernels.messages`: the errors of a flagged frame;
-   :mod:`~radiosim.kernels.reference`: the numpy oracles;
-   :mod:`~radiosim.kernels.threads`: fixed blocks of pixel rows on radiosim's threads;
-   :mod:`~radiosim.kernels.launch`: the entry points and their buffers;
-   :mod:`~radiosim.kernels.bands`: the image stage's sub-band kernel;
-   :mod:`~radiosim.kernels.compiling`: compiling ahead of time (:func:`warmup`);
-   :mod:`~radiosim.kernels.engines`: the engines (compiled, numpy), sets of operations;
-   :mod:`~radiosim.kernels.merging`: jobs sharing footprints, merged frame by frame through
    an engine.

numba's on-disk cache tracks each compiled function's own file only;
:mod:`~radiosim.kernels.cache` stamps every kernel with all the kernel sources instead, so
editing ``intrinsics.py``, ``sweeps.py`` or ``radiance.py`` (or the chip's kernels) recompiles
what inlined them.
"""

from radiosim.kernels import cache as _cache

_cache.register()  # before any kernel below is decorated with cache=True

from radiosim.kernels.codes import (SIGNAL_INDEX, SIGNAL_MAP, SIGNAL_NONE, SIGNAL_SCALAR,
                                    STATUS_ABOVE_TABLE, STATUS_BAD_INDEX, STATUS_BAD_SAMPLE,
                                    STATUS_BELOW_TABLE, STATUS_OK)
from radiosim.kernels.engines import ENGINES, Engine, get_engine, set_engine
from radiosim.kernels.intrinsics import FRAME_DTYPES, fast_exp
from radiosim.kernels.compiling import cache_location, compile_pending, warmup, warmup_bands
from radiosim.kernels.launch import accumulate, accumulate_merged, pixel_mean, thread_count
from radiosim.kernels.reference import (Members, accumulate_merged_reference,
                                        accumulate_reference, pixel_mean_reference)
from radiosim.kernels.table import SignalTable
from radiosim.kernels.threads import run_blocks

__all__ = [
    "FRAME_DTYPES",
    "fast_exp",
    "run_blocks",
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
    "dispatchers",
    "warmup",
    "warmup_bands",
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

"""
The command's side of compiling radiosim's kernels (:mod:`radiosim.kernels.compiling` does the
work): saying once that a command is about to compile, and ``radiosim warmup``, which compiles
every variant ahead of time, in this process.
"""

from __future__ import annotations

import sys

from radiosim.console import Progress

__all__ = ["COMPILE_SECONDS", "announce_compile", "warmup_chip", "warmup_command"]

#: About how long [s] a first run of the paper's study compiles, said once when it starts (the
#: integrator's kernel and the chip's, from an empty cache on 2 cores: docs/performance.md,
#: measured by benchmarks/bench_cli.py).
COMPILE_SECONDS = 12


def announce_compile(args, frame_dtype="float64", chip=False):
    """Say once, on a terminal's stderr, that the kernels are about to compile (the integrator's
    kernel is not cached for frames of ``frame_dtype``, or the segmented chip's kernels are not
    when ``chip``), before the work starts.
    Not in a log: there an error stays the one line on stderr."""
    if args.quiet or not sys.stderr.isatty():
        return
    from radiosim.kernels import compile_pending, get_engine

    if get_engine().name != "compiled":  # the other engines compile nothing of radiosim's
        return

    also = ()
    if chip:
        from radiosim.scenes.segmented_chip.kernel import moving_terms_kernel

        also = (moving_terms_kernel,)
    if compile_pending((frame_dtype,), also=also):
        print(f"radiosim: compiling radiosim's kernels, once, about {COMPILE_SECONDS} s "
              "(radiosim warmup does it ahead of time)", file=sys.stderr, flush=True)


def warmup_chip() -> None:
    """Compile (or load) the segmented chip's kernels: its moving terms on a small region at
    the band's time (frames and region maps)."""
    from radiosim.scenes import SegmentedChip

    chip = SegmentedChip()
    middle = tuple(slice(n // 2, n // 2 + 16) for n in chip.shape)
    chip.temperature(chip.event_time, middle), chip.regions(chip.event_time, middle)


def warmup_command(args) -> int:
    """``radiosim warmup``: every kernel compiled (or loaded from numba's cache) in this
    process, in order, with progress: the chip's moving terms, the image stage's sub-band
    kernel, then every variant of the integrator's kernel."""
    import time

    from radiosim.kernels import FRAME_DTYPES, compile_pending, get_engine, warmup, warmup_bands
    from radiosim.kernels.bands import band_kernel
    from radiosim.scenes.segmented_chip.kernel import band_profile, moving_terms_kernel

    engine = get_engine()
    if engine.name != "compiled":  # NUMBA_DISABLE_JIT, or the numpy engine chosen
        print(f"nothing to compile: the {engine.name} engine runs no compiled kernel "
              "(NUMBA_DISABLE_JIT or RADIOSIM_ENGINE chose it)")
        return 0
    began = time.perf_counter()
    progress = Progress("step", args.quiet)
    pending = compile_pending(FRAME_DTYPES, ("uint8", "intp"),  # else all is loaded
                              also=(band_kernel, moving_terms_kernel, band_profile))
    steps = 2 + 2 * len(FRAME_DTYPES) * 5
    warmup_chip()
    progress(1, steps, "the chip's moving terms")
    warmup_bands()
    progress(2, steps, "the image stage's sub-band kernel")
    report = warmup(progress=lambda k, total, label: progress(2 + k, 2 + total, label),
                    bands=False)
    kernels = f"{report['variants']} kernel variants and the chip's moving terms"
    seconds = time.perf_counter() - began
    print(f"compiled radiosim's kernels in {seconds:.0f} s ({kernels}; cached in "
          f"{report['cache']})" if pending else f"radiosim's kernels were compiled already "
          f"({kernels}, cached in {report['cache']}): loaded in {seconds:.0f} s")
    return 0

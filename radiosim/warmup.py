"""
The command's side of compiling radiosim's kernels (:mod:`radiosim.kernels.compiling` does the
work): saying once that a command is about to compile; before a run or a measurement, another
process compiling the integrator's last helpers (and a chip's kernels) while the integrator's
kernel compiles here; and ``radiosim warmup``, which compiles every variant ahead of time on
both cores.
"""

from __future__ import annotations

import sys

from radiosim.console import Progress

__all__ = ["COMPILE_SECONDS", "WARMUP_SECONDS", "announce_compile", "compile_for_run",
           "compile_helpers_aside", "warmup_chip", "chip_main", "warmup_command"]

#: Compile times [s] from an empty cache on 2 cores (measured by benchmarks/bench_cli.py and
#: bench_compile.py; README): what a run of the paper's study compiles (the integrator's kernel
#: and the chip's), and every kernel (``radiosim warmup``).
COMPILE_SECONDS, WARMUP_SECONDS = 14, 14


def announce_compile(args, frame_dtype="float64", chip=False):
    """Say once, on a terminal's stderr, that the kernels are about to compile (the integrator's
    kernel is not cached for frames of ``frame_dtype``, or the segmented chip's kernels are not
    when ``chip``), before the work starts.
    Not in a log: there an error stays the one line on stderr."""
    if args.quiet or not sys.stderr.isatty():
        return
    from radiosim.kernels import compile_pending, compiled_selected

    if not compiled_selected():  # the numpy engine compiles nothing
        return

    also = ()
    if chip:
        from radiosim.scenes.segmented_chip.kernel import moving_terms_kernel

        also = (moving_terms_kernel,)
    if compile_pending((frame_dtype,), also=also):
        print(f"radiosim: compiling radiosim's kernels, once, about {COMPILE_SECONDS} s "
              "(radiosim warmup does it ahead of time)", file=sys.stderr, flush=True)


def compile_for_run(scene) -> None:
    """
    Before a run on a segmented chip whose integrator kernel the cache lacks: compile it here,
    now, while another process (the second core) compiles the integrator's last helpers, ahead
    of this compile reaching them (:func:`~radiosim.kernels.compiling.compile_helpers_ahead`:
    this one loads them from the cache), then the chip's kernels (or loads them, if cached).
    The integrator's is the longer of the two, so it is compiled where it does not wait for a
    process to start and import radiosim; the chip's first frame waits for that process
    (:mod:`radiosim.scenes.segmented_chip.compiled`), then loads what it cached. Other
    scenes (:func:`compile_helpers_aside`), and a chip whose integrator kernel is cached, have
    nothing compiled here ahead: their kernels compile at their first call.
    """
    import numpy as np

    from radiosim.acquisition import frame_dtype
    from radiosim.kernels import compile_pending, compiled_selected, warmup
    from radiosim.scenes import SegmentedChip

    if not compiled_selected() or not isinstance(scene, SegmentedChip):
        return  # the numpy engine compiles nothing
    dtype = np.dtype(frame_dtype(scene)).name
    if not compile_pending((dtype,)):
        return
    # The chip's kernels too when the cache lacks them (else this process's loading thread
    # loads them: the chip's first frame waits only for a process compiling them).
    _start_aside(helpers_only=not compile_pending((), also=scene.compiled_kernels()))
    warmup(frame_dtypes=(dtype,), bands=False)


def _start_aside(helpers_only: bool) -> None:
    """Start and register the process compiling the integrator's last helpers, then (unless
    ``helpers_only``) the chip's kernels (:data:`~radiosim.compiling_process.CHIP_CHILD`); if
    none can start, what it would compile compiles here, at its first call."""
    from radiosim import compiling_process
    from radiosim.kernels.background import register

    child = compiling_process.start(child=compiling_process.CHIP_CHILD,
                                    helpers_only=helpers_only)
    if child is not None:
        register(*child)


def compile_helpers_aside(scene) -> None:
    """
    Before a measurement of ``scene`` (``radiosim measure``) whose integrator kernel the cache
    lacks: start another process compiling the integrator's last helpers
    (:func:`~radiosim.kernels.compiling.compile_helpers_ahead`), while this one checks the
    inputs and compiles the kernel at its first launch, which loads them from the cache (its
    compile reaches them last). The process is stopped with this one (an input refused first)
    and no launch waits for it.
    """
    import numpy as np

    from radiosim.acquisition import frame_dtype
    from radiosim.kernels import compile_pending, compiled_selected

    if compiled_selected() and compile_pending((np.dtype(frame_dtype(scene)).name,)):
        _start_aside(helpers_only=True)


def warmup_chip() -> None:
    """Compile (or load) the segmented chip's kernels: its moving terms on a small region at
    the band's time (frames and region maps)."""
    from radiosim.scenes import SegmentedChip

    chip = SegmentedChip()
    middle = tuple(slice(n // 2, n // 2 + 16) for n in chip.shape)
    chip.temperature(chip.event_time, middle), chip.regions(chip.event_time, middle)


def chip_main(argv) -> int:
    """The process compiling the integrator's last helpers ahead of the process that started it
    (:func:`compile_for_run`), then the chip's kernels, unless ``--helpers-only``
    (:data:`radiosim.compiling_process.CHIP_CHILD`: ``--memmap-dir DIR`` is its working folder,
    ``--parent PID`` the process it ends with)."""
    from radiosim.compiling_process import watch_parent

    argv = list(argv)
    watch_parent(argv)
    try:
        from radiosim.kernels.compiling import compile_helpers_ahead

        # Not the radiance pass's row: the other process's compile reaches it about when this
        # one, started after that process's imports, could have cached it (measured), and the
        # chip's kernels come next here.
        compile_helpers_ahead(count=3)
        if "--helpers-only" not in argv:
            warmup_chip()
    except KeyboardInterrupt:  # the terminal's interrupt reaches this process too
        return 130
    return 0


def warmup_command(args) -> int:
    """``radiosim warmup``."""
    import shutil
    import time

    from radiosim import compiling_process

    began = time.perf_counter()
    progress = Progress("step", args.quiet)
    # Another process compiles the integrator's kernel (one for both frame dtypes), started
    # before this one imports numba and the kernels (the imports overlap), while this one
    # compiles that kernel's last helpers ahead of it (it loads them from the cache), then the
    # chip's and the image stage's kernels (shares of about equal work on two cores); then
    # every variant is launched here (loaded).
    child = compiling_process.start()
    try:
        from radiosim.kernels import FRAME_DTYPES, compile_pending, warmup, warmup_bands
        from radiosim.kernels.background import register, wait_for_background
        from radiosim.kernels.compiling import compile_helpers_ahead
    except BaseException:  # interrupted while importing: the process and its folder go too
        if child is not None:
            child[0].kill()
            child[0].wait()
            shutil.rmtree(child[1], ignore_errors=True)
        raise
    from radiosim.kernels.bands import band_kernel
    from radiosim.scenes.segmented_chip.kernel import band_profile, moving_terms_kernel

    pending = compile_pending(FRAME_DTYPES, ("uint8", "intp"),  # else all is loaded
                              also=(band_kernel, moving_terms_kernel, band_profile))
    started = []
    if child is not None:  # else this process compiles everything itself
        register(*child)
        started.append(child[0])
    # helpers, chip, sub-bands, processes, variants
    steps = 3 + len(started) + 2 * len(FRAME_DTYPES) * 5
    if started and compile_pending(FRAME_DTYPES):  # the other process compiles: go ahead
        compile_helpers_ahead()
    progress(1, steps, "the integrator's last helpers")
    warmup_chip()
    progress(2, steps, "the chip's moving terms")
    warmup_bands(wait_for_processes=False)
    progress(3, steps, "the image stage's sub-band kernel")
    for k, process in enumerate(started, start=4):
        process.wait()
        progress(k, steps, "the integrator's kernel (another process)")
    wait_for_background()
    done = 3 + len(started)
    report = warmup(progress=lambda k, total, label: progress(done + k, done + total, label))
    kernels = f"{report['variants']} kernel variants and the chip's moving terms"
    seconds = time.perf_counter() - began
    print(f"compiled radiosim's kernels in {seconds:.0f} s ({kernels}; cached in "
          f"{report['cache']})" if pending else f"radiosim's kernels were compiled already "
          f"({kernels}, cached in {report['cache']}): loaded in {seconds:.0f} s")
    return 0

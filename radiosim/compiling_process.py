"""
Starting a Python process that compiles radiosim's kernels beside this one: the integrator's
(:func:`radiosim.kernels.compiling.compile_in_background` starts it where the cache lacks the
kernel; ``radiosim warmup`` starts it first thing, before this process imports numba, so that
the two imports overlap), or the integrator's last helpers ahead of this process, then the
segmented chip's (``radiosim run``, while this process compiles the integrator's:
:func:`radiosim.warmup.compile_for_run`). Imports nothing heavy: the process
imports radiosim itself (:func:`radiosim.kernels.compiling._main`,
:func:`radiosim.warmup.chip_main`).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time

__all__ = ["CHILD", "CHIP_CHILD", "start", "watch_parent"]

#: What the integrator's process runs (``python -c CHILD [DTYPE ...] [--bands] --memmap-dir
#: DIR --parent PID``): :func:`radiosim.kernels.compiling._main`.
CHILD = "import sys; from radiosim.kernels.compiling import _main; sys.exit(_main(sys.argv[1:]))"
#: What the chip's process runs (``python -c CHIP_CHILD --memmap-dir DIR --parent PID``):
#: :func:`radiosim.warmup.chip_main`.
CHIP_CHILD = "import sys; from radiosim.warmup import chip_main; sys.exit(chip_main(sys.argv[1:]))"


def start(frame_dtypes=(), with_bands: bool = False, child: str = CHILD,
          helpers_only: bool = False) -> tuple[subprocess.Popen, str] | None:
    """
    Start a compiling process: :func:`radiosim.kernels.compiling.warmup` on frames of
    ``frame_dtypes`` (every frame dtype when empty), with ``with_bands`` the sub-band kernel
    too (a launch of the integrator waits for it); or, with ``child`` :data:`CHIP_CHILD`, the
    integrator's last helpers (for this process's compile of the integrator to load) and the
    segmented chip's kernels (its ``aside`` set: the integrator's launches do not wait for it;
    its ``with_chip`` set: the chip's first frame does), or with ``helpers_only`` those helpers
    only (``with_chip`` not set). It runs in a temporary folder of its own, made here
    (its working folder and that of its small memory-mapped file), imports this process's
    radiosim, discards its output, and ends by itself if this process is killed. Returns the
    process (its ``frame_dtypes``, empty for every frame dtype, and ``with_bands`` say what it
    launches) and its folder, which the caller registers
    (:func:`radiosim.kernels.background.register`: waited for, stopped and removed), or
    ``None`` when no process can start (the caller then compiles itself).
    """
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    paths = [package, os.environ.get("PYTHONPATH", "")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in paths if p))
    folder = None
    try:
        folder = tempfile.mkdtemp(prefix="radiosim-compiling-")
        command = [sys.executable, "-c", child, *frame_dtypes, "--memmap-dir", folder,
                   "--parent", str(os.getpid())]
        command += (["--bands"] if with_bands else []) + (
            ["--helpers-only"] if helpers_only else [])
        process = subprocess.Popen(command,
                                   cwd=folder, env=env, stdin=subprocess.DEVNULL,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except (OSError, TypeError, ValueError):  # cannot start one (no interpreter to run, no
        if folder is not None:  # temporary folder)
            os.rmdir(folder)
        return None
    process.frame_dtypes, process.with_bands = tuple(frame_dtypes), with_bands
    # ``aside``: it compiles nothing an integrator's launch loads (its last helpers are loaded
    # by a compile); ``with_chip``: the chip's first frame waits for it.
    process.aside = child == CHIP_CHILD
    process.with_chip = process.aside and not helpers_only
    return process, folder


def watch_parent(argv: list) -> None:
    """In a compiling process: take ``--parent PID`` out of ``argv`` and watch that process
    (the one that started this one) on a daemon thread; this one ends when it has ended
    without stopping it (killed), even before this one got here, instead of compiling on for
    no one."""
    parent = os.getppid()
    if "--parent" in argv:
        at = argv.index("--parent")
        parent = int(argv[at + 1])
        del argv[at:at + 2]

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()

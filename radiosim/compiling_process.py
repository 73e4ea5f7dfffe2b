"""
Starting the Python process that compiles radiosim's integrator kernel beside this one
(:func:`radiosim.kernels.compiling.compile_in_background` starts it where the cache lacks the
kernel; ``radiosim warmup`` starts it first thing, before this process imports numba, so that
the two imports overlap). Imports nothing heavy: the process imports radiosim itself
(:func:`radiosim.kernels.compiling._main`).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

__all__ = ["CHILD", "start"]

#: What the process runs (``python -c CHILD [DTYPE ...] [--bands] --memmap-dir DIR --parent
#: PID``): :func:`radiosim.kernels.compiling._main`.
CHILD = "import sys; from radiosim.kernels.compiling import _main; sys.exit(_main(sys.argv[1:]))"


def start(frame_dtypes=(), with_bands: bool = False,
          child: str = CHILD) -> tuple[subprocess.Popen, str] | None:
    """
    Start the compiling process: :func:`radiosim.kernels.compiling.warmup` on frames of
    ``frame_dtypes`` (every frame dtype when empty), with ``with_bands`` the sub-band kernel
    too. It runs in a temporary folder of its own, made here (its working folder and that of
    its small memory-mapped file), imports this process's radiosim, discards its output, and
    ends by itself if this process is killed. Returns the process (its ``frame_dtypes``, empty
    for every frame dtype, and ``with_bands`` say what it launches) and its folder, which the caller registers
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
        process = subprocess.Popen(command + (["--bands"] if with_bands else []),
                                   cwd=folder, env=env, stdin=subprocess.DEVNULL,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except (OSError, TypeError, ValueError):  # cannot start one (no interpreter to run, no
        if folder is not None:  # temporary folder)
            os.rmdir(folder)
        return None
    process.frame_dtypes, process.with_bands = tuple(frame_dtypes), with_bands
    return process, folder

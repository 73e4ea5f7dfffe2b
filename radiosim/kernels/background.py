"""
The compiling processes this one has started
(:func:`radiosim.kernels.compiling.compile_in_background`), and the wait for them before a
kernel launches: :func:`wait_for_background` returns at once when there are none (the launch
functions call it every time), else waits until they have ended, so that the launch loads from
numba's cache what they compiled instead of compiling it a second time. Processes still running
when this one exits are stopped.
"""

from __future__ import annotations

import atexit
import subprocess
import threading

__all__ = ["register", "wait_for_background", "stop_all"]

_RUNNING: list = []  # started and not yet waited for
_LOCK = threading.Lock()


def register(process: subprocess.Popen) -> None:
    """Count ``process`` (a compiling process) among those a launch waits for."""
    with _LOCK:
        _RUNNING.append(process)


def wait_for_background() -> None:
    """Wait until the registered compiling processes have ended (at once when there are none).
    Interrupted, it stops them."""
    if not _RUNNING:
        return
    with _LOCK:
        try:
            while _RUNNING:
                _RUNNING[0].wait()
                _RUNNING.pop(0)
        except BaseException:
            stop_all()
            raise


@atexit.register
def stop_all() -> None:
    """Stop the compiling processes still running (this process is exiting, or was interrupted
    while it waited): numba writes each cache file whole (to a temporary name, then renamed),
    so at worst a variant stays uncached."""
    while _RUNNING:
        process = _RUNNING.pop()
        if process.poll() is None:
            process.terminate()
            try:
                process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                process.kill()

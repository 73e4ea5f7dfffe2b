"""
The compiling processes this one has started (:mod:`radiosim.compiling_process`: the
integrator's, :func:`radiosim.kernels.compiling.compile_in_background`, or one compiling the
integrator's last helpers and the segmented chip's kernels, :func:`radiosim.warmup.compile_for_run`),
and the wait for them before a kernel
launches: :func:`wait_for_background` returns at once when there are none (the launch
functions call it every time), else waits until they have ended, so that the launch loads from
numba's cache what they compiled instead of compiling it a second time. Each process works in a
folder of its own that this process made and removes once the process has ended. Processes
still running when this one exits, or is interrupted, are stopped.
"""

from __future__ import annotations

import atexit
import os
import shutil
import signal
import subprocess
import threading

__all__ = ["register", "register_loader", "wait_for_loaders", "wait_for_background",
           "any_running", "stop_all"]

_RUNNING: list = []  # (process, its folder): started and not yet waited for
_LOADING: list = []  # threads loading kernels from the cache (compiling.load_in_background)
_LOCK = threading.Lock()


def register(process: subprocess.Popen, folder: str | None = None) -> None:
    """Count ``process`` (a compiling process) among those a launch waits for; ``folder``
    (its working folder) is removed once it has ended."""
    with _LOCK:
        _RUNNING.append((process, folder))


def register_loader(thread: threading.Thread) -> None:
    """Count ``thread`` (loading kernels from numba's cache) among what a launch waits for:
    numba's typing is not safe to run while another thread loads (it fills shared tables)."""
    with _LOCK:
        _LOADING.append(thread)


def wait_for_loaders() -> None:
    """Wait until the registered loading threads have ended (at once when there are none):
    before a kernel runs that no registered process compiles."""
    if not _LOADING:
        return
    with _LOCK:
        while _LOADING:
            _LOADING[0].join()
            _LOADING.pop(0)


def any_running(flag: str, unset: bool = False) -> bool:
    """Whether a registered compiling process not yet waited for has the attribute ``flag``
    set (``with_bands``: it compiles the sub-band kernel too; ``with_chip``: it compiles the
    segmented chip's kernels; ``aside``: it compiles nothing an integrator's launch loads, only
    the integrator's last helpers and the chip's kernels), or, with ``unset``, one has it not
    set (e.g. any process not ``aside``: one that may compile the integrator)."""
    with _LOCK:
        return any(bool(getattr(process, flag, False)) != unset for process, _ in _RUNNING)


def _remove(folder) -> None:
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)


def wait_for_background() -> None:
    """Wait until the registered loading threads and compiling processes have ended (at once
    when there are none). Interrupted, it stops the processes."""
    if not _RUNNING and not _LOADING:
        return
    wait_for_loaders()
    with _LOCK:
        try:
            while _RUNNING:
                process, folder = _RUNNING[0]
                process.wait()
                _RUNNING.pop(0)
                _remove(folder)
        except BaseException:
            stop_all(at_once=True)
            raise


@atexit.register
def stop_all(at_once: bool = False) -> None:
    """
    Stop the compiling processes still running and remove their folders: asked to end
    (SIGTERM), given 5 s, then killed; with ``at_once`` (an interrupt: also from a signal
    handler, where a process being waited for cannot be polled) killed at once and reaped
    directly. numba writes each cache file under a temporary name, then renames it: at worst a
    variant stays uncached.
    """
    while _RUNNING:
        process, folder = _RUNNING.pop()
        if at_once and process.returncode is None:  # (a reaped process's id may be reused)
            try:
                os.kill(process.pid, signal.SIGKILL)
                os.waitpid(process.pid, 0)
            except (ProcessLookupError, ChildProcessError):
                pass  # it had ended, and was reaped
        elif process.poll() is None:
            process.terminate()
            try:
                process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        _remove(folder)

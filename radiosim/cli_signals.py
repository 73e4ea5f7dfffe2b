"""
The ``radiosim`` command's signal handling: one line and exit 130 for Ctrl-C or SIGTERM at any
moment, its temporary files removed.

-   While the command starts (its imports: seconds on a loaded machine), the handlers installed
    when this module loads — :mod:`radiosim.cli` imports it first, in the command's process
    only, never when radiosim is imported as a library — end it with one line: nothing has
    been written yet.
-   While it works, :func:`on_interrupt` unwinds (every ``finally`` removes its temporary
    files), ends a local cluster's workers and bounds the cleanup to
    :data:`~radiosim.interrupts.GRACE` seconds; :func:`on_unraisable` sends again an interrupt
    that arrived where it cannot unwind; the library's loops raise again one that was swallowed
    (:func:`radiosim.interrupts.raise_if_interrupted`).
-   :func:`exit_interrupted` and :func:`exit_done` end the process.

And the environments the command ends in one line rather than a traceback: too small an
address space (:func:`short_of_memory`), a damaged kernel cache (:func:`damaged_cache`), an
``MPLBACKEND`` matplotlib refuses (:func:`bad_mplbackend`), streams that cannot encode µ and °
(:func:`encode_what_it_can`).
"""

import contextlib
import sys

from radiosim.errors import Interrupted
from radiosim.interrupts import GRACE, command_state

__all__ = ["on_interrupt", "on_unraisable", "exit_interrupted", "exit_done", "short_of_memory",
           "damaged_cache", "bad_mplbackend", "encode_what_it_can"]


# -- the command's start-up ------------------------------------------------------------------
# The ``radiosim`` command reaches :func:`radiosim.cli.main` only after the package's imports
# (numpy, numba, the chain: seconds on a loaded machine). A Ctrl-C there would print a
# KeyboardInterrupt traceback from deep inside an import, and a SIGTERM would end the process
# with no word. This module is the first of the package to load, so it installs, in the
# command's process only (never when radiosim is imported as a library), a handler that ends
# the start-up with one line and exit 130: nothing has been written yet. ``main`` replaces it
# with the handlers of the work (which unwind and remove temporary files). Processes the
# command spawns (Dask's local workers re-import the command's main module) ignore Ctrl-C:
# the terminal sends it to the whole process group, and the command shuts its workers down.


def _is_command() -> bool:
    """Whether this process is the ``radiosim`` command (its console script, or
    ``python -m radiosim.cli``), or a process it spawned (which inherits its ``sys.argv``)."""
    import os
    import sys

    argv0 = sys.argv[0] if sys.argv else ""
    if os.path.basename(argv0) in ("radiosim", "radiosim.exe", "radiosim-script.py"):
        return True
    if argv0.replace("\\", "/").endswith("radiosim/cli.py"):
        return True
    orig = list(getattr(sys, "orig_argv", ()))
    return any(a == "-m" and b in ("radiosim", "radiosim.cli") for a, b in zip(orig, orig[1:]))


def _startup_interrupt(signum, frame):  # pragma: no cover - runs in the command's process
    import os
    import signal

    what = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
    os.write(2, f"radiosim: interrupted ({what}); nothing was written\n".encode())
    os._exit(130)


def _install_startup_handlers():
    import signal
    import sys
    import threading

    if threading.current_thread() is not threading.main_thread() or not _is_command():
        return
    if "--multiprocessing-fork" in getattr(sys, "orig_argv", ()):
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a spawned worker: its parent decides
        return
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(signum) in (signal.SIG_DFL, signal.default_int_handler):
            signal.signal(signum, _startup_interrupt)


_install_startup_handlers()


# -- the command's work, interrupted ------------------------------------------------------------
# radiosim.cli.main installs on_interrupt for SIGINT and SIGTERM while a command works.


def on_interrupt(signum, frame):
    """The work's handler: unwind (``finally`` blocks remove temporary files). In the command,
    the first signal also ends the local cluster's workers (they ignore Ctrl-C and would log
    their lost scheduler), silences the engine's shutdown chatter, and bounds the cleanup."""
    import signal

    if command_state.active and not command_state.interrupted:
        import logging
        import threading

        command_state.interrupted = True
        command_state.signum = signum
        command_state.signal_name = ("Ctrl-C" if signum == signal.SIGINT
                                     else signal.Signals(signum).name)
        logging.disable(logging.CRITICAL)
        _end_children()
        timer = threading.Timer(GRACE, _give_up, (signum,))
        timer.daemon = True
        timer.start()
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Interrupted(signal.Signals(signum).name)


def on_unraisable(unraisable):
    """The command's ``sys.unraisablehook``: an interrupt that :func:`on_interrupt` raised where
    it cannot unwind (in Python code that C calls back, such as llvmlite's object cache while
    numba compiles or loads a kernel: Python reports it as "Exception ignored" with a traceback,
    and goes on) is not reported; the signal is sent again a moment later, from another thread,
    so that the command still unwinds once its main thread is back in Python. Anything else
    goes to Python's own hook."""
    import sys

    if command_state.interrupted and isinstance(unraisable.exc_value,
                                                (KeyboardInterrupt, Interrupted)):
        import os
        import threading

        timer = threading.Timer(0.01, os.kill, (os.getpid(), command_state.signum))
        timer.daemon = True
        timer.start()
        return
    sys.__unraisablehook__(unraisable)


def _end_children():
    """Kill this process's multiprocessing children (a local Dask cluster's workers), if any:
    quietly, and before the cleanup talks to them. All are stopped first (SIGSTOP), then
    killed: a worker killed before another would otherwise let that one log, with a
    traceback, the connection it lost."""
    import os
    import signal
    import sys

    if "multiprocessing" not in sys.modules:
        return
    import multiprocessing

    try:
        children = multiprocessing.active_children()
        for child in children:
            with contextlib.suppress(OSError):
                os.kill(child.pid, signal.SIGSTOP)
        for child in children:
            child.kill()
    except Exception:  # noqa: BLE001 - best effort on the way out
        pass


def _give_up(signum):  # pragma: no cover - a cleanup that hangs
    import os
    import signal
    import sys

    what = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
    files = sys.modules.get("radiosim.files")
    if files is not None:  # the writes under way end absent, as an unwinding would leave them
        files.remove_open_temporaries()
    os.write(2, f"radiosim: interrupted ({what}); the cleanup did not finish within "
                f"{GRACE:g} s, ended\n".encode())
    exit_interrupted()


def exit_interrupted(code: int = 130):
    """End the command after an interrupt, its cleanup done: without the interpreter's exit
    handlers, which would close a half-started Dask cluster at length and print its errors
    (its worker processes end with this one: they watch their parent)."""
    import logging
    import os
    import sys

    logging.disable(logging.CRITICAL)  # the cluster's threads would log its end as errors
    _end_children()  # any started during the cleanup
    util = sys.modules.get("multiprocessing.util")
    if util is not None:  # release the semaphores as the exit handlers would (else the
        try:  # resource tracker warns of them)
            util._run_finalizers(0)
        except Exception:  # noqa: BLE001 - best effort on the way out
            pass
    _flush_output()
    os._exit(code)


def _flush_output() -> None:
    """Flush stdout and stderr, whatever state they are in (closed, a full disk)."""
    import sys

    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):  # (AttributeError: closed, None)
            pass


def exit_done(code: int):
    """End the command's process, its work done and its files written: the exit handlers run
    (temporary files, logging, a cluster's shutdown) and the output is flushed, but the
    interpreter does not take down its modules one by one (numba's compiled code, scipy,
    matplotlib: time that nothing needs)."""
    import atexit
    import os

    _flush_output()
    atexit._run_exitfuncs()
    _flush_output()
    os._exit(code)


# -- environments the command ends in one line ----------------------------------------------


def short_of_memory(exc: BaseException) -> bool:
    """Say in one line, and return True, when ``exc`` is the process running out of memory or
    address space (``MemoryError``, or a library it could not map: ``ulimit -v`` too low)."""
    text = str(exc)
    mapping = isinstance(exc, (ImportError, OSError)) and (
        "failed to map segment" in text or "load shared object" in text
        or "cannot allocate memory" in text.lower())
    if not (isinstance(exc, MemoryError) or mapping):
        return False
    import resource

    limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    if not isinstance(exc, MemoryError) and limit == resource.RLIM_INFINITY:
        return False  # a library missing for another reason: said as it is
    stated = ("no limit" if limit == resource.RLIM_INFINITY
              else f"ulimit -v {limit // 1024}, in KiB")
    what = "ran out of memory" if isinstance(exc, MemoryError) else \
        f"could not load a library ({text.splitlines()[0][:120]})"
    print(f"radiosim: error: {what}; the process's address space ({stated}) is too small: "
          "radiosim needs about 1 GB to load numpy, scipy and numba, and its frames' worth "
          "more (raise or lift ulimit -v)", file=sys.stderr)
    return True


def damaged_cache(exc: BaseException) -> bool:
    """Say in one line, and return True, when ``exc`` arose reading numba's on-disk cache of
    radiosim's kernels (a damaged or truncated file there), naming the folder to delete."""
    trace, folder = exc.__traceback__, None
    while trace is not None:  # the deepest frame of numba's cache: the file it was reading
        frame = trace.tb_frame
        if frame.f_code.co_filename.replace("\\", "/").endswith("numba/core/caching.py"):
            folder = getattr(frame.f_locals.get("self"), "_cache_path", folder) or ""
        trace = trace.tb_next
    if folder is None:
        return False
    print(f"radiosim: error: numba's cache of radiosim's kernels cannot be read "
          f"({type(exc).__name__}: {str(exc)[:80]}): a file there is damaged; delete the folder "
          f"{folder or 'of the cache (NUMBA_CACHE_DIR, or radiosim/kernels/__pycache__)'} (the "
          "kernels are compiled again on the next run)", file=sys.stderr)
    return True


def encode_what_it_can() -> None:
    """The command's stdout and stderr write what their encoding cannot as escapes (``\\xb5``
    for µ under ``PYTHONIOENCODING=ascii``) instead of raising after the work is done."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            with contextlib.suppress(Exception):  # a stream that cannot: left as it is
                reconfigure(errors="backslashreplace")


def bad_mplbackend(exc: BaseException) -> bool:
    """Say in one line, and return True, when ``exc`` is matplotlib refusing the backend the
    environment variable ``MPLBACKEND`` names (radiosim draws with Agg whatever it names)."""
    import os

    backend = os.environ.get("MPLBACKEND")
    if not (backend and isinstance(exc, ValueError) and "for backend" in str(exc)):
        return False
    print(f"radiosim: error: the environment variable MPLBACKEND={backend!r} names no "
          "matplotlib backend, so matplotlib cannot load to draw the figures; unset it "
          "(radiosim draws with Agg whatever it names) or give a valid one", file=sys.stderr)
    return True

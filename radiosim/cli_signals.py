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
"""

import contextlib

from radiosim.errors import Interrupted
from radiosim.interrupts import GRACE, command_state

__all__ = ["on_interrupt", "on_unraisable", "exit_interrupted", "exit_done"]


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

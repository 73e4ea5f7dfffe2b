"""
Drawing figures in other processes: a figure is Python work (ticks, texts, paths) that holds the
interpreter for about a second, and matplotlib's import holds it for half a second more. In a
process of their own, started while a study measures (:func:`start_drawers`), matplotlib loads
beside the measurements instead of taking the interpreter from them, and the figures are drawn
there, on the other core, when the results are in (:func:`draw_aside`).

A drawing process runs one job, a module-level function and its (picklable) arguments, and
sends back its return value and the warnings it raised, which are raised again here, never
silenced. Whatever goes wrong there (no process could start, it ended, the job raised), the
job runs in this process instead, as it would without it: the results, and the error a broken
input gives, do not depend on where the figures were drawn. On an interrupt the processes are
asked to stop (their files are written atomically: a stopped job leaves none half-written) and
waited for; an idle process ends with this one (its parent), or after :data:`IDLE_SECONDS`.
"""

from __future__ import annotations

import atexit
import os
import pickle
import signal
import subprocess
import sys
import warnings

__all__ = ["IDLE_SECONDS", "DRAWERS", "MODULES", "start_drawers", "idle_drawers", "draw_aside",
           "stop_drawers"]

#: An idle drawing process ends after this long [s] without a job (a study measured from a
#: notebook whose figures are never drawn); a job sent later then runs in this process.
IDLE_SECONDS = 900.0

#: What a drawing process runs (``python -c CHILD --parent PID [MODULE ...]``): :func:`_main`.
CHILD = "import sys; from radiosim.drawing import _main; _main(sys.argv[1:])"

_IDLE: list = []  # started drawing processes without a job yet


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


#: How many drawing processes ``radiosim run`` starts (on two cores or more): the paper's
#: figures in two shares of about equal time (:data:`radiosim.paper.figures.FIGURE_SECONDS`).
DRAWERS = 2

#: What a drawing process imports while it waits, besides matplotlib: the reading of results
#: (an EXR file's measurement and its camera).
MODULES = ("radiosim.plotting", "radiosim.io.exr", "radiosim.camera")


def start_drawers(count: int, modules=MODULES) -> int:
    """
    Have ``count`` drawing processes ready (started now, or idle from before), each importing
    matplotlib and ``modules`` (names of modules) while it waits for its job; none on a machine
    of one core (there the figures are drawn here). Returns how many are ready. A process that
    cannot start is left out: its job will run here.
    """
    _IDLE[:] = [p for p in _IDLE if p.poll() is None]
    if _cores() < 2 or os.name != "posix":  # one core, or no select() on a pipe
        return 0
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    paths = [package, os.environ.get("PYTHONPATH", "")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in paths if p))
    while len(_IDLE) < count:
        try:
            process = subprocess.Popen(
                [sys.executable, "-c", CHILD, "--parent", str(os.getpid()), *modules],
                env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL)
        except (OSError, ValueError):
            break
        _IDLE.append(process)
        if len(_IDLE) == 1:
            atexit.register(_end_idle)
    return len(_IDLE)


def _end_idle() -> None:
    """End the idle drawing processes at once (also at exit)."""
    while _IDLE:
        process = _IDLE.pop()
        try:
            process.kill()
            process.wait()
        except OSError:
            pass
        for stream in (process.stdin, process.stdout):
            try:
                stream.close()
            except OSError:
                pass


def idle_drawers() -> int:
    """How many drawing processes are ready for a job."""
    _IDLE[:] = [p for p in _IDLE if p.poll() is None]
    return len(_IDLE)


def stop_drawers() -> None:
    """End the idle drawing processes (a study whose figures will not be drawn): they hold
    nothing to clean up."""
    _end_idle()


def _stop(process, grace: float = 2.0) -> None:
    """Ask ``process`` to stop (SIGTERM: it unwinds, its partial files removed) and wait for it,
    at most ``grace`` [s], then kill it."""
    if process.poll() is None:
        try:
            process.send_signal(signal.SIGTERM)
            process.wait(grace)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        except OSError:
            pass
    for stream in (process.stdin, process.stdout):
        try:
            stream.close()
        except OSError:
            pass


def _send(process, job: bytes) -> bool:
    """Give ``process`` its job; False if it has ended (then the job runs here)."""
    try:
        process.stdin.write(job)
        process.stdin.close()
        return True
    except (OSError, ValueError):
        return False


def _receive(process):
    """The reply of ``process`` to its job: ``(value, warnings)``, or ``None`` if it sent none
    (it ended, or its job raised)."""
    try:
        reply = process.stdout.read()
        process.wait()
        outcome = pickle.loads(reply) if reply else None
    except Exception:  # noqa: BLE001 - a truncated or unreadable reply: the job runs here
        return None
    finally:
        process.stdout.close()
    if not isinstance(outcome, tuple) or len(outcome) != 3 or outcome[0] != "done":
        return None
    return outcome[1], outcome[2]


def draw_aside(jobs) -> list:
    """
    Run ``jobs``, each ``(function, args)``: each in one of the ready drawing processes
    (:func:`start_drawers`) where it pickles (a module-level function, picklable arguments);
    the rest, and any whose process fails, here, in order. Returns their values in the order of
    ``jobs``; the warnings a job raised there are raised here again, in the jobs' order.
    """
    jobs = list(jobs)
    sent = []
    try:
        for function, args in jobs:
            process = None
            try:
                job = pickle.dumps((function, tuple(args)), protocol=pickle.HIGHEST_PROTOCOL)
            except Exception:  # noqa: BLE001 - e.g. a local function: it runs here
                job = None
            while job is not None and _IDLE and process is None:
                candidate = _IDLE.pop(0)
                if candidate.poll() is None and _send(candidate, job):
                    process = candidate
                else:
                    _stop(candidate)
            sent.append(process)
        values = []
        for (function, args), process in zip(jobs, sent):
            outcome = None if process is None else _receive(process)
            if outcome is None:
                values.append(function(*args))
                continue
            value, raised = outcome
            for message, category, filename, lineno in raised:
                warnings.warn_explicit(message, category, filename, lineno)
            values.append(value)
        return values
    finally:  # an interrupt or an error here: the processes still drawing stop, cleanly
        for process in sent:
            if process is not None:
                _stop(process)


def _main(argv) -> None:
    """A drawing process: import matplotlib and the modules named (on a thread of lowest
    priority), wait for one job on stdin, run it (at normal priority, once those imports are
    done), write ``("done", value, warnings)`` to stdout (nothing if it raised), and end the
    process: 0, 130 when stopped (SIGTERM or Ctrl-C, unwound), 1 when its job raised."""
    import select
    import threading

    from radiosim.compiling_process import watch_parent

    argv = list(argv)
    reply = os.fdopen(os.dup(1), "wb")  # the job's own prints go nowhere, not into the reply
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # unwind as on Ctrl-C
    try:
        watch_parent(argv)
        loader = threading.Thread(target=_preload, args=(argv, True), daemon=True,
                                  name="radiosim-drawing-preload")
        loader.start()
        ready, _, _ = select.select([sys.stdin.buffer], [], [], IDLE_SECONDS)
        data = sys.stdin.buffer.read() if ready else b""
        if not data:  # idle too long, or the parent is done without a job for it
            os._exit(0)
        loader.join()
        function, args = pickle.loads(data)
        with warnings.catch_warnings(record=True) as raised:
            value = function(*args)
        raised = [_picklable(w) for w in raised]
        reply.write(pickle.dumps(("done", value, raised), protocol=pickle.HIGHEST_PROTOCOL))
        reply.close()
        code = 0
    except KeyboardInterrupt:  # unwound: a job's partial files are removed
        code = 130
    except Exception:  # noqa: BLE001 - no reply: the parent runs the job itself, and raises
        code = 1
    # Its files are complete (written atomically and synced) or removed: end now, without the
    # interpreter's tear-down of matplotlib and numba, which the parent would wait for.
    os._exit(code)


def _preload(modules, lowest: bool = False) -> None:
    """Import matplotlib's drawing modules and its default font, then ``modules``; with
    ``lowest``, on this thread at the lowest priority (nice 19: the measurements beside it
    come first; on Linux a thread's priority is its own, so the job runs at normal priority)."""
    import importlib
    import threading

    if lowest:
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 19)
        except (AttributeError, OSError):  # not a thread's own elsewhere: left as it is
            pass
    try:
        from radiosim.plotting import load_matplotlib

        load_matplotlib()
    except Exception:  # noqa: BLE001 - the job raises it (then runs in the parent)
        pass
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - the job that needs it raises it (then runs there)
            pass


def _picklable(warning) -> tuple:
    """A recorded warning as ``(message, category, filename, lineno)``, its message and
    category as raised where they pickle, else as text and a :class:`UserWarning`."""
    entry = (warning.message, warning.category, warning.filename, warning.lineno)
    try:
        pickle.loads(pickle.dumps(entry))
        return entry
    except Exception:  # noqa: BLE001
        return (str(warning.message), UserWarning, warning.filename, warning.lineno)

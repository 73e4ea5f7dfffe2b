"""
Drawing figures in other processes: a figure is Python work (ticks, texts, paths) that holds the
interpreter for about a second, and matplotlib's import holds it for half a second more. In
processes of their own, started by ``radiosim run`` before it loads the study
(:func:`start_drawers`), matplotlib loads beside the measurements instead of taking the
interpreter from them, and the figures are drawn there, on the other core, when the results
are in (:func:`draw_aside`).

A drawing process runs one job, a module-level function and its (picklable) arguments, in the
parent's working folder, and sends back its return value and every warning it raised (all of
them recorded, whatever the filters there), which are raised again here, through this process's
filters, as if raised here. Whatever goes wrong there (no process could start, it ended, the
job raised), the job runs in this process instead, as it would without it, and the error a
broken input gives is raised here. A caller that has set matplotlib up in this process
(rcParams, a style) draws here: a drawing process draws with matplotlib's defaults
(:func:`matplotlib_configured`). On an interrupt the processes drawing are asked to stop (they
unwind: files written atomically leave nothing half-written) and waited for; an idle process
ends with this one (its parent). POSIX only, two cores or more.
"""

from __future__ import annotations

import atexit
import os
import pickle
import signal
import struct
import subprocess
import sys
import threading
import warnings

__all__ = ["DRAWERS", "MODULES", "start_drawers", "idle_drawers", "draw_aside",
           "stop_drawers", "matplotlib_configured"]

#: How many drawing processes ``radiosim run`` starts (on two cores or more): the paper's
#: figures in two shares of about equal time (:data:`radiosim.paper.figures.FIGURE_SECONDS`).
DRAWERS = 2

#: What a drawing process imports while it waits, besides matplotlib: the reading of results
#: (an EXR file's measurement and its camera) and the paper's figures.
MODULES = ("radiosim.plotting", "radiosim.io.exr", "radiosim.camera", "radiosim.paper.figures")

#: What a drawing process runs (``python -P -c CHILD --parent PID [MODULE ...]``, ``-P``: its
#: working folder is not on its import path): :func:`_main`.
CHILD = "import sys; from radiosim.drawing import _main; _main(sys.argv[1:])"

_IDLE: list = []  # started drawing processes without a job yet
_LOCK = threading.Lock()  # guards _IDLE
_HEADER = struct.Struct("<Q")  # a job's length [bytes], before it
_REGISTRIES: dict = {}  # warnings' registries of modules a drawing process raised them from


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _close(process) -> None:
    for stream in (process.stdin, process.stdout):
        try:
            stream.close()
        except OSError:
            pass


def _prune() -> None:
    """Forget the idle processes that have ended (their pipes closed). Under ``_LOCK``."""
    for process in [p for p in _IDLE if p.poll() is not None]:
        _IDLE.remove(process)
        _close(process)


def start_drawers(count: int, modules=MODULES) -> int:
    """
    Have ``count`` drawing processes ready (started now, or idle from before), each importing
    ``modules`` (names of modules) and matplotlib while it waits for its job; none on a
    machine of one core or off POSIX (there the figures are drawn here). Returns how many are
    ready. A process that cannot start is left out: its job will run here.
    """
    if _cores() < 2 or os.name != "posix":  # one core, or no fork-safe pipes and signals
        return 0
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    paths = [package, os.environ.get("PYTHONPATH", "")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in paths if p))
    command = [sys.executable, *subprocess._args_from_interpreter_flags(), "-P", "-c", CHILD,
               "--parent", str(os.getpid()), *modules]
    with _LOCK:
        _prune()
        missing = count - len(_IDLE)
    for _ in range(missing):
        try:
            process = subprocess.Popen(command, env=env, stdin=subprocess.PIPE,
                                       stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        except (OSError, ValueError):
            break
        with _LOCK:
            _IDLE.append(process)
    return idle_drawers()


def idle_drawers() -> int:
    """How many drawing processes are ready for a job."""
    with _LOCK:
        _prune()
        return len(_IDLE)


def stop_drawers() -> None:
    """End the idle drawing processes at once (a study whose figures will not be drawn; also
    at exit): they hold nothing to clean up."""
    with _LOCK:
        idle = list(_IDLE)
        _IDLE.clear()
    for process in idle:
        try:
            process.kill()
            process.wait()
        except OSError:
            pass
        _close(process)


atexit.register(stop_drawers)


def _forget_in_fork() -> None:
    """In a child forked from this process (multiprocessing, Dask): the drawing processes are
    not its own; close its copies of their pipes (and take a new lock: a thread of the parent
    may have held it at the fork)."""
    global _LOCK
    _LOCK = threading.Lock()
    for process in _IDLE:
        _close(process)
    _IDLE.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_in_fork)


#: matplotlib's settings that do not change how a figure is drawn (its own list of settings a
#: style does not set, less the dates' epoch and time zone).
_NOT_DRAWING = frozenset({
    "backend", "backend_fallback", "interactive", "toolbar", "figure.max_open_warning",
    "figure.raise_window", "savefig.directory", "tk.window_focus", "docstring.hardcopy",
    "webagg.address", "webagg.open_in_browser", "webagg.port", "webagg.port_retries"})


def matplotlib_configured() -> bool:
    """Whether this process has changed matplotlib's settings since it read them from its
    files (rcParams set, a style or a context in use): a drawing process, which reads the same
    files, would not share them, so figures are then drawn here. (The settings that do not
    change a drawing are left out, :data:`_NOT_DRAWING`: the backend, e.g., as the figures
    are drawn by Agg either way.)"""
    mpl = sys.modules.get("matplotlib")
    if mpl is None:
        return False
    try:
        keys = set(mpl.rcParams) - _NOT_DRAWING
        return any(mpl.rcParams[k] != mpl.rcParamsOrig[k] for k in keys)
    except Exception:  # noqa: BLE001 - settings that cannot be compared: draw here
        return True


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
    _close(process)


def _send(process, job: bytes) -> bool:
    """Give ``process`` its job, its length first (the process reads exactly that: a copy of
    the pipe in a forked child cannot hold it waiting for the end of its input); False if it
    has ended (then the job runs here)."""
    try:
        process.stdin.write(_HEADER.pack(len(job)) + job)
        process.stdin.close()
        return True
    except (OSError, ValueError):
        return False


def _receive(process):
    """The reply of ``process`` to its job: ``(value, warnings)``, or ``None`` if it sent none
    (it ended, or its job raised)."""
    try:
        reply = process.stdout.read()
        try:
            process.wait(5)  # it has replied: only its exit handlers are left
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        outcome = pickle.loads(reply) if reply else None
    except Exception:  # noqa: BLE001 - a truncated or unreadable reply: the job runs here
        return None
    finally:
        _close(process)
    if not isinstance(outcome, tuple) or len(outcome) != 3 or outcome[0] != "done":
        return None
    return outcome[1], outcome[2]


def _raise_again(raised) -> None:
    """Raise the warnings a drawing process recorded, through this process's filters, as from
    their module (its registry: one shown once per place, as if raised here)."""
    for message, category, filename, lineno, module in raised:
        where = sys.modules.get(module)
        registry = (_REGISTRIES.setdefault(module, {}) if where is None
                    else where.__dict__.setdefault("__warningregistry__", {}))
        warnings.warn_explicit(message, category, filename, lineno, module=module,
                               registry=registry)


def draw_aside(jobs) -> list:
    """
    Run ``jobs``, each ``(function, args)``: each in one of the ready drawing processes
    (:func:`start_drawers`) where it pickles (a module-level function, picklable arguments);
    the rest, and any whose process fails, here, in order. Returns their values in the order of
    ``jobs``; the warnings a job raised there are raised here again, in the jobs' order.
    """
    jobs = list(jobs)
    sent, taken = [], []
    try:
        for function, args in jobs:
            process = None
            try:
                job = pickle.dumps((os.getcwd(), function, tuple(args)),
                                   protocol=pickle.HIGHEST_PROTOCOL)
            except Exception:  # noqa: BLE001 - e.g. a local function: it runs here
                job = None
            while job is not None and process is None:
                with _LOCK:
                    candidate = _IDLE.pop(0) if _IDLE else None
                if candidate is None:
                    break
                taken.append(candidate)
                if candidate.poll() is None and _send(candidate, job):
                    process = candidate
            sent.append(process)
        values = []
        for (function, args), process in zip(jobs, sent):
            outcome = None if process is None else _receive(process)
            if outcome is None:
                values.append(function(*args))
                continue
            value, raised = outcome
            _raise_again(raised)
            values.append(value)
        return values
    finally:  # an interrupt or an error here: the processes still drawing stop, cleanly
        for process in taken:
            _stop(process)


def _read_job(stream) -> bytes:
    """The job on ``stream``: its length, then that many bytes (``b""`` if it ends first)."""
    head = stream.read(_HEADER.size)
    if len(head) < _HEADER.size:
        return b""
    size = _HEADER.unpack(head)[0]
    data = stream.read(size)
    return data if len(data) == size else b""


def _main(argv) -> None:
    """A drawing process: import the modules named and matplotlib (on a thread of lowest
    priority), wait for one job on stdin, run it (once those imports are done, at normal
    priority) in the parent's working folder, write ``("done", value, warnings)`` to stdout
    (nothing if it raised), and end: 0, 130 when stopped (SIGTERM or Ctrl-C, unwound), 1 when
    its job raised."""
    from radiosim.compiling_process import watch_parent

    argv = list(argv)
    reply = os.fdopen(os.dup(1), "wb")  # the job's own prints go nowhere, not into the reply
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # unwind as on Ctrl-C
    code = 1
    try:
        watch_parent(argv)
        # Everything, numpy first, is imported at the lowest priority (the threads numpy's
        # BLAS starts keep it: figures do not use them).
        loader = threading.Thread(target=_preload, args=(argv, True), daemon=True,
                                  name="radiosim-drawing-preload")
        loader.start()
        data = _read_job(sys.stdin.buffer)
        if data:  # else the parent is done without a job for it
            loader.join()
            folder, function, args = pickle.loads(data)
            os.chdir(folder)
            with warnings.catch_warnings(record=True) as raised:
                warnings.simplefilter("always")  # all of them: the parent's filters decide
                value = function(*args)
            raised = [_picklable(w) for w in raised]
            reply.write(pickle.dumps(("done", value, raised), protocol=pickle.HIGHEST_PROTOCOL))
            reply.close()
        code = 0
    except KeyboardInterrupt:  # unwound: a job's partial files are removed
        code = 130
    except BaseException:  # noqa: BLE001 - no reply: the parent runs the job itself, and raises
        code = 1
    # Its files are complete (written atomically and synced) or removed. The exit handlers
    # (matplotlib's removes a temporary configuration folder) run, the interpreter's tear-down
    # of matplotlib and numba, which the parent would wait for, does not.
    try:
        atexit._run_exitfuncs()
    finally:
        os._exit(code)


def _preload(modules, lowest: bool = False) -> None:
    """Import ``modules``, then matplotlib's drawing modules and its default font; with
    ``lowest`` on Linux, on this thread at the lowest priority (nice 19, a thread's own there:
    the measurements beside it come first, and the job runs at normal priority)."""
    import importlib

    if lowest and sys.platform.startswith("linux"):
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 19)
        except (AttributeError, OSError):
            pass
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - the job that needs it raises it (then runs there)
            pass
    try:
        from radiosim.plotting import load_matplotlib

        load_matplotlib()
    except Exception:  # noqa: BLE001 - the job raises it (then runs in the parent)
        pass


def _picklable(warning) -> tuple:
    """A recorded warning as ``(message, category, filename, lineno, module)``, its message and
    category as raised where they pickle, else as text and a :class:`UserWarning`; ``module``
    the name of the module of ``filename``, as :func:`warnings.warn` finds it."""
    module = next((name for name, m in list(sys.modules.items())
                   if getattr(m, "__file__", None) == warning.filename), None)
    if module is None:
        module = os.path.splitext(os.path.basename(warning.filename or ""))[0] or "<unknown>"
    entry = (warning.message, warning.category, warning.filename, warning.lineno, module)
    try:
        pickle.loads(pickle.dumps(entry))
        return entry
    except Exception:  # noqa: BLE001
        return (str(warning.message), UserWarning, warning.filename, warning.lineno, module)

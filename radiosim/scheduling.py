"""
The Dask engine that studies and uncertainty budgets run on, and what travels with its tasks.

:func:`connect` gives ``(run, close)``: ``run(function, argument_lists, shared=())`` returns
the tasks' results in order, on the synchronous or threads scheduler in this process, a local
``distributed`` cluster of worker processes, or a scheduler by address (checked, and its
handshake bounded by :data:`SCHEDULER_TIMEOUT`). Seeds are spawned per task from one
:class:`numpy.random.SeedSequence`, so any scheduler gives identical bits; a task's
:class:`~radiosim.errors.RadiosimWarning`\\ s are recorded (:func:`recorded_warnings`) and
travel back with its value, for the caller to raise again, never silenced.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import threading
import warnings

import numpy as np

from radiosim.checks import check_positive, check_rng
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.interrupts import raise_if_interrupted

__all__ = ["connect", "SCHEDULER_TIMEOUT", "recorded_warnings", "recording_run", "seed_sequence",
           "spawn_seeds", "recorded_call", "with_eta", "CLUSTER_START_SECONDS",
           "CLUSTER_TASK_FACTOR", "SECONDS_PER_SAMPLE", "cluster_overhead", "worth_a_cluster",
           "local_workers"]


class _quiet:
    """Loggers raised to CRITICAL for a block (a cluster's shutdown chatter)."""

    def __init__(self, *names):
        self.loggers = [logging.getLogger(n) for n in names]

    def __enter__(self):
        self.levels = [log.level for log in self.loggers]
        for log in self.loggers:
            log.setLevel(logging.CRITICAL)

    def __exit__(self, *exc):
        for log, level in zip(self.loggers, self.levels):
            log.setLevel(level)
        return False


#: Seconds a scheduler address has to answer (connect and handshake) before it is given up.
SCHEDULER_TIMEOUT = 10.0


def _check_address(address: str) -> None:
    """A scheduler address as ``tcp://HOST:PORT`` (or tls://…), or a RadiosimError naming it."""
    from distributed.comm.addressing import parse_address, parse_host_port

    expected = "expected tcp://HOST:PORT, e.g. tcp://127.0.0.1:8786"
    try:
        protocol, location = parse_address(address)
        host, port = parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise RadiosimError(f"scheduler address {address!r} is malformed ({exc}); "
                            f"{expected}") from None
    if protocol not in ("tcp", "tls", "ucx", "inproc") or not host:
        raise RadiosimError(f"scheduler address {address!r}: no host or an unknown protocol "
                            f"{protocol!r}; {expected}")
    if not isinstance(port, int) or not 0 < port < 65536:
        raise RadiosimError(f"scheduler address {address!r}: port {port!r} is not in "
                            f"1–65535; {expected}")


def _probe(address: str, timeout: float) -> None:
    """Connect to ``address`` and complete distributed's handshake within ``timeout`` [s]
    (distributed's own connect waits for the handshake without a bound), or raise a
    RadiosimError naming it."""
    import asyncio
    import threading

    from distributed.comm import connect as open_comm

    outcome = []

    async def handshake():
        comm = await asyncio.wait_for(open_comm(address, timeout=timeout), timeout)
        await comm.close()

    def attempt():  # its own thread and loop: works under a caller's running loop too
        try:
            asyncio.run(handshake())
            outcome.append(None)
        except BaseException as exc:  # reported below, in one line
            outcome.append(exc)

    thread = threading.Thread(target=attempt, daemon=True, name="radiosim-scheduler-probe")
    thread.start()
    thread.join(timeout + 2.0)
    error = outcome[0] if outcome else TimeoutError()
    if error is None:
        return
    if isinstance(error, (TimeoutError, asyncio.TimeoutError)) or "Timed out" in str(error):
        raise RadiosimError(f"the Dask scheduler at {address} did not answer within "
                            f"{timeout:g} s (is a Dask scheduler listening there?)")
    raise RadiosimError(f"cannot reach the Dask scheduler at {address}: "
                        f"{getattr(error, 'strerror', None) or error}")


def _kept(value):
    """A task's value as given: what the tasks share, kept on the workers (:func:`connect`)."""
    return value


def _lost_scheduler() -> tuple:
    """The errors distributed raises for futures whose scheduler went away mid-run."""
    import asyncio

    from distributed.client import FutureCancelledError, FuturesCancelledError
    from distributed.comm.core import CommClosedError

    return (FutureCancelledError, FuturesCancelledError, asyncio.CancelledError,
            CommClosedError)


def _wait_while_answering(client, futures, timeout: float) -> None:
    """Wait for ``futures`` as long as the scheduler answers: every ``timeout`` [s] without
    them all, its handshake is tried again (:func:`_probe`), so a scheduler that stops
    answering mid-run (stopped, its host gone) ends the wait in one error line within about
    twice ``timeout``, where distributed would wait for ever."""
    from distributed import wait

    address = getattr(getattr(client, "scheduler", None), "address", None)
    while True:
        try:
            wait(futures, timeout=timeout)
            return
        except TimeoutError:
            if address is not None:
                _probe(address, timeout)


#: Seconds a local cluster costs before and after its work, measured on 2 cores by
#: ``benchmarks/bench_cluster.py`` (warm numba cache, quiet host, 2026-11-26): a study of two
#: one-frame measurements took 3.27 s on a ``LocalCluster`` of 2 single-threaded worker
#: processes against 0.05 s in this process: starting the cluster and its client (0.5 s), each
#: worker importing radiosim to unpickle the scene, loading the compiled kernels and building
#: the scene's geometry for its first measurement, and closing it (0.1 s). A loaded host
#: doubles it.
CLUSTER_START_SECONDS = 3.2

#: Work of a study's measurements on a local cluster, times the workers sharing it, over the
#: same measurements in this process (``benchmarks/bench_cluster.py``, the paper's study: 23.3 s
#: on 2 workers against 3.3 s here, 3.2 s of it the start). A task makes the frames of its own
#: window on its worker's share of the cores (one thread each of 2 workers on 2 cores), where
#: this process measures all the cases of a scene in one pass over their frames, its kernels
#: on every core (``radiosim.camera.measure_many_statistics``): the 44 measurements of the
#: paper's study share the chip's frames, which the tasks make 44 times. So on 2 cores a local
#: cluster never gains on a study (12 / 2 workers > 1); where many cores share the work it may,
#: though there this process's kernels have more threads too: the factor is measured on 2
#: cores only, and ``benchmarks/bench_cluster.py`` measures it on the machine at hand.
CLUSTER_TASK_FACTOR = 12.0

#: The same for a study's tasks since issue 43 — per scene, one task per part of the frames its
#: cases' windows span (``radiosim.acquisition.part_frames``), its cases sharing each part's
#: pass on a worker, as this process measures them — measured by ``benchmarks/bench_cluster.py``
#: (2 cores, 2026-11-29): the paper's study, 9 tasks (8 parts of the chip's 450 frames, the
#: pixel sweep's crop), took 6.34 s on 2 workers (2.57 s of it the start) against 3.29 s here
#: (7.4 s with a task a scene, 23.3 s with a task a measurement). Its 2.3 is per core-second
#: 1.15: a worker's one thread does the work of this process's two threads' half, and a bit.
STUDY_TASK_FACTOR = 2.3

#: Seconds [s] a measurement spends per sample it reads and frame of its window in this
#: process, warm, on 2 cores: the paper's study (44 measurements reading 4.97e9 sample-frames
#: in all, the field sweeps' whole chip and the pixel sweep's footprints) took 3.3 s
#: (``benchmarks/bench_cluster.py``, quiet host; 4.3 s in a slower minute). The estimate
#: :meth:`radiosim.study.Study.run` gives :func:`local_workers`.
SECONDS_PER_SAMPLE = 6.6e-10


def _cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def cluster_overhead(workers: int, cores: int | None = None) -> float:
    """Seconds [s] a local cluster of ``workers`` processes adds to the work: start, shipping,
    warm-up and close (:data:`CLUSTER_START_SECONDS`, measured with 2 workers on 2 cores),
    longer where more workers than ``cores`` (default: this process's) warm up on them."""
    cores = _cores() if cores is None else int(cores)
    return CLUSTER_START_SECONDS * max(1.0, workers / max(1, cores))


def _seconds(value: float) -> str:
    return f"{value:.2g}" if value < 10 else f"{value:.0f}"


def worth_a_cluster(n_measurements: int, seconds_per_measurement: float, workers: int,
                    cores: int | None = None, task_factor: float = CLUSTER_TASK_FACTOR,
                    unit: str = "measurement") -> tuple[bool, str]:
    """
    Whether a local cluster of ``workers`` processes finishes ``n_measurements`` sooner than
    this process alone, and why, in one line.

    In this process the work takes ``n_measurements × seconds_per_measurement`` [s]; on the
    cluster, :func:`cluster_overhead` plus that work times ``task_factor`` (a task's work
    there over the same work here: :data:`CLUSTER_TASK_FACTOR` for tasks that each make their
    own frames, :data:`STUDY_TASK_FACTOR` for a study's tasks, a part of a scene's frames
    each), shared by ``min(workers, cores, n_measurements)`` processes. The cluster is chosen only if it
    saves at least 10 % of the time.

    Parameters
    ----------
    n_measurements
        Tasks to run (measurements, or batches of draws).
    seconds_per_measurement
        Estimated seconds [s] of one in this process (warm).
    workers
        Worker processes asked for.
    cores
        Cores to share (default: those this process may run on).
    task_factor, unit
        A task's work on the cluster over the same here (above), and what a task is called.

    Returns
    -------
    (bool, str)
        The choice and the reason, e.g. ``(False, "2 workers: a local cluster would take
        about 23 s against 3.3 s in this process (44 measurements of about 0.075 s on 2 cores;
        starting it costs 3.2 s); measuring in this process")``.

    Examples
    --------
    >>> worth_a_cluster(44, 0.075, 2, cores=2)[0]
    False
    >>> worth_a_cluster(400, 2.0, 2, cores=2)[0]  # 800 s alone, 4,800 s on the cluster
    False
    >>> worth_a_cluster(400, 2.0, 32, cores=32)[0]  # 800 s alone, 300 s on the cluster
    True
    """
    if isinstance(workers, bool) or int(workers) != workers or workers < 1:
        raise RadiosimError(f"workers must be a whole number ≥ 1, got {workers!r}")
    if not (seconds_per_measurement >= 0):  # NaN too
        raise RadiosimError(f"seconds_per_measurement must be ≥ 0 [s], got "
                            f"{seconds_per_measurement!r}")
    n = int(n_measurements)
    cores = _cores() if cores is None else int(cores)
    alone = n * seconds_per_measurement
    share = max(1, min(int(workers), cores, n))
    overhead = cluster_overhead(workers, cores)
    cluster = overhead + alone * float(task_factor) / share
    what = (f"{int(workers)} workers: a local cluster would take about {_seconds(cluster)} s "
            f"against {_seconds(alone)} s in this process ({n} {unit}"
            f"{'' if n == 1 else 's'} of about {_seconds(seconds_per_measurement)} s on "
            f"{cores} core{'' if cores == 1 else 's'}; starting it costs "
            f"{_seconds(overhead)} s)")
    if cluster <= 0.9 * alone:
        return True, f"{what}; starting it"
    return False, f"{what}; measuring in this process"


def local_workers(workers: int | None, n_measurements: int, seconds_per_measurement: float,
                  cores: int | None = None, task_factor: float = CLUSTER_TASK_FACTOR,
                  unit: str = "measurement") -> int | None:
    """
    ``workers`` if a local cluster of them pays (:func:`worth_a_cluster`, with
    ``task_factor``), else ``None`` (run in this process), the reason logged as one warning
    line either way it declines.
    """
    if workers is None:
        return None
    gain, reason = worth_a_cluster(n_measurements, seconds_per_measurement, workers, cores,
                                   task_factor, unit)
    if not gain:
        logging.getLogger(__name__).warning(reason)
        return None
    logging.getLogger(__name__).info(reason)
    return workers


def connect(scheduler=None, workers: int | None = None, timeout: float | None = None):
    """
    The Dask engine: ``(run, close)`` where ``run(function, argument_lists)`` returns the
    results in order.

    ``scheduler``: ``None`` or ``"synchronous"`` (in this process, in order), ``"threads"``
    (a local thread pool sized to the machine), a ``distributed.Client``, or an address
    ``"tcp://HOST:PORT"``; ``workers``: start a local ``distributed`` cluster of that many
    single-threaded worker processes. ``RADIOSIM_SCHEDULER`` gives the address when neither
    is given. A malformed address is refused naming it; one that does not complete the
    handshake within ``timeout`` seconds (default :data:`SCHEDULER_TIMEOUT`) is given up with
    one error line.
    """
    import dask

    if workers is not None and (isinstance(workers, bool) or int(workers) != workers
                                or workers < 1):
        raise RadiosimError(f"workers must be a whole number ≥ 1, got {workers!r}")
    scheduler = scheduler if scheduler is not None or workers else (
        os.environ.get("RADIOSIM_SCHEDULER") or None)  # set but empty: unset
    client, cluster = None, None
    if workers:
        from distributed import Client, LocalCluster

        for name in ("distributed", "distributed.scheduler", "distributed.http.proxy"):
            # A local cluster is an engine here, not a service: its start-up chatter stays out.
            logger = logging.getLogger(name)
            logger.setLevel(max(logger.getEffectiveLevel(), logging.WARNING))

        # Each worker's compiled kernels get their share of the cores (not all of them each:
        # N workers × all cores would oversubscribe the machine).
        threads = str(max(1, (os.cpu_count() or 1) // int(workers)))
        # SIGINT blocked while the cluster starts: the threads Dask starts (and the worker
        # processes they spawn) inherit the mask, so a Ctrl-C reaches this process alone, which
        # shuts the workers down, instead of printing one traceback per worker.
        blocked = threading.current_thread() is threading.main_thread()
        if blocked:
            mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            cluster = LocalCluster(
                n_workers=int(workers), threads_per_worker=1, processes=True,
                dashboard_address=":0",  # any free port
                silence_logs=logging.ERROR,
                env={"NUMBA_NUM_THREADS": threads})
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        client = Client(cluster)
    elif isinstance(scheduler, str) and "://" in scheduler:
        from distributed import Client

        wait = SCHEDULER_TIMEOUT if timeout is None else check_positive(timeout, "timeout",
                                                                          "s")
        _check_address(scheduler)
        _probe(scheduler, wait)
        try:
            client = Client(scheduler, timeout=wait)
        except (OSError, ValueError, TypeError) as exc:
            raise RadiosimError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") \
                from None
    elif scheduler is not None and not isinstance(scheduler, str):
        client = scheduler  # a distributed.Client
    elif scheduler not in (None, "synchronous", "sync", "threads"):
        raise RadiosimError(f"the Dask scheduler must be 'synchronous', 'threads', a Client "
                            f"or a tcp:// address, got {scheduler!r}")

    if client is not None:
        wait = SCHEDULER_TIMEOUT if timeout is None else check_positive(timeout, "timeout", "s")

        def run(function, argument_lists, shared=()):
            # What the tasks share, sent as tasks of its own (not scattered: a submission
            # never blocks, and a worker that dies with it can make it again); each worker
            # fetches it once and keeps it while the tasks run.
            scattered = [client.submit(_kept, value, pure=False) for value in shared]
            futures = [client.submit(function, *scattered, *args, pure=False)
                       for args in argument_lists]
            try:
                _wait_while_answering(client, futures, wait)
                return client.gather(futures)
            except _lost_scheduler() as exc:  # the scheduler gone mid-run: one line
                address = getattr(getattr(client, "scheduler", None), "address", "")
                raise RadiosimError(f"lost the Dask scheduler {address} mid-run "
                                    f"({type(exc).__name__}: {str(exc).splitlines()[0][:120]})"
                                    ) from None
    else:
        name = "threads" if scheduler == "threads" else "synchronous"

        def run(function, argument_lists, shared=()):
            tasks = [dask.delayed(function, pure=False)(*shared, *args)
                     for args in argument_lists]
            return list(dask.compute(*tasks, scheduler=name))

    def close():
        if workers:
            # The workers close before the scheduler; their goodbye is not an error to show.
            with _quiet("distributed", "tornado", "asyncio"):
                client.close()
                cluster.close()
        elif client is not None and isinstance(scheduler, str):
            with _quiet("distributed", "tornado", "asyncio"):  # a stopped scheduler: no wait
                try:
                    client.close(timeout=wait)
                except (TimeoutError, OSError):
                    pass  # the scheduler is gone or stopped: nothing left to tell it

    return run, close



_RECORDER = threading.Lock()
_RECORDING = {"depth": 0, "saved": None}
_THREAD = threading.local()


def _dispatch(message, category, filename, lineno, file=None, line=None):
    """warnings.showwarning while recording: a RadiosimWarning goes to the list of the thread
    that raised it (if it records), anything else on as before."""
    texts = getattr(_THREAD, "texts", None)
    if texts is not None and issubclass(category, RadiosimWarning):
        texts.append(str(message))
        return
    _RECORDING["saved"][0](message, category, filename, lineno, file, line)


@contextlib.contextmanager
def recorded_warnings():
    """
    Record the :class:`~radiosim.errors.RadiosimWarning`\\ s raised in this thread during the
    block into the list it yields, instead of showing them (the caller raises them again or
    files them). Unlike :class:`warnings.catch_warnings`, threads that record at the same time
    (Dask's threads scheduler) each get their own warnings.
    """
    texts: list[str] = []
    with _RECORDER:
        if _RECORDING["depth"] == 0:
            _RECORDING["saved"] = (warnings.showwarning, list(warnings.filters))
            warnings.simplefilter("always", RadiosimWarning)  # every one, not once per place
            warnings.showwarning = _dispatch
        _RECORDING["depth"] += 1
    previous = getattr(_THREAD, "texts", None)
    _THREAD.texts = texts
    try:
        yield texts
    finally:
        _THREAD.texts = previous
        with _RECORDER:
            _RECORDING["depth"] -= 1
            if _RECORDING["depth"] == 0:
                shown, filters = _RECORDING["saved"]
                warnings.showwarning = shown
                warnings.filters[:] = filters
                for name in ("_filters_mutated", "_filters_mutated_lock_held"):
                    if callable(getattr(warnings, name, None)):
                        getattr(warnings, name)()  # the warnings' caches see the change
                        break


class _Recording:
    """A task function whose RadiosimWarnings are recorded, not shown: returns (value, the
    warnings' texts), so that they travel back from any worker."""

    def __init__(self, function):
        self.function = function

    def __call__(self, *args):
        raise_if_interrupted()  # one the work swallowed: raised again, task by task
        with recorded_warnings() as texts:
            value = self.function(*args)
        return value, texts


class _Timed:
    """A progress callback given the estimated seconds left, if it takes a third argument."""

    def __init__(self, callback):
        import inspect
        import time

        self.callback, self.clock = callback, time.monotonic
        self.start = self.clock()
        try:
            parameters = inspect.signature(callback).parameters.values()
            positional = [p for p in parameters if p.kind in (p.POSITIONAL_ONLY,
                                                               p.POSITIONAL_OR_KEYWORD)]
            self.eta = len(positional) >= 3 or any(p.kind == p.VAR_POSITIONAL
                                                   for p in parameters)
        except (TypeError, ValueError):
            self.eta = False

    def __call__(self, done, total):
        if not self.eta:
            return self.callback(done, total)
        elapsed = self.clock() - self.start
        left = elapsed / done * (total - done) if total and done else None
        return self.callback(done, total, left)


def with_eta(progress):
    """``progress(done, total)``, or ``progress(done, total, seconds_left)`` if it takes a
    third argument (the time to ``total`` estimated from the tasks so far [s]); ``None``
    stays ``None``."""
    return None if progress is None else _Timed(progress)


def recording_run(run, caught: dict):
    """
    ``run`` (an engine's, :func:`connect`) with each task's RadiosimWarnings recorded, not
    shown: their texts are counted into ``caught`` (text → evaluations that raised it), for the
    caller to raise each distinct one once, with its count (never silenced).
    """
    def recorded(function, argument_lists, shared=()):
        outcomes = run(_Recording(function), argument_lists, shared=shared)
        for _, texts in outcomes:
            for text in texts:
                caught[text] = caught.get(text, 0) + 1
        return [value for value, _ in outcomes]

    return recorded


def seed_sequence(rng) -> np.random.SeedSequence:
    """The root :class:`numpy.random.SeedSequence` of an evaluation whose tasks spawn their
    own generators: from a seed ≥ 0, ``None`` (fresh entropy) or a sequence (copied: the
    caller's is not spent)."""
    if isinstance(rng, np.random.SeedSequence):
        return np.random.SeedSequence(entropy=rng.entropy, spawn_key=rng.spawn_key)
    if rng is None or (isinstance(rng, (int, np.integer)) and not isinstance(rng, bool)
                       and rng >= 0):
        return np.random.SeedSequence(None if rng is None else int(rng))
    raise RadiosimError(f"rng must be a seed ≥ 0 or a numpy SeedSequence (each draw spawns "
                        f"its own generator from it), got {rng!r}")


def spawn_seeds(rng, distributed: bool) -> list:
    """A sequence whose item ``i`` seeds measurement ``i`` of a plan (spawned lazily)."""
    if isinstance(rng, np.random.SeedSequence):
        root = rng
    elif isinstance(rng, np.random.Generator) and not distributed:
        # a root drawn from the generator: its state moves on, as when it draws noise itself
        return _Spawned(np.random.SeedSequence([int(v) for v in rng.integers(2**63, size=4)]))
    elif rng is None and not distributed:
        root = np.random.SeedSequence()
    elif isinstance(rng, (int, np.integer)) and not isinstance(rng, bool) and rng >= 0:
        root = np.random.SeedSequence(int(rng))
    elif distributed:
        raise RadiosimError(f"a study on a Dask scheduler needs an integer seed ≥ 0 (or a "
                            f"SeedSequence), got {rng!r}")
    else:
        check_rng(rng)  # raises, naming what it accepts
        raise RadiosimError(f"rng must be a seed ≥ 0, a SeedSequence or a Generator, got "
                            f"{rng!r}")
    return _Spawned(root)


class _Spawned:
    """``root.spawn(n)``'s children, item ``i`` the same whatever slice is asked first."""

    def __init__(self, root: np.random.SeedSequence):
        self.root = np.random.SeedSequence(entropy=root.entropy, spawn_key=root.spawn_key)
        self.children: list = []

    def __getitem__(self, index):
        stop = index.stop if isinstance(index, slice) else index + 1
        if stop > len(self.children):
            self.children += self.root.spawn(stop - len(self.children))
        return self.children[index]


def recorded_call(function, *args):
    """``function(*args)`` and the texts of the RadiosimWarnings it raised (recorded, not
    shown: the caller raises them again, and a study files them in the row)."""
    with recorded_warnings() as texts:
        value = function(*args)
    return value, texts


"""
How far from the truth, with what uncertainty: a Monte Carlo budget after GUM Supplement 1,
run on Dask.

Uncertain inputs are distributions named by the parameter they perturb (:data:`INPUTS`); each
Monte Carlo draw samples every input, builds the perturbed camera and scene, and measures (its
own noise seed draws the temporal noise). :func:`propagate` returns, per pixel, the mean
apparent temperature, its standard uncertainty, the 95 % probabilistically symmetric coverage
interval and the error against the scene truth, and the budget: each input's contribution by
the GUM law of propagation (sensitivity coefficients from the chain, by central differences of
one standard uncertainty) and by one-input-at-a-time Monte Carlo.

Every draw is a Dask task. Its seed is spawned from one :class:`numpy.random.SeedSequence`
(the draw's index picks its child), so a budget gives identical bits on any scheduler and any
number of workers; draws are accumulated in index order. Tasks carry the scene as a recipe
(scenes pickle as their parameters, or as the path of a memory-mapped stack), never its
frames.

Memory is bounded in the number of draws: moments are streamed (Welford's update), and the
coverage interval's quantiles come from a per-pixel histogram of :data:`HISTOGRAM_BINS` bins
spanning ±8 standard deviations of the first 20 draws around their mean, interpolated linearly
within a bin (a quantile is resolved to 16/400 = 0.04 standard deviations; draws outside the
span are counted, and a pixel with more than 0.5 % of them there has no interval, NaN).

References
----------
-   JCGM 101:2008, Evaluation of measurement data — Supplement 1 to the GUM: Propagation of
    distributions using a Monte Carlo method (§7.7 the coverage interval, §7.9 the adaptive
    procedure).
-   JCGM 100:2008 (GUM), §5.1 (the law of propagation of uncertainty).
-   Lane, B., Whitenton, E., Madhavan, V. & Donmez, A. (2013). Uncertainty of temperature
    measurements by infrared thermography for metal cutting applications. Metrologia 50, 637.
-   Welford, B. P. (1962). Technometrics 4, 419 (the streaming variance).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
import signal
import threading
import warnings
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from radiosim.checks import check_positive
from radiosim.config import si_value
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.psf import GaussianBlur, ScatterHalo

__all__ = ["Distribution", "Normal", "Uniform", "Triangular", "TruncatedNormal", "Samples",
           "INPUTS", "distribution_from_table", "propagate", "UncertaintyResult",
           "connect", "HISTOGRAM_BINS", "MAX_DRAWS", "SCHEDULER_TIMEOUT",
           "recorded_warnings"]

#: Bins of each pixel's histogram (the quantile method, module docstring).
HISTOGRAM_BINS = 400
_SPAN_SIGMAS = 8.0
_SPAN_DRAWS = 20  # draws that set each pixel's histogram span
_MAX_OUTSIDE = 0.005


# -- distributions ---------------------------------------------------------------------------


class Distribution(ABC):
    """An input's probability distribution (its values in the input's SI unit)."""

    @abstractmethod
    def sample(self, rng: np.random.Generator):
        """One draw."""

    @property
    @abstractmethod
    def mean(self) -> float:
        """Expectation: the input's best estimate."""

    @property
    @abstractmethod
    def std(self) -> float:
        """Standard deviation: the input's standard uncertainty."""

    @abstractmethod
    def ppf(self, q):
        """Quantile function."""


@dataclass(frozen=True)
class Normal(Distribution):
    """Gaussian of ``mean`` and standard deviation ``sd``."""

    mu: float
    sd: float

    def __post_init__(self):
        check_positive(self.sd, "Normal standard deviation", "input unit")

    def sample(self, rng):
        return float(rng.normal(self.mu, self.sd))

    @property
    def mean(self):
        return float(self.mu)

    @property
    def std(self):
        return float(self.sd)

    def ppf(self, q):
        from scipy.stats import norm

        return norm.ppf(q, self.mu, self.sd)


@dataclass(frozen=True)
class Uniform(Distribution):
    """Rectangular on [``low``, ``high``] (GUM: u = (high − low)/√12).

    Examples
    --------
    >>> round(Uniform(0.2, 0.4).std, 6)
    0.057735
    """

    low: float
    high: float

    def __post_init__(self):
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.high > self.low):
            raise RadiosimError(f"Uniform needs finite low < high, got {self.low!r}, "
                                f"{self.high!r}")

    def sample(self, rng):
        return float(rng.uniform(self.low, self.high))

    @property
    def mean(self):
        return 0.5 * (self.low + self.high)

    @property
    def std(self):
        return (self.high - self.low) / math.sqrt(12.0)

    def ppf(self, q):
        return self.low + np.asarray(q) * (self.high - self.low)


@dataclass(frozen=True)
class Triangular(Distribution):
    """Triangular on [``low``, ``high``] with its mode at ``mode``."""

    low: float
    mode: float
    high: float

    def __post_init__(self):
        if not (self.low <= self.mode <= self.high and self.high > self.low):
            raise RadiosimError(f"Triangular needs low ≤ mode ≤ high and low < high, got "
                                f"{self.low!r}, {self.mode!r}, {self.high!r}")

    def sample(self, rng):
        return float(rng.triangular(self.low, self.mode, self.high))

    @property
    def mean(self):
        return (self.low + self.mode + self.high) / 3.0

    @property
    def std(self):
        a, c, b = self.low, self.mode, self.high
        return math.sqrt((a * a + b * b + c * c - a * b - a * c - b * c) / 18.0)

    def ppf(self, q):
        from scipy.stats import triang

        width = self.high - self.low
        return triang.ppf(q, (self.mode - self.low) / width, self.low, width)


@dataclass(frozen=True)
class TruncatedNormal(Distribution):
    """A Gaussian of ``mu`` and ``sd`` truncated to [``low``, ``high``]."""

    mu: float
    sd: float
    low: float
    high: float

    def __post_init__(self):
        check_positive(self.sd, "TruncatedNormal standard deviation", "input unit")
        if not self.high > self.low:
            raise RadiosimError(f"TruncatedNormal needs low < high, got {self.low!r}, "
                                f"{self.high!r}")

    def _frozen(self):
        from scipy.stats import truncnorm

        return truncnorm((self.low - self.mu) / self.sd, (self.high - self.mu) / self.sd,
                         self.mu, self.sd)

    def sample(self, rng):
        return float(self._frozen().ppf(rng.random()))

    @property
    def mean(self):
        return float(self._frozen().mean())

    @property
    def std(self):
        return float(self._frozen().std())

    def ppf(self, q):
        return self._frozen().ppf(q)


@dataclass(frozen=True, eq=False)
class Samples(Distribution):
    """An empirical distribution: draws resample ``values`` with replacement."""

    values: np.ndarray

    def __post_init__(self):
        values = np.asarray(self.values, dtype=float).ravel()
        if values.size < 2 or not np.all(np.isfinite(values)):
            raise RadiosimError("Samples needs at least two finite values")
        object.__setattr__(self, "values", values)

    def sample(self, rng):
        return float(self.values[rng.integers(self.values.size)])

    @property
    def mean(self):
        return float(self.values.mean())

    @property
    def std(self):
        return float(self.values.std())

    def ppf(self, q):
        return np.quantile(self.values, q)


#: TOML tables of distributions: ``{distribution = "uniform", low = …, high = …}``.
_DISTRIBUTIONS = {"normal": (Normal, ("mean", "std")),
                  "uniform": (Uniform, ("low", "high")),
                  "triangular": (Triangular, ("low", "mode", "high")),
                  "truncated_normal": (TruncatedNormal, ("mean", "std", "low", "high")),
                  "samples": (Samples, ("values",))}


def distribution_from_table(table: dict, name: str) -> Distribution:
    """A distribution from a TOML table (values in the input's unit, :data:`INPUTS`)."""
    if not isinstance(table, dict) or table.get("distribution") not in _DISTRIBUTIONS:
        raise RadiosimError(f"[uncertainty.inputs] {name} must be a table with distribution = "
                            f"one of {', '.join(_DISTRIBUTIONS)}, got {table!r}")
    cls, keys = _DISTRIBUTIONS[table["distribution"]]
    unknown = set(table) - set(keys) - {"distribution"}
    missing = set(keys) - set(table)
    if unknown or missing:
        raise RadiosimError(f"[uncertainty.inputs] {name} ({table['distribution']}) needs "
                            f"{', '.join(keys)}" + (f"; unknown {sorted(unknown)}" if unknown
                                                    else ""))
    scale = INPUTS[name][2] if name in INPUTS else 1.0  # the edge unit (µm, µs) → SI
    if table["distribution"] == "samples":
        return cls(np.asarray(table["values"], dtype=float) * scale)
    for k in keys:
        if isinstance(table[k], bool) or not isinstance(table[k], (int, float)):
            raise RadiosimError(f"[uncertainty.inputs] {name}: {k} must be a number, got "
                                f"{table[k]!r}")
    return cls(*(si_value(float(table[k]), scale) for k in keys))


# -- the inputs ------------------------------------------------------------------------------


def _emissivity(camera, scene, settings, value):
    return camera, scene.with_emissivity(float(value)), settings


def _reflected(camera, scene, settings, value):
    import copy

    out = copy.copy(scene)
    out.set_environment(**{**scene.environment, "reflected_temperature": value})
    return camera, out, settings


def _camera_field(name):
    def apply(camera, scene, settings, value):
        return camera.replace(**{name: value}), scene, settings
    return apply


def _psf_sigma(camera, scene, settings, value):
    if value <= 0:
        return camera, scene, settings
    psfs = tuple(camera.optics.psf or ()) + (GaussianBlur(value),)
    return camera.replace(optics=dataclasses.replace(camera.optics, psf=psfs)), scene, settings


def _halo_fraction(camera, scene, settings, value):
    psfs = list(camera.optics.psf or ())
    halos = [i for i, p in enumerate(psfs) if isinstance(p, ScatterHalo)]
    if halos:
        psfs[halos[0]] = ScatterHalo(value, psfs[halos[0]].width)
    else:
        psfs.append(ScatterHalo(value, 50e-6))
    return camera.replace(optics=dataclasses.replace(camera.optics, psf=tuple(psfs))), scene, \
        settings


def _window(key):
    def apply(camera, scene, settings, value):
        return camera, scene, {**settings, key: settings[key] + value}
    return apply


def _registration(axis):
    def apply(camera, scene, settings, value):
        origin = list(camera.fpa.origin)
        origin[axis] += value
        if origin[axis] < 0:
            raise RadiosimError(f"registration moves the array's origin to {origin} m: give the "
                                "camera an origin (fpa.origin) larger than the registration's "
                                "spread")
        fpa = dataclasses.replace(camera.fpa, origin=tuple(origin))
        return camera.replace(fpa=fpa), scene, settings
    return apply


#: The uncertain inputs by name: (what the value is, its unit, the TOML edge scale to SI, how it
#: is applied to (camera, scene, settings)).
INPUTS = {
    "emissivity": ("the scene's grey emissivity (metal regions of the chip)", "1", 1.0,
                   _emissivity),
    "assumed_emissivity": ("the camera's emissivity setting", "1", 1.0,
                           _camera_field("assumed_emissivity")),
    "reflected_temperature": ("the temperature the scene reflects", "K", 1.0, _reflected),
    "assumed_reflected_temperature": ("the camera's reflected-temperature setting", "K", 1.0,
                                      _camera_field("assumed_reflected_temperature")),
    "psf_sigma": ("a Gaussian blur added to the optics' PSF", "m", 1e-6, _psf_sigma),
    "halo_fraction": ("the scatter halo's fraction (a 50 µm halo if the optics have none)",
                      "1", 1.0, _halo_fraction),
    "calibration_scale": ("the calibration's radiometric scale", "1", 1.0,
                          _camera_field("calibration_scale")),
    "t_start": ("the integration window's start, added to the nominal", "s", 1e-6,
                _window("t_start")),
    "integration_time": ("the integration time, added to the nominal", "s", 1e-6,
                         _window("integration_time")),
    "registration_x": ("the array's registration along x, added to its origin", "m", 1e-6,
                       _registration(1)),
    "registration_y": ("the array's registration along y, added to its origin", "m", 1e-6,
                       _registration(0)),
}


def _domain(name: str, model) -> tuple[float, float, bool]:
    """(low, high, low is open) of the values input ``name`` accepts, for the nominal model."""
    if name in ("emissivity",):
        return 0.0, 1.0, False
    if name in ("assumed_emissivity", "halo_fraction"):
        return 0.0, 1.0, True
    if name in ("calibration_scale", "reflected_temperature", "assumed_reflected_temperature"):
        return 0.0, math.inf, True
    if name == "t_start":
        return -model.t_start, math.inf, False
    if name == "integration_time":
        return -model.integration_time, math.inf, True
    if name in ("registration_x", "registration_y"):
        return -model.camera.fpa.origin[1 if name == "registration_x" else 0], math.inf, False
    if name == "psf_sigma":  # a blur's width: 0 (none) or more
        return 0.0, math.inf, False
    return -math.inf, math.inf, False


_EDGE_UNITS = {"1": "(dimensionless)"}

#: An input's distribution may put at most this probability outside the values it accepts.
_OUTSIDE_DOMAIN = 1e-9


def _check_domains(model) -> None:
    """Every draw of every input must be a value the chain accepts: each distribution's
    support, less 1e-9 of probability at either end (a normal's ±6σ), is checked once before
    any draw, not found out by a failing task."""
    for name, dist in model.inputs.items():
        low, high, open_low = _domain(name, model)
        lo, hi = (float(v) for v in dist.ppf(np.array([_OUTSIDE_DOMAIN, 1 - _OUTSIDE_DOMAIN])))
        if lo < low or (open_low and lo <= low) or hi > high:
            scale, unit = INPUTS[name][2], _EDGE_UNITS.get(INPUTS[name][1], INPUTS[name][1])
            if scale != 1.0:
                unit = {1e-6: {"m": "µm", "s": "µs"}}.get(scale, {}).get(INPUTS[name][1], unit)
            lo, hi, low, high = (v / scale for v in (lo, hi, low, high))
            raise RadiosimError(
                f"input {name!r}: {type(dist).__name__} draws values in [{lo:.6g}, {hi:.6g}] "
                f"{unit}, outside its domain {'(' if open_low else '['}{low:.6g}, {high:.6g}] "
                f"{unit} ({INPUTS[name][0]}); narrow it or use a bounded distribution "
                "(Uniform, Triangular, TruncatedNormal)")


def _check_inputs(inputs: dict) -> dict:
    if not isinstance(inputs, dict):
        raise RadiosimError(f"inputs must map input names to distributions, got {inputs!r}")
    for name, dist in inputs.items():
        if name not in INPUTS:
            import difflib

            close = difflib.get_close_matches(str(name), INPUTS, 1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise RadiosimError(f"unknown uncertainty input {name!r}{hint}; inputs are "
                                f"{', '.join(INPUTS)}")
        if not isinstance(dist, Distribution):
            raise RadiosimError(f"input {name!r} must be a Distribution (Normal, Uniform, …), "
                                f"got {dist!r}")
    return dict(inputs)


# -- one draw (a task) -----------------------------------------------------------------------


@dataclass(frozen=True)
class _Model:
    """Everything a task needs: the nominal camera and scene (a recipe when pickled), the
    nominal window and the inputs."""

    camera: object
    scene: object
    integration_time: float
    t_start: float
    inputs: dict

    def evaluate(self, values: dict, noise_seed) -> np.ndarray:
        """The apparent temperature [K] (NaN where flagged) with the inputs at ``values``."""
        camera, scene = self.camera, self.scene
        settings = {"t_start": self.t_start, "integration_time": self.integration_time}
        for name, value in values.items():
            camera, scene, settings = INPUTS[name][3](camera, scene, settings, value)
        m = camera.measure(scene, settings["integration_time"], settings["t_start"],
                           np.random.default_rng(noise_seed))
        return m.apparent_temperature.astype(np.float64)


def _draw(model: _Model, seed: np.random.SeedSequence, vary, fixed_noise) -> np.ndarray:
    """One Monte Carlo draw: inputs in ``vary`` sampled from the draw's seed (the others at
    their means), noise from the seed unless ``fixed_noise`` is given."""
    input_seed, noise_seed = seed.spawn(2)
    rng = np.random.default_rng(input_seed)
    values = {}
    for name, dist in model.inputs.items():  # every input draws, so draws stay aligned
        value = dist.sample(rng)
        values[name] = value if name in vary else dist.mean
    return model.evaluate(values, noise_seed if fixed_noise is None else fixed_noise)


# -- the engine ------------------------------------------------------------------------------


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
    scheduler = scheduler if scheduler is not None or workers else os.environ.get(
        "RADIOSIM_SCHEDULER")
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
                env={"NUMBA_NUM_THREADS": threads, "OMP_WAIT_POLICY": "PASSIVE"})
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
        raise RadiosimError(f"scheduler must be 'synchronous', 'threads', a distributed Client "
                            f"or a tcp:// address, got {scheduler!r}")

    if client is not None:
        def run(function, argument_lists, shared=()):
            scattered = (client.scatter(list(shared), broadcast=True, hash=False) if shared
                         else [])
            futures = [client.submit(function, *scattered, *args, pure=False)
                       for args in argument_lists]
            return client.gather(futures)
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
            client.close()

    return run, close


# -- streaming statistics --------------------------------------------------------------------


class _Moments:
    """Per-pixel streaming mean and variance over valid draws (Welford), and the histogram of
    the quantile method."""

    def __init__(self, shape):
        self.n = np.zeros(shape)
        self.mean = np.zeros(shape)
        self.m2 = np.zeros(shape)
        self.draws = 0
        self.edges = None
        self.counts = None
        self.below = np.zeros(shape)
        self.above = np.zeros(shape)

    def add(self, values: np.ndarray):
        self.draws += 1
        valid = np.isfinite(values)
        self.n += valid
        delta = np.where(valid, values - self.mean, 0.0)
        self.mean += np.where(valid, delta / np.maximum(self.n, 1), 0.0)
        self.m2 += np.where(valid, delta * (values - self.mean), 0.0)
        if self.edges is not None:
            self._bin(values)

    def start_histogram(self, first: list[np.ndarray]):
        """Fix each pixel's histogram span from the first draws, and bin them."""
        std = np.sqrt(self.variance)
        half = _SPAN_SIGMAS * np.where(std > 0, std, 1e-9 * np.abs(self.mean) + 1e-12)
        self.edges = (self.mean - half, self.mean + half)
        self.counts = np.zeros((*self.mean.shape, HISTOGRAM_BINS), dtype=np.int32)
        for values in first:
            self._bin(values)

    def _bin(self, values):
        low, high = self.edges
        valid = np.isfinite(values)
        position = (values - low) / (high - low) * HISTOGRAM_BINS
        inside = valid & (position >= 0) & (position < HISTOGRAM_BINS)
        self.below += valid & (position < 0)
        self.above += valid & (position >= HISTOGRAM_BINS)
        flat = np.flatnonzero(inside)
        index = flat * HISTOGRAM_BINS + position.ravel()[flat].astype(np.int64)
        np.add.at(self.counts.reshape(-1), index, 1)

    @property
    def variance(self):
        return np.where(self.n > 1, self.m2 / np.maximum(self.n - 1, 1), np.nan)

    def quantile(self, q: float) -> np.ndarray:
        """Per-pixel quantile by linear interpolation of the histogram's CDF (NaN where too
        many draws fell outside its span)."""
        low, high = self.edges
        counts = self.counts
        outside = self.below + self.above
        total = counts.sum(axis=-1) + outside
        cdf = np.cumsum(counts, axis=-1)
        target = q * total - self.below  # the rank among all draws, within the span
        k = np.sum(cdf < target[..., None], axis=-1).clip(0, HISTOGRAM_BINS - 1)
        before = np.take_along_axis(cdf, np.maximum(k - 1, 0)[..., None], -1)[..., 0]
        before = np.where(k > 0, before, 0)
        inbin = np.take_along_axis(counts, k[..., None], -1)[..., 0]
        fraction = np.where(inbin > 0, (target - before) / np.maximum(inbin, 1), 0.5)
        value = low + (k + fraction) / HISTOGRAM_BINS * (high - low)
        bad = (total == 0) | (outside > _MAX_OUTSIDE * np.maximum(total, 1)) | (
            target < 0) | (target > counts.sum(axis=-1))
        return np.where(bad, np.nan, value)


# -- the result ------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class UncertaintyResult:
    """
    A Monte Carlo uncertainty evaluation (GUM Supplement 1), per pixel, and its budget.

    Attributes
    ----------
    mean : numpy.ndarray
        Mean apparent temperature [K] (over valid draws).
    std : numpy.ndarray
        Its standard uncertainty [K].
    truth : numpy.ndarray
        The scene truth each pixel measures: the tensor mean of the nominal window [K].
    valid_fraction : numpy.ndarray
        Fraction of draws in which the pixel had a reading [1].
    draws : int
        Monte Carlo draws.
    budget : list of dict
        Per input (and the noise), for the peak and the array mean: its standard uncertainty,
        the GUM sensitivity coefficient and contribution, and the one-input-at-a-time Monte
        Carlo contribution [K] (see :meth:`budget_table`).
    gum_std : numpy.ndarray
        Per pixel, the GUM combined standard uncertainty [K] (law of propagation).
    """

    mean: np.ndarray
    std: np.ndarray
    truth: np.ndarray
    valid_fraction: np.ndarray
    draws: int
    budget: list
    gum_std: np.ndarray
    _moments: object = None
    #: The texts of the warnings the evaluations raised (each also raised once).
    warnings: tuple = ()

    @property
    def error(self) -> np.ndarray:
        """Mean reading minus scene truth [K] (negative: the camera reads low)."""
        return self.mean - self.truth

    def interval(self, coverage: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
        """The probabilistically symmetric coverage interval (low, high) [K] per pixel."""
        if not 0 < coverage < 1:
            raise RadiosimError(f"coverage must be in (0, 1), got {coverage!r}")
        tail = (1 - coverage) / 2
        return self._moments.quantile(tail), self._moments.quantile(1 - tail)

    def gum_interval(self, coverage: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
        """The GUM interval mean ± k·u_c with k the normal coverage factor [K]."""
        from scipy.stats import norm

        k = norm.ppf(0.5 + coverage / 2)
        return self.mean - k * self.gum_std, self.mean + k * self.gum_std

    def budget_table(self) -> list[dict]:
        """The budget as rows (Lane et al.'s layout), with each input's share of the
        variance [%]."""
        return self.budget


# -- propagation -----------------------------------------------------------------------------


_SUMMARIES = {"peak": lambda a: float(np.nanmax(a)) if np.isfinite(a).any() else math.nan,
              "mean": lambda a: float(np.nanmean(a)) if np.isfinite(a).any() else math.nan}


def _significant_tolerance(u: np.ndarray, digits: int) -> np.ndarray:
    """GUM S1 §7.9.2: δ = ½·10^l for u written with ``digits`` significant digits."""
    with np.errstate(divide="ignore", invalid="ignore"):
        exponent = np.floor(np.log10(np.abs(u))) - digits + 1
    return np.where(np.isfinite(exponent), 0.5 * 10.0**exponent, np.inf)


def propagate(camera, scene, integration_time: float, inputs: dict, draws: int | None = None,
              rng=None, scheduler=None, t_start: float | None = None, workers: int | None = None,
              batch: int = 50, digits: int = 2, max_draws: int = 10_000,
              budget_draws: int | None = None, progress=None) -> UncertaintyResult:
    """
    Propagate the ``inputs``' distributions through the camera's whole chain (GUM Supplement 1).

    Parameters
    ----------
    camera, scene
        The nominal camera and scene.
    integration_time
        Nominal integration time [s].
    inputs
        Input name (:data:`INPUTS`) → :class:`Distribution`, e.g.
        ``{"emissivity": Uniform(0.2, 0.4)}``. The temporal noise is always an input, through
        each draw's own noise seed.
    draws
        Monte Carlo draws; ``None``: the adaptive procedure (GUM S1 §7.9), batches of
        ``batch`` draws until twice the standard deviation of the batches' means, standard
        uncertainties and interval ends is within the tolerance of ``digits`` significant
        digits of u at every pixel with readings (at most ``max_draws``).
    rng
        Seed (an int or :class:`numpy.random.SeedSequence`) of the whole evaluation.
    scheduler, workers
        The Dask engine (:func:`connect`).
    t_start
        Nominal window start [s] (``None``: as the camera chooses).
    budget_draws
        Draws of each one-input-at-a-time evaluation (default: ``max(20, draws // 4)``, at
        least 20).
    progress
        Called as ``progress(done, total)`` after each batch (total is ``None`` while
        adaptive), or as ``progress(done, total, seconds_left)`` if it takes three arguments:
        the estimated time to ``total`` [s] from the batches so far (``None`` while adaptive
        or before the first batch).

    Returns
    -------
    UncertaintyResult
    """
    inputs = _check_inputs(inputs)
    t_int = check_positive(integration_time, "integration_time", "s")
    for name, value, least in (("draws", draws, 2), ("batch", batch, 1),
                               ("max_draws", max_draws, 2), ("digits", digits, 1),
                               ("budget_draws", budget_draws, 2)):
        if value is None and name in ("draws", "budget_draws"):
            continue
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
            raise RadiosimError(f"{name} must be a whole number ≥ {least}, got {value!r}")
        if name in ("draws", "max_draws", "budget_draws") and value > MAX_DRAWS:
            raise RadiosimError(f"{name} = {value} is above radiosim's bound of {MAX_DRAWS} "
                                "Monte Carlo draws (each draw is a whole measurement; GUM S1 "
                                "asks 10⁶ only for a 95 % interval to two digits): give at "
                                f"most {MAX_DRAWS}, or draws unset for the adaptive procedure")
    if isinstance(rng, np.random.SeedSequence):  # a copy: the caller's sequence is not spent
        seed = np.random.SeedSequence(entropy=rng.entropy, spawn_key=rng.spawn_key)
    elif rng is None or (isinstance(rng, (int, np.integer)) and not isinstance(rng, bool)
                         and rng >= 0):
        seed = np.random.SeedSequence(None if rng is None else int(rng))
    else:
        raise RadiosimError(f"rng must be a seed ≥ 0 or a numpy SeedSequence (each draw spawns "
                            f"its own generator from it), got {rng!r}")
    main_seed, budget_seed, noise_seed = seed.spawn(3)
    start = camera.window(scene, t_int, t_start).start
    model = _Model(camera, scene, t_int, start, inputs)
    _check_domains(model)
    nominal = camera.measure(scene, t_int, start, np.random.default_rng(noise_seed))
    engine, close = connect(scheduler, workers)
    caught: dict[str, int] = {}

    def run(function, argument_lists, shared=()):
        """The engine's run, each task's warnings recorded (the draws are many: each distinct
        warning is raised once, below, with how many evaluations raised it)."""
        outcomes = engine(_Recording(function), argument_lists, shared=shared)
        for _, texts in outcomes:
            for text in texts:
                caught[text] = caught.get(text, 0) + 1
        return [value for value, _ in outcomes]

    progress = _Timed(progress) if progress is not None else None
    try:
        moments, done = _monte_carlo(run, model, main_seed, draws, batch, digits, max_draws,
                                     nominal.shape, progress)
        n_budget = budget_draws or max(20, done // 4)
        budget, gum_var = _budget(run, model, budget_seed, noise_seed, n_budget, nominal.shape)
    finally:
        close()
    for text, count in caught.items():  # never silenced: once each, with its count
        warnings.warn(f"{text} (in {count} Monte Carlo evaluations)", RadiosimWarning,
                      stacklevel=2)
    return UncertaintyResult(
        mean=np.where(moments.n > 0, moments.mean, np.nan), std=np.sqrt(moments.variance),
        truth=nominal.tensor_mean, valid_fraction=moments.n / max(done, 1), draws=done,
        budget=budget, gum_std=np.sqrt(gum_var), _moments=moments,
        warnings=tuple(caught))


#: The most Monte Carlo draws radiosim runs in one evaluation (draws, max_draws, budget_draws).
MAX_DRAWS = 1_000_000


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


def _monte_carlo(run, model, seed, draws, batch, digits, max_draws, shape, progress):
    """The main Monte Carlo: batches of draws, accumulated in index order."""
    moments = _Moments(shape)
    total = draws if draws is not None else max_draws
    children = seed.spawn(total)
    vary = tuple(model.inputs)
    done, batch_stats, first = 0, [], []
    while done < total:
        size = min(batch, total - done)
        results = run(_draw, [(children[done + i], vary, None) for i in range(size)],
                      shared=(model,))
        for values in results:
            moments.add(values)
            if moments.edges is None:
                first.append(values)
        done += size
        if moments.edges is None and (done >= _SPAN_DRAWS or done >= total):
            moments.start_histogram(first)  # the span from at least 20 draws
            first = []
        if progress is not None:
            progress(done, draws)
        if draws is None:
            stack = np.stack(results)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                batch_stats.append(np.stack([np.nanmean(stack, 0), np.nanstd(stack, 0, ddof=1),
                                             np.nanquantile(stack, 0.025, 0),
                                             np.nanquantile(stack, 0.975, 0)]))
            if len(batch_stats) >= 2:
                spread = np.nanstd(np.stack(batch_stats), axis=0, ddof=1) / math.sqrt(
                    len(batch_stats))
                tolerance = _significant_tolerance(np.sqrt(moments.variance), digits)
                readings = moments.n > 1
                if np.all((2 * spread <= tolerance)[:, readings]):
                    break
    else:
        if draws is None:
            warnings.warn(f"the adaptive Monte Carlo stopped at max_draws = {max_draws} before "
                          "its tolerance was met", RadiosimWarning, stacklevel=3)
    return moments, done


def _budget(run, model, seed, noise_seed, draws, shape):
    """Per input: the GUM sensitivity (central differences of ± one standard uncertainty, the
    noise fixed) and the one-input-at-a-time Monte Carlo variance (the noise fixed); the
    noise's own variance with every input at its mean."""
    fixed_noise = noise_seed.spawn(1)[0]
    means = {name: dist.mean for name, dist in model.inputs.items()}
    steps = []
    for name, dist in model.inputs.items():
        for sign in (1, -1):
            steps.append({**means, name: dist.mean + sign * dist.std})
    differences = run(_evaluate, [(values, fixed_noise) for values in steps], shared=(model,))
    rows, gum_var = [], np.zeros(shape)
    contributions = {}
    children = seed.spawn(len(model.inputs) + 1)
    for i, (name, dist) in enumerate(model.inputs.items()):
        plus, minus = differences[2 * i], differences[2 * i + 1]
        sensitivity = (plus - minus) / (2 * dist.std)  # [K per input unit]
        gum_var = gum_var + (sensitivity * dist.std) ** 2  # NaN where a step had no reading
        oat = run(_draw, [(child, (name,), fixed_noise) for child in children[i].spawn(draws)],
                  shared=(model,))
        contributions[name] = (dist, sensitivity, plus, minus, oat)
    noise = run(_draw, [(child, (), None) for child in children[-1].spawn(draws)],
                shared=(model,))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        noise_var = np.nanvar(np.stack(noise), axis=0, ddof=1)
    gum_var = gum_var + noise_var
    for summary, reduce in _SUMMARIES.items():
        summary_rows = []
        for name, (dist, _, plus, minus, oat) in contributions.items():
            c = (reduce(plus) - reduce(minus)) / (2 * dist.std)
            summary_rows.append({
                "quantity": summary, "input": name, "distribution": type(dist).__name__,
                "unit": INPUTS[name][1], "estimate": dist.mean, "std_uncertainty": dist.std,
                "sensitivity": c, "gum_contribution_K": abs(c) * dist.std,
                "mc_contribution_K": float(np.std([reduce(a) for a in oat], ddof=1))})
        noise_u = float(np.std([reduce(a) for a in noise], ddof=1))
        summary_rows.append({"quantity": summary, "input": "temporal noise",
                             "distribution": "Poisson + Normal", "unit": "", "estimate": math.nan,
                             "std_uncertainty": math.nan, "sensitivity": math.nan,
                             "gum_contribution_K": noise_u, "mc_contribution_K": noise_u})
        total = sum(r["gum_contribution_K"] ** 2 for r in summary_rows)
        for r in summary_rows:
            r["share_percent"] = 100 * r["gum_contribution_K"] ** 2 / total if total else math.nan
        rows += summary_rows
    return rows, gum_var


def _evaluate(model: _Model, values: dict, noise_seed) -> np.ndarray:
    return model.evaluate(values, noise_seed)

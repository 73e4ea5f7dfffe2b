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

Every draw is a Dask task (the engine is :mod:`radiosim.scheduling`). Its seed is spawned
from one :class:`numpy.random.SeedSequence` (the draw's index picks its child), so a budget
gives identical bits on any scheduler and any number of workers; draws are accumulated in index
order. Tasks carry the scene as a recipe (scenes pickle as their parameters, or as the path of
a memory-mapped stack), never its frames; draws share running sums over the frames
(:mod:`radiosim.budget_reuse`), so a draw is a blur and a read-out, not a pass over the frames.

Memory is bounded in the number of draws (:mod:`radiosim.moments`): moments are streamed
(Welford's update), and the coverage interval's quantiles come from a per-pixel histogram of
:data:`HISTOGRAM_BINS` bins spanning ±8 standard deviations of the first 20 draws around their
mean, interpolated linearly within a bin (a quantile is resolved to 16/400 = 0.04 standard deviations; draws outside the
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

import dataclasses
import math
import warnings
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from radiosim import budget_reuse
from radiosim.checks import check_count, check_positive
from radiosim.config import si_value
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.moments import HISTOGRAM_BINS, PixelMoments, over_draws
from radiosim.psf import GaussianBlur, ScatterHalo
# connect, SCHEDULER_TIMEOUT and recorded_warnings are also importable from here, as before.
from radiosim.scheduling import (SCHEDULER_TIMEOUT, connect, recorded_warnings, recording_run,
                                 seed_sequence, with_eta)

__all__ = ["Distribution", "Normal", "Uniform", "Triangular", "TruncatedNormal", "Samples",
           "INPUTS", "UncertainInput", "Domain", "distribution_from_table", "propagate", "UncertaintyResult",
           "connect", "HISTOGRAM_BINS", "MAX_DRAWS", "SCHEDULER_TIMEOUT",
           "recorded_warnings"]

_SPAN_DRAWS = 20  # draws that set each pixel's histogram span (radiosim.moments)


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
    scale = INPUTS[name].scale if name in INPUTS else 1.0  # the edge unit (µm, µs) → SI
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


class Domain(NamedTuple):
    """The values an uncertain input accepts: from ``low`` to ``high`` [the input's unit],
    ``low`` excluded if ``open_low``."""

    low: float
    high: float
    open_low: bool = False


@dataclass(frozen=True)
class UncertainInput:
    """
    One uncertain input of :func:`propagate`: what it perturbs, in which unit, which values it
    accepts and how a value is applied to the chain.

    Attributes
    ----------
    name : str
        The input's name (a key of :data:`INPUTS`, and of ``[uncertainty.inputs]``).
    description : str
        What the value is.
    unit : str
        Its SI unit (``"1"``: dimensionless).
    domain : callable
        ``domain(model) →`` :class:`Domain`: the values the chain accepts [unit], for the
        nominal camera, scene and window (a shift may not move them below zero).
    apply : callable
        ``apply(camera, scene, settings, value) → (camera, scene, settings)``, ``settings`` the
        window's ``t_start`` and ``integration_time`` [s].
    scale : float
        The TOML edge unit in SI (1e-6: the table states µm or µs) [unit].
    """

    name: str
    description: str
    unit: str
    domain: Callable
    apply: Callable
    scale: float = 1.0

    @property
    def edge_unit(self) -> str:
        """The unit the study file and the error messages state values in."""
        unit = _EDGE_UNITS.get(self.unit, self.unit)
        if self.scale != 1.0:
            unit = {1e-6: {"m": "µm", "s": "µs"}}.get(self.scale, {}).get(self.unit, unit)
        return unit


_EDGE_UNITS = {"1": "(dimensionless)"}


def _within(low: float, high: float, open_low: bool = False) -> Callable:
    """A domain that does not depend on the nominal model."""
    return lambda model: Domain(low, high, open_low)


#: The uncertain inputs by name (:class:`UncertainInput`).
INPUTS = {i.name: i for i in (
    UncertainInput("emissivity", "the scene's grey emissivity (metal regions of the chip)", "1",
                   _within(0.0, 1.0), _emissivity),
    UncertainInput("assumed_emissivity", "the camera's emissivity setting", "1",
                   _within(0.0, 1.0, True), _camera_field("assumed_emissivity")),
    UncertainInput("reflected_temperature", "the temperature the scene reflects", "K",
                   _within(0.0, math.inf, True), _reflected),
    UncertainInput("assumed_reflected_temperature", "the camera's reflected-temperature "
                   "setting", "K", _within(0.0, math.inf, True),
                   _camera_field("assumed_reflected_temperature")),
    UncertainInput("psf_sigma", "a Gaussian blur added to the optics' PSF", "m",
                   _within(0.0, math.inf), _psf_sigma, 1e-6),  # 0 (no blur) or more
    UncertainInput("halo_fraction", "the scatter halo's fraction (a 50 µm halo if the optics "
                   "have none)", "1", _within(0.0, 1.0, True), _halo_fraction),
    UncertainInput("calibration_scale", "the calibration's radiometric scale", "1",
                   _within(0.0, math.inf, True), _camera_field("calibration_scale")),
    UncertainInput("t_start", "the integration window's start, added to the nominal", "s",
                   lambda model: Domain(-model.t_start, math.inf), _window("t_start"), 1e-6),
    UncertainInput("integration_time", "the integration time, added to the nominal", "s",
                   lambda model: Domain(-model.integration_time, math.inf, True),
                   _window("integration_time"), 1e-6),
    UncertainInput("registration_x", "the array's registration along x, added to its origin",
                   "m", lambda model: Domain(-model.camera.fpa.origin[1], math.inf),
                   _registration(1), 1e-6),
    UncertainInput("registration_y", "the array's registration along y, added to its origin",
                   "m", lambda model: Domain(-model.camera.fpa.origin[0], math.inf),
                   _registration(0), 1e-6),
)}

#: An input's distribution may put at most this probability outside the values it accepts.
_OUTSIDE_DOMAIN = 1e-9


def _check_domains(model) -> None:
    """Every draw of every input must be a value the chain accepts: each distribution's
    support, less 1e-9 of probability at either end (a normal's ±6σ), is checked once before
    any draw, not found out by a failing task."""
    for name, dist in model.inputs.items():
        record = INPUTS[name]
        domain = record.domain(model)
        low, high, open_low = domain.low, domain.high, domain.open_low
        lo, hi = (float(v) for v in dist.ppf(np.array([_OUTSIDE_DOMAIN, 1 - _OUTSIDE_DOMAIN])))
        if lo < low or (open_low and lo <= low) or hi > high:
            unit = record.edge_unit
            lo, hi, low, high = (v / record.scale for v in (lo, hi, low, high))
            raise RadiosimError(
                f"input {name!r}: {type(dist).__name__} draws values in [{lo:.6g}, {hi:.6g}] "
                f"{unit}, outside its domain {'(' if open_low else '['}{low:.6g}, {high:.6g}] "
                f"{unit} ({record.description}); narrow it or use a bounded distribution "
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
    plan: budget_reuse.ReusePlan | None = None  # the draws' running sums, where they serve
    shape: tuple | None = None  # the nominal image's: every draw must see the same pixels

    def evaluate(self, values: dict, noise_seed) -> np.ndarray:
        """The apparent temperature [K] (NaN where flagged) with the inputs at ``values``:
        from the running sums of :mod:`radiosim.budget_reuse` where they serve, else
        measured."""
        camera, scene = self.camera, self.scene
        camera.response_model  # built before the inputs apply: the draws' cameras share it
        settings = {"t_start": self.t_start, "integration_time": self.integration_time}
        for name, value in values.items():
            camera, scene, settings = INPUTS[name].apply(camera, scene, settings, value)
        rng = np.random.default_rng(noise_seed)
        reading = None if self.plan is None else budget_reuse.draw(
            self.plan, camera, scene, settings["integration_time"], settings["t_start"], rng)
        if reading is None:
            reading = camera.measure(scene, settings["integration_time"], settings["t_start"],
                                     rng).apparent_temperature.astype(np.float64)
        if self.shape is not None and reading.shape != tuple(self.shape):
            drawn = ", ".join(f"{k} = {v:.6g}" for k, v in values.items())
            raise RadiosimError(f"a draw ({drawn}) sees {reading.shape[0]} × {reading.shape[1]} "
                                f"pixels of the scene, the nominal camera {self.shape[0]} × "
                                f"{self.shape[1]}: the inputs move the array past the scene's "
                                "edge; leave the scene a margin around the array wider than "
                                "their spread")
        return reading

    def span(self) -> tuple[float, float]:
        """The earliest start and latest end of any draw's window [s] (the inputs'
        distributions less 1e-9 of probability at either end, as :func:`_check_domains`)."""
        def reach(name):
            dist = self.inputs.get(name)
            if dist is None:
                return 0.0, 0.0
            return tuple(float(v) for v in dist.ppf(np.array([_OUTSIDE_DOMAIN,
                                                              1 - _OUTSIDE_DOMAIN])))
        (early, late), (_, longer) = reach("t_start"), reach("integration_time")
        return self.t_start + early, self.t_start + late + self.integration_time + longer


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
              budget_draws: int | None = None, progress=None,
              reuse: bool = True) -> UncertaintyResult:
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
        The Dask engine (:func:`radiosim.scheduling.connect`).
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
    reuse
        Draws keep the running sums over frames of the scene's radiance between them
        (:mod:`radiosim.budget_reuse`); ``False``: each draw makes its own, one pass over the
        frames — the same bits, slower. Budgets the sums cannot serve are measured draw by
        draw either way.

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
        check_count(value, name, least, integers_only=True)
        if name in ("draws", "max_draws", "budget_draws") and value > MAX_DRAWS:
            raise RadiosimError(f"{name} = {value} is above radiosim's bound of {MAX_DRAWS} "
                                "Monte Carlo draws (each draw is a whole measurement; GUM S1 "
                                "asks 10⁶ only for a 95 % interval to two digits): give at "
                                f"most {MAX_DRAWS}, or draws unset for the adaptive procedure")
    main_seed, budget_seed, noise_seed = seed_sequence(rng).spawn(3)
    start = camera.window(scene, t_int, t_start).start
    model = _Model(camera, scene, t_int, start, inputs)
    _check_domains(model)
    nominal = camera.measure(scene, t_int, start, np.random.default_rng(noise_seed))
    model = dataclasses.replace(model, plan=budget_reuse.ReusePlan.for_budget(
        camera, scene, *model.span(), reuse=reuse), shape=nominal.shape)
    engine, close = connect(scheduler, workers)
    # The draws are many: each distinct warning is raised once, below, with its count.
    caught: dict[str, int] = {}
    run = recording_run(engine, caught)
    progress = with_eta(progress)
    try:
        moments, done = _monte_carlo(run, model, main_seed, draws, batch, digits, max_draws,
                                     nominal.shape, progress)
        n_budget = budget_draws or max(20, done // 4)
        budget, gum_var = _budget(run, model, budget_seed, noise_seed, n_budget, nominal.shape)
    finally:
        close()
        if model.plan is not None:
            budget_reuse.release(model.plan)
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


def _monte_carlo(run, model, seed, draws, batch, digits, max_draws, shape, progress):
    """The main Monte Carlo: batches of draws, accumulated in index order."""
    moments = PixelMoments(shape)
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
            stack = np.stack(results)  # NaN: a draw without a reading at the pixel
            batch_stats.append(np.stack([
                over_draws(np.nanmean, stack), over_draws(np.nanstd, stack, 2, ddof=1),
                over_draws(np.nanquantile, stack, q=0.025),
                over_draws(np.nanquantile, stack, q=0.975)]))
            if len(batch_stats) >= 2:
                spread = over_draws(np.nanstd, np.stack(batch_stats), 2, ddof=1) / math.sqrt(
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


class _Contribution(NamedTuple):
    """One input's evaluations for the budget (per pixel, the noise fixed)."""

    distribution: Distribution
    sensitivity: np.ndarray  # [K per input unit], central differences
    plus: np.ndarray  # apparent temperature [K] at mean + one standard uncertainty
    minus: np.ndarray  # … at mean − one standard uncertainty
    one_at_a_time: list  # the one-input-at-a-time Monte Carlo draws [K]


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
        contributions[name] = _Contribution(dist, sensitivity, plus, minus, oat)
    noise = run(_draw, [(child, (), None) for child in children[-1].spawn(draws)],
                shared=(model,))
    noise_var = over_draws(np.nanvar, np.stack(noise), 2, ddof=1)  # NaN: fewer than 2 readings
    gum_var = gum_var + noise_var
    for summary, reduce in _SUMMARIES.items():
        summary_rows = []
        for name, share in contributions.items():
            dist = share.distribution
            c = (reduce(share.plus) - reduce(share.minus)) / (2 * dist.std)
            summary_rows.append({
                "quantity": summary, "input": name, "distribution": type(dist).__name__,
                "unit": INPUTS[name].unit, "estimate": dist.mean, "std_uncertainty": dist.std,
                "sensitivity": c, "gum_contribution_K": abs(c) * dist.std,
                "mc_contribution_K": float(np.std([reduce(a) for a in share.one_at_a_time],
                                                  ddof=1))})
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

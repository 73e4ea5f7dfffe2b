"""
Studies: a scene, cameras and sweeps as data (TOML), run into a tidy table and EXR files.

A study file names

-   a ``[scene]``: ``type = "segmented-chip"`` (optional ``params`` TOML, ``dt_us``, ``dx_um``,
    ``emissivity`` as a number, a curve name or a table per region), ``type = "frames"``
    (``path``, ``dt_us``, ``dx_um``, ``units``, optional ``event_time_us``) or
    ``type = "fea"`` (``path``, ``dx_um``,
    ``units`` table, ``fill_K``); any type may state its environment
    (:meth:`~radiosim.scenes.Scene.set_environment`): ``reflected_temperature_K`` (a number,
    or ``"tool"`` on the segmented chip for its reflected field, with ``reflection_view_um``),
    ``path_transmission``, ``path_temperature_K``, ``surroundings_temperature_K``;
-   ``[cameras.NAME]`` tables: ``preset = "nist-ir"`` or ``"linear-ideal"``, or ``file =
    "camera.toml"``, with optional overrides ``response``, ``pixel_pitch_um`` (same
    magnification: the detector pixels scale), ``assumed_emissivity`` and
    ``assumed_reflected_temperature_K``;
-   ``[[sweeps]]``: ``name``, ``cameras`` (names), and lists whose product is measured:
    ``response`` (override), ``pixel_pitch_um`` or ``pixel_samples`` (p × p scene samples, the
    paper's "p × p movie pixels"), ``integration_time_us`` or ``integration_time_frames``,
    ``alignment`` (``"centred"`` on the event — the paper's bracketing —, ``"starting"`` at the
    event frame's start, ``"ending"`` at its end). ``kind = "pixel"`` measures only the pixel
    that the study's ``pixel`` hook picks and records its instantaneous history;
-   an optional ``[hooks]`` table of case-specific functions, as ``"module:function"``:
    ``summary(measurement, scene) → dict`` adds columns to each row, ``pixel(scene,
    pixel_pitch) → scene`` picks the pixel of ``kind = "pixel"`` sweeps, and
    ``figures(folder, scene) → [paths]`` draws the study's figures.

A study is generic: it runs sweeps and writes tidy rows (:data:`RESULT_COLUMNS`, then the hook's
columns). Shipped studies live in ``radiosim/studies`` (:func:`available_studies`); ``msec2009``
is the paper's Table 2 with the linear and Planck responses, whose hooks are in
:mod:`radiosim.paper`. The file's tables are read and checked in :mod:`radiosim.study_spec`;
studies run on Dask through :mod:`radiosim.scheduling`.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import itertools
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from radiosim.acquisition import check_measurable, measure_many_statistics
from radiosim.camera import Camera
from radiosim.config import build_from_toml, reject_unknown
from radiosim.errors import RadiosimError, RadiosimIOError, RadiosimWarning
from radiosim.files import OutputFolder, atomic_write, check_name, is_staging, safe_name
from radiosim.interrupts import raise_if_interrupted
from radiosim.measurement import Measurement
from radiosim.scenes.base import CroppedScene, Scene
from radiosim.scheduling import (SECONDS_PER_SAMPLE, STUDY_TASK_FACTOR, connect, local_workers,
                                 recorded_call, spawn_seeds)
from radiosim.study_spec import (ALIGNMENTS, CAMERA_KEYS, ENVIRONMENT_KEYS, HOOKS,
                                 SCENE_KEYS, STUDY_KEYS, SWEEP_KEYS, UNCERTAINTY_KEYS, Sweep,
                                 UncertaintySpec, camera_from_table, exr_name, load_hook,
                                 scene_from_table)
from radiosim.uncertainty import propagate
from radiosim.units import round_significant, shift, to_celsius

__all__ = ["Study", "Sweep", "Planned", "StudyResult", "available_studies", "summarise",
           "STUDY_DIRECTORY",
           "RESULT_COLUMNS", "HOOKS", "load_hook", "format_value", "format_table",
           # read in radiosim.study_spec, importable from here as before
           "UncertaintySpec", "ALIGNMENTS", "STUDY_KEYS", "UNCERTAINTY_KEYS", "SWEEP_KEYS",
           "SCENE_KEYS", "CAMERA_KEYS", "ENVIRONMENT_KEYS"]

#: Folder of the shipped studies.
STUDY_DIRECTORY = Path(__file__).resolve().parent / "studies"

#: Columns of the results table, with units in the names. ``peak_bias_K`` is reading − scene
#: peak (negative when the camera reads low); a summary hook's columns follow ``exr``.
RESULT_COLUMNS = [
    "study", "sweep", "camera", "response", "integration_time_us", "n_frames", "pixel_pitch_um",
    "pixel_samples", "sensor_area_um2", "alignment", "t_start_us", "peak_scene_C", "peak_C",
    "peak_bias_K", "peak_uncertainty_K", "saturated_fraction", "under_range_fraction",
    "over_range_fraction", "warnings", "exr",
]

class Planned(NamedTuple):
    """One measurement of a study's plan (:meth:`Study.plan`)."""

    sweep: Sweep
    camera_name: str  # the camera's name in the study ([cameras.NAME])
    camera: Camera  # with the sweep's response and pixel pitch
    integration_time: float  # [s]
    alignment: str  # on the scene's event: centred, starting or ending (ALIGNMENTS)


class _Case(NamedTuple):
    """A planned measurement and the scene it measures (a pixel sweep's: a crop)."""

    sweep: Sweep
    camera_name: str
    camera: Camera
    integration_time: float  # [s]
    alignment: str
    scene: Scene


class _History(NamedTuple):
    """The longest window of a pixel sweep's camera, whose pixel history is written."""

    integration_time: float  # [s]
    t_start: float  # [s]
    pixel: Scene  # the scene cropped to the pixel


class _KeptPixel(CroppedScene):
    """
    A pixel hook's crop (a :class:`~radiosim.scenes.base.CroppedScene`, the same window of the
    same scene) that keeps the frames measured over its whole extent, up to :attr:`LIMIT`
    bytes, so that the pixel history reads them back instead of making them again (a 9 × 9
    pixel's 3625 frames hold 2.3 MB). Used in this process only (a Dask task gets the crop).
    """

    #: Most bytes of frames kept.
    LIMIT = 64 << 20

    def __init__(self, crop: CroppedScene):
        (r0, c0), (rows, cols) = crop.offset, crop.shape
        super().__init__(crop.parent, (r0, r0 + rows), (c0, c0 + cols))
        self.emissivity = crop.emissivity
        self.set_environment(**crop.environment)
        self._whole = (slice(0, rows), slice(0, cols))
        self._kept: dict[int, np.ndarray] = {}
        self._bytes = 0

    def _sample(self, k: int, region):
        frame = super()._sample(k, region)
        t = frame.temperature
        if (region == self._whole and frame.regions is None and isinstance(t, np.ndarray)
                and k not in self._kept and self._bytes + t.nbytes <= self.LIMIT):
            self._kept[k] = t.copy()  # the scene's _read of frame k (no region map)
            self._bytes += t.nbytes
        return frame

    def _read(self, k: int, region):
        kept = self._kept.get(k) if region == self._whole else None
        return super()._read(k, region) if kept is None else kept.copy()


def format_value(value):
    """A table cell: floats to 10 significant digits (no float noise such as
    899.4000000000002), others unchanged.

    Examples
    --------
    >>> format_value(1172.55 - 273.15), format_value(8.995502248875562), format_value(1.0)
    ('899.4', '8.995502249', '1.0')
    """
    if isinstance(value, (float, np.floating)):
        return repr(round_significant(value))
    return value


def available_studies() -> tuple[str, ...]:
    """Names of the shipped studies."""
    return tuple(sorted(p.stem for p in STUDY_DIRECTORY.glob("*.toml")))


@dataclass
class StudyResult:
    """What a study run produced: the table rows and where the files are."""

    rows: list[dict]
    table: Path | None = None
    exr_directory: Path | None = None
    history: Path | None = None
    columns: list[str] = field(default_factory=lambda: list(RESULT_COLUMNS))
    study: str | None = None  # the study's name, as its rows give it

    def to_xarray(self, name: str | None = None, history: str | None = None,
                  institution: str | None = None):
        """The rows as one CF-1.8 :class:`xarray.Dataset`: one record per measurement along
        ``measurement``, the sweep parameters as coordinates along it
        (:func:`radiosim.io.results_to_xarray`); ``name``: the study's (default: the one
        that ran, else ``"study"``); ``history``: the command that made them."""
        from radiosim.io.netcdf import results_to_xarray

        name = name if name is not None else self.study or "study"
        return results_to_xarray(self.rows, name, columns=self.columns, history=history,
                                 institution=institution)


def summarise(m: Measurement) -> dict:
    """
    The generic per-measurement numbers: the scene's peak and the highest valid reading.

    ``peak_scene_C`` is the largest tensor maximum [°C]; ``peak_C`` the highest valid reading
    [°C], ``peak_bias_K`` that reading minus the scene's peak [K] (negative when the camera
    reads low), ``peak_uncertainty_K`` the tensor standard deviation at that pixel [K]; then the
    saturated and under-range fractions.
    """
    apparent = m.apparent_temperature
    scene_peak = float(m.tensor_max.max())
    out = {"peak_scene_C": to_celsius(scene_peak)}
    if np.isfinite(apparent).any():
        i, j = np.unravel_index(np.nanargmax(apparent), apparent.shape)
        out.update(peak_C=to_celsius(float(apparent[i, j])),
                   peak_bias_K=float(apparent[i, j]) - scene_peak,
                   peak_uncertainty_K=float(m.tensor_std[i, j]))
    else:
        out.update(peak_C=math.nan, peak_bias_K=math.nan, peak_uncertainty_K=math.nan)
    out["saturated_fraction"] = m.saturated_fraction
    out["under_range_fraction"] = float(np.mean(m.under_range))
    out["over_range_fraction"] = float(np.mean(m.over_range))
    return out


class Study:
    """
    A study: scene, cameras and sweeps (see the module docstring for the TOML format).

    Examples
    --------
    >>> study = Study.preset("msec2009")
    >>> [s.name for s in study.sweeps]
    ['integration-time', 'size-of-source', 'long-integration']
    """

    def __init__(self, name: str, scene: dict, cameras: dict[str, Camera], sweeps: list[Sweep],
                 description: str = "", base: Path | None = None, hooks: dict | None = None):
        self.name, self.description = name, description
        self.scene_spec, self.cameras, self.sweeps = dict(scene), cameras, sweeps
        self.base = base or Path.cwd()
        self.hooks = dict(hooks or {})
        #: The study file (:meth:`from_toml`), named in errors found after loading it.
        self.path: Path | None = None
        #: The study's uncertainty budget (:class:`UncertaintySpec`), if it has one.
        self.uncertainty: UncertaintySpec | None = None
        #: The camera files the study reads (never written over by its run).
        self.camera_files: list[Path] = []
        reject_unknown([k for k in self.hooks if k not in HOOKS], HOOKS, "[hooks]")
        self._scene = None

    def hook(self, name: str) -> Callable | None:
        """The study's ``name`` hook (see :data:`HOOKS`), or ``None``."""
        spec = self.hooks.get(name)
        return None if spec is None else load_hook(spec, f"{name} hook")

    # -- construction -------------------------------------------------------------------------

    @classmethod
    def preset(cls, name: str) -> Study:
        """A shipped study (see :func:`available_studies`)."""
        path = STUDY_DIRECTORY / f"{name}.toml"
        if not path.is_file():
            raise RadiosimError(f"unknown study {name!r}; available: "
                                f"{', '.join(available_studies())}")
        return cls.from_toml(path)

    @classmethod
    def from_toml(cls, path) -> Study:
        """A study from a TOML file (relative paths in it are relative to the file)."""
        study = build_from_toml(path, "study",
                                lambda data, base: cls.from_dict(data, base=base))
        study.path = Path(path)
        return study

    @classmethod
    def from_dict(cls, data: dict, base: Path | None = None) -> Study:
        data = dict(data)
        base = base or Path.cwd()
        reject_unknown([k for k in data if k not in STUDY_KEYS], STUDY_KEYS, "study")
        name = check_name(data.pop("name", "study"), "study name")
        description = str(data.pop("description", ""))
        scene = data.pop("scene", None)
        if not isinstance(scene, dict) or "type" not in scene:
            raise RadiosimError("a study needs a [scene] table with a type")
        camera_tables = data.pop("cameras", None)
        if not isinstance(camera_tables, dict) or not camera_tables:
            raise RadiosimError("a study needs at least one [cameras.NAME] table")
        cameras = {check_name(n, "[cameras.NAME] name"): camera_from_table(t, n, base)
                   for n, t in camera_tables.items()}
        sweep_tables = data.pop("sweeps", [])
        if not isinstance(sweep_tables, list) or not all(isinstance(t, dict)
                                                         for t in sweep_tables):
            raise RadiosimError("sweeps must be an array of tables: write each as [[sweeps]] "
                                "(two brackets), not [sweeps]")
        sweeps = [Sweep.from_dict(s, cameras) for s in sweep_tables]
        names = [safe_name(s.name, "sweep name") for s in sweeps]
        for i, sweep_name in enumerate(names):  # the names label rows and EXR files
            if sweep_name in names[:i]:
                first = sweeps[names.index(sweep_name)].name
                raise RadiosimError(f"two sweeps are named {first!r}" + (
                    f" and {sweeps[i].name!r} (the same in file names)"
                    if first != sweeps[i].name else "") + "; give each sweep its own name")
        uncertainty = data.pop("uncertainty", None)
        uncertainty = None if uncertainty is None else UncertaintySpec.from_dict(uncertainty,
                                                                                 cameras)
        if not sweeps and uncertainty is None:
            raise RadiosimError("a study needs at least one [[sweeps]] table or an "
                                "[uncertainty] table")
        hooks = data.pop("hooks", {})
        if not isinstance(hooks, dict):
            raise RadiosimError(f"[hooks] must be a table, got {hooks!r}")
        study = cls(name, scene, cameras, sweeps, description, base, hooks)
        study.uncertainty = uncertainty
        study.camera_files = [base / t["file"] for t in camera_tables.values()
                              if isinstance(t, dict) and isinstance(t.get("file"), str)]
        for name in study.hooks:
            study.hook(name)  # fail now, not after the first measurements
        return study

    # -- the scene ----------------------------------------------------------------------------

    @property
    def scene(self) -> Scene:
        """The study's scene (built on first use)."""
        if self._scene is None:
            try:
                self._scene = scene_from_table(self.scene_spec, self.base)
            except RadiosimError as exc:
                raise self._named(exc, "[scene]") from None
        return self._scene

    def _named(self, exc: RadiosimError, where: str) -> RadiosimError:
        """``exc`` with the study file and ``where`` in it (a table, a sweep) in front."""
        text = str(exc)
        prefix = "" if self.path is None or str(self.path) in text else f"{self.path}: "
        where = "" if text.startswith(where) else f"{where}: "
        return type(exc)(f"{prefix}{where}{text}")

    # -- the measurements ---------------------------------------------------------------------

    def plan(self):
        """Every measurement to make, as :class:`Planned` records (sweep, camera name, camera,
        integration time [s], alignment)."""
        scene = self.scene
        for sweep in self.sweeps:
            pitches = ([p * scene.dx for p in sweep.pixel_samples] if sweep.pixel_samples
                       else list(sweep.pixel_pitches))
            times = (list(sweep.integration_times) if sweep.integration_times
                     else [n * scene.dt for n in sweep.integration_frames])
            for name, response, pitch, t_int, alignment in itertools.product(
                    sweep.cameras, sweep.responses, pitches, times, sweep.alignments):
                camera = self.cameras[name]
                if response is not None and response != camera.response:
                    camera = camera.replace(response=response)
                if pitch is not None:
                    camera = camera.with_pixel_pitch(pitch)
                yield Planned(sweep, name, camera, t_int, alignment)

    def _seconds_per_measurement(self, plan) -> float:
        """Estimated seconds [s] of one of ``plan``'s measurements in this process, warm:
        the mean over the plan of the samples it reads per frame (the whole scene for a field
        sweep, one pixel's footprint for a pixel sweep) × the frames of its window × the
        measured cost of one (:data:`radiosim.scheduling.SECONDS_PER_SAMPLE`)."""
        if not plan:
            return 0.0
        scene = self.scene
        whole = scene.shape[0] * scene.shape[1]
        footprint = [math.ceil(p.camera.fpa.pixel_pitch / scene.dx - 1e-9) ** 2 for p in plan]
        work = [(f if p.sweep.kind == "pixel" else whole) * (p.integration_time / scene.dt + 1.0)
                for f, p in zip(footprint, plan)]
        return SECONDS_PER_SAMPLE * float(np.mean(work))

    def _tasks(self, plan) -> int:
        """The tasks ``plan`` makes on a cluster (at least 1): per scene its cases measure —
        the study's scene for its field sweeps, one crop per pixel pitch of its pixel sweeps
        (:meth:`_measure_all`) — one per part (:func:`~radiosim.acquisition.part_frames`) of
        the frames its cases' windows span together."""
        from radiosim.acquisition import part_frames

        groups: dict = {}
        for p in plan:
            key = p.camera.fpa.pixel_pitch if p.sweep.kind == "pixel" else None
            window = p.camera.window(self.scene, p.integration_time,
                                     self._window_start(p.integration_time, p.alignment))
            first, weights = self.scene.window_frames(window)
            low, high = groups.get(key, (first, first + weights.size))
            groups[key] = (min(low, first), max(high, first + weights.size))
        # a pixel sweep's crop: a pixel's samples
        sizes = {key: part_frames(math.prod(self.scene.shape) if key is None else
                                  max(1, round(key / self.scene.dx)) ** 2) for key in groups}
        return max(1, sum(-(-(high - low) // sizes[key]) for key, (low, high) in groups.items()))

    def _window_start(self, t_int: float, alignment: str) -> float | None:
        scene = self.scene
        if alignment == "centred" or scene.event_time is None:
            return None  # the camera centres the window on the event, or starts at t = 0
        if alignment == "starting":
            return scene.event_time - 0.5 * scene.dt
        return scene.event_time + 0.5 * scene.dt - t_int

    def columns(self) -> list[str]:
        """Columns of the results table: :data:`RESULT_COLUMNS` and the summary hook's."""
        return result_columns(self, self.hook("summary"))

    def propagate(self, draws: int | None = None, seed: int | None = None, scheduler=None,
                  workers: int | None = None, progress=None):
        """
        The study's uncertainty budget (its ``[uncertainty]`` table) through
        :func:`radiosim.uncertainty.propagate`; ``draws`` and ``seed`` override the table's.
        """
        spec = self.uncertainty
        if spec is None:
            raise RadiosimError(f"study {self.name} has no [uncertainty] table")
        return propagate(self.cameras[spec.camera], self.scene, spec.integration_time,
                         spec.inputs, draws=draws if draws is not None else spec.draws,
                         rng=spec.seed if seed is None else seed, scheduler=scheduler,
                         t_start=spec.t_start, workers=workers, batch=spec.batch,
                         progress=progress)

    def inputs(self) -> list[Path]:
        """The files the study reads (its scene's files, parameter and camera files): a run
        never writes over one of them."""
        found = []
        spec = self.scene_spec
        for key in ("path", "params"):
            if isinstance(spec.get(key), str) and spec[key]:
                found.append(self.base / spec[key])
        scene = self._scene
        for attribute in ("paths", "path"):
            value = getattr(scene, attribute, None) if scene is not None else None
            if isinstance(value, (str, Path)):
                found.append(Path(value))
            elif isinstance(value, (list, tuple)):
                found.extend(Path(v) for v in value if isinstance(v, (str, Path)))
        found += list(self.camera_files)
        expanded = []
        for path in found:
            if path.is_dir():
                expanded.extend(p for p in path.rglob("*") if p.is_file())
            else:
                expanded.append(path)
        return expanded

    def run(self, out=None, rng=0, write_exr: bool = True,
            progress: Callable[[int, int, str], None] | None = None, scheduler=None,
            workers: int | None = None, overwrite: bool = False,
            cluster: str = "auto", figures: bool = True) -> StudyResult:
        """
        Run every measurement of the study.

        Parameters
        ----------
        out
            Folder for ``results.csv``, ``exr/`` and ``pixel_history.csv``; ``None``: keep
            results in memory only. The command's rules hold (:class:`radiosim.files.
            OutputFolder`): a new or empty folder, or with ``overwrite`` one that radiosim's
            earlier run wrote (only the files its manifest lists are replaced); a dangling link
            or a file is refused before any work, and so is a run that would replace one of
            its own inputs. Files are staged in ``OUT.partial`` (marked with this process's
            id while the run lasts) and moved in when the run completes; a run that fails
            keeps its completed rows there. An :class:`~radiosim.files.OutputFolder`'s
            staging folder is written into directly (its owner commits it).
        rng
            Seed (a whole number ≥ 0), :class:`numpy.random.SeedSequence` or Generator of the
            cameras' noise. Measurement ``i`` of the plan draws its noise from the ``i``-th
            seed spawned from it (:meth:`numpy.random.SeedSequence.spawn`), in this process as
            on any scheduler: the same seed gives the same bits everywhere.
        write_exr
            Write each field measurement as an EXR file.
        progress
            Called as ``progress(done, total, label)`` after each measurement.
        scheduler, workers
            Run on Dask (:func:`radiosim.uncertainty.connect`): the measurements of a scene
            (the study's scene, or a pixel sweep's crop) share a pass over each part of its
            frames (:func:`radiosim.acquisition.part_frames`), one task a part on a worker,
            merged in order as in this process (the same bits); the scene travels as its
            recipe, once to each worker.
        cluster
            With ``workers`` (and no ``scheduler``): ``"auto"`` starts the local cluster only
            where it pays (:func:`radiosim.scheduling.local_workers`: a study too small to gain
            runs in this process, the reason logged as one warning line); ``"always"`` starts
            it regardless.
        overwrite
            Allow ``out`` to hold radiosim's own earlier results (see above).
        figures
            Whether the study's figures will be drawn after the run: then, with an ``out``
            folder, its figures hook's ``prepare`` (if it has one) is called first (see below).

        Warnings raised while measuring a row are kept in its ``warnings`` column and reach
        the caller as :class:`~radiosim.errors.RadiosimWarning`\\ s (never silenced). With an
        ``out`` folder, the study's figures hook's ``prepare`` (if it has one) is called first:
        the figures drawn after the run then find their libraries loaded (the paper's loads
        matplotlib on a background thread, :func:`radiosim.paper.figures.prepare`, unless
        processes are ready to draw them: ``radiosim run`` starts them).
        """
        seeds = spawn_seeds(rng, scheduler is not None or workers is not None)
        plan = list(self.plan())
        if cluster not in ("auto", "always"):
            raise RadiosimError(f"cluster must be 'auto' or 'always', got {cluster!r}")
        if scheduler is None and workers is not None and cluster == "auto":
            tasks = self._tasks(plan)
            workers = local_workers(workers, tasks,
                                    self._seconds_per_measurement(plan) * len(plan) / tasks,
                                    task_factor=STUDY_TASK_FACTOR, unit="task")
        summary, pick_pixel = self.hook("summary"), self.hook("pixel")
        columns = self.columns()
        folder = None
        if out is not None and not is_staging(out):
            folder = OutputFolder(out, overwrite=overwrite, inputs=self.inputs(),
                                  option="the output folder")
            target, out = Path(out), folder.staging
        out = None if out is None else Path(out)
        exr_dir = None
        created = []
        if out is not None:
            try:
                for path in [*reversed(out.parents), out] + ([out / "exr"] if write_exr else []):
                    if not path.exists():
                        path.mkdir()
                        created.append(path)
            except OSError as exc:
                if folder is not None:
                    folder.abandon(keep=False)
                raise RadiosimIOError(f"cannot create {exc.filename or out}: "
                                      f"{exc.strerror or exc}") from None
            exr_dir = out / "exr" if write_exr else None
        result = StudyResult(rows=[], exr_directory=exr_dir, columns=columns, study=self.name)
        if out is not None and figures:
            self._prepare_figures()
        history = {}
        run = close = None  # the Dask engine's (run, close), if one is asked for
        completed = False
        try:
            if scheduler is not None or workers is not None:
                run, close = connect(scheduler, workers)
            self._measure_all(plan, result, history, summary, pick_pixel, exr_dir, seeds,
                              progress, run)
            if close is not None:
                close()  # the cluster or client it opened
                close = None
            if out is not None:
                result.table = out / "results.csv"
                _write_csv(result.table, columns, result.rows)
                if history:
                    result.history = out / "pixel_history.csv"
                    self._write_history(result.history, history)
            if folder is not None:
                folder.commit()
                result = _moved(result, out, target)
            completed = True
        finally:
            if close is not None:
                with contextlib.suppress(Exception):
                    close()
            if not completed and out is not None:
                if result.rows:  # what completed, as a table of its own
                    with contextlib.suppress(Exception):
                        _write_csv(out / "results.csv", columns, result.rows)
                if folder is not None:
                    folder.abandon(keep=True)
                else:
                    for path in reversed(created):  # never an empty skeleton
                        with contextlib.suppress(OSError):
                            path.rmdir()
        return result

    def _prepare_figures(self):
        """Call the figures hook's ``prepare``, if it has one."""
        try:
            figures = self.hook("figures")
        except RadiosimError:
            return  # a hook that does not load is reported where the figures are drawn
        prepare = getattr(figures, "prepare", None)
        if callable(prepare):
            prepare()

    def _measure_all(self, plan, result, history, summary, pick_pixel, exr_dir, seeds,
                     progress, run=None):
        """
        Measure every planned case into ``result.rows`` (and ``history``); case ``i`` draws
        its noise from ``seeds[i]``; ``run``: the Dask engine's, else in this process.
        Consecutive cases on the same scene are measured in one pass over its frames, here
        or as one task on the engine (the same function: the same bits); the warnings each case raises
        go to its row and are raised again here, in the plan's order.
        """
        from radiosim.files import BackgroundWrites
        from radiosim.io.exr import write_exr

        pixels = {}
        cases = []
        for sweep, name, camera, t_int, alignment in plan:  # Planned records
            scene = self.scene
            if sweep.kind == "pixel":
                if pick_pixel is None:
                    raise self._named(RadiosimError(
                        f"sweep {sweep.name!r} is of kind 'pixel': the study needs a pixel "
                        "hook ([hooks] pixel = 'module:function')"), "sweeps")
                pitch = camera.fpa.pixel_pitch
                if pitch not in pixels:  # one crop per pixel size: its cases share a pass
                    pixels[pitch] = pick_pixel(scene, pitch)
                    if run is None and type(pixels[pitch]) is CroppedScene:
                        pixels[pitch] = _KeptPixel(pixels[pitch])  # for the history
                scene = pixels[pitch]
            cases.append(_Case(sweep, name, camera, t_int, alignment, scene))
        files = {}
        for sweep, name, camera, t_int, alignment, scene in cases:  # before any work
            what = (f"sweep {sweep.name!r}, camera {name!r}, integration time "
                    f"{t_int * 1e6:.10g} µs, pixel pitch {camera.fpa.pixel_pitch * 1e6:.10g} µm")
            try:
                window = camera.window(scene, t_int, self._window_start(t_int, alignment))
                check_measurable(camera, window.duration)
                camera.integrator(scene)
            except RadiosimError as exc:
                raise self._named(exc, what) from None
            if exr_dir is not None and sweep.kind != "pixel":
                filename = exr_name(sweep, name, camera, t_int, alignment)
                if filename in files:
                    raise self._named(RadiosimError(
                        f"{files[filename]} and {what} would both be written to "
                        f"exr/{filename}; give values that differ in their first 6 "
                        "digits (times) or 4 (pitches)"),
                        "sweeps")
                files[filename] = what
        # The EXR files are written on a thread of their own while the next group measures;
        # a row whose file could not be written is not a completed row.
        write = BackgroundWrites(write_exr)
        try:
            with write:
                self._measure_groups(cases, seeds, run, result, summary, exr_dir, write,
                                     history, progress)
        finally:
            failed = {f"exr/{path.name}" for path in write.failed}
            result.rows[:] = [r for r in result.rows if r.get("exr") not in failed]

    def _measure_groups(self, cases, seeds, run, result, summary, exr_dir, write, history,
                        progress):
        """:meth:`_measure_all`'s measurements, group by group, and their rows."""
        # Consecutive cases on one scene (the same object) share a group: one pass over it.
        groups = [list(g) for _, g in itertools.groupby(cases, key=lambda c: id(c.scene))]
        done = 0
        for group in groups:
            raise_if_interrupted()  # one the work swallowed: raised again between groups
            scene = group[0].scene
            group_seeds = seeds[done:done + len(group)]
            triples = [(c.camera, c.integration_time,
                        self._window_start(c.integration_time, c.alignment)) for c in group]
            # The scene's frames in parts, one task a part on the engine (its cases sharing
            # each part's pass), merged and read out here: the same bits as in this process.
            outcomes = _measure_group(scene, triples, group_seeds, run)
            for case, (m, caught) in zip(group, outcomes):
                raise_if_interrupted()  # and between rows
                done += 1
                for text in caught:  # to the caller, as raised: never silenced
                    warnings.warn(text, RadiosimWarning, stacklevel=4)
                row = self._row(case, m, summary, exr_dir, write, history)
                row["warnings"] = " | ".join(dict.fromkeys(caught))
                result.rows.append(row)
                if progress is not None:
                    camera = case.camera
                    progress(done, len(cases), f"{case.sweep.name}: {case.camera_name} "
                             f"({camera.response}), {case.integration_time * 1e6:g} µs, "
                             f"{camera.fpa.pixel_pitch * 1e6:.3g} µm")

    def _row(self, case: _Case, m: Measurement, summary, exr_dir, write, history) -> dict:
        """One row of the results table (and the measurement's EXR file)."""
        sweep, name, camera, t_int, alignment, scene = case
        row = {
            "study": self.name, "sweep": sweep.name, "camera": name,
            "response": camera.response, "integration_time_us": shift(t_int, 6),
            "n_frames": m.n_frames, "pixel_pitch_um": shift(camera.fpa.pixel_pitch, 6),
            "pixel_samples": camera.fpa.pixel_pitch / scene.dx,
            "sensor_area_um2": camera.fpa.fill_factor * (camera.fpa.pixel_pitch * 1e6) ** 2,
            "alignment": alignment if scene.event_time is not None else m.alignment,
            "t_start_us": shift(m.t_start, 6),
        }
        row.update(summarise(m))
        if sweep.kind == "pixel":
            row.update(peak_C=to_celsius(float(m.tensor_mean[0, 0])),
                       peak_uncertainty_K=float(m.tensor_std[0, 0]))
            key = (name, camera.response)
            if key not in history or t_int > history[key].integration_time:
                history[key] = _History(t_int, m.t_start, scene)
        else:
            if summary is not None:
                row.update(summary(m, scene))
            if exr_dir is not None:
                filename = exr_name(sweep, name, camera, t_int, alignment)
                write(exr_dir / filename, m)
                row["exr"] = f"exr/{filename}"
        return {k: row.get(k, "") for k in result_columns(self, summary)}

    def _write_history(self, path: Path, history: dict):
        """Instantaneous footprint mean of the chosen pixel over the longest window."""
        rows = []
        for (name, response), (t_int, t_start, pixel) in history.items():
            first = int(math.floor(t_start / pixel.dt + 1e-9))
            last = int(math.ceil((t_start + t_int) / pixel.dt - 1e-9))
            for k in range(first, last):
                rows.append({"camera": name, "response": response,
                             "time_us": ((k + 0.5) * pixel.dt - t_start) * 1e6,
                             "mean_C": to_celsius(float(pixel.frame(k).mean()))})
        _write_csv(path, ["camera", "response", "time_us", "mean_C"], rows)


def format_table(rows: list[dict], extra=()) -> list[str]:
    """
    The console table of a run's rows: sweep, camera (its full name), response, alignment,
    integration time, pixel pitch, the peak reading and its bias, the ``extra`` columns (a
    summary hook's ``table_columns``: (heading, column, unit) triples, e.g. the paper's
    Column I), the saturated fraction, and a note number for each row with warnings, the notes
    listed below the table.
    """
    def cell(value, width=9):
        if value == "" or value is None or (isinstance(value, float) and math.isnan(value)):
            return f"{'—':>{width}}"
        return f"{value:>{width}.1f}"

    sweep_w = max([5, *(len(str(r["sweep"])) for r in rows)]) + 2
    camera_w = max([6, *(len(str(r["camera"])) for r in rows)]) + 2
    align_w = max([9, *(len(str(r["alignment"])) for r in rows)]) + 2
    lines = [f"{'sweep':<{sweep_w}}{'camera':<{camera_w}}{'response':<9}{'alignment':<{align_w}}"
             f"{'t_int':>8}{'pixel':>7}{'peak':>9}{'bias':>9}"
             + "".join(f"{heading:>9}" for heading, _, _ in extra) + f"{'sat.':>7}  flags",
             f"{'':<{sweep_w + camera_w + 9 + align_w}}{'[µs]':>8}{'[µm]':>7}{'[°C]':>9}"
             f"{'[K]':>9}" + "".join(f"{unit:>9}" for _, _, unit in extra) + f"{'[%]':>7}",
             "  (bias = reading − scene peak: negative when the camera reads low)"]
    notes: dict[str, int] = {}
    for r in rows:
        flags = [t for t in str(r.get("warnings", "") or "").split(" | ") if t]
        marks = " ".join(f"[{notes.setdefault(t, len(notes) + 1)}]" for t in flags)
        lines.append(
            f"{str(r['sweep']):<{sweep_w}}{str(r['camera']):<{camera_w}}"
            f"{str(r['response']):<9}{str(r['alignment']):<{align_w}}"
            f"{r['integration_time_us']:>8.3g}{r['pixel_pitch_um']:>7.3g}{cell(r['peak_C'])}"
            f"{cell(r['peak_bias_K'])}" + "".join(cell(r.get(key, "")) for _, key, _ in extra)
            + f"{100 * r['saturated_fraction']:>7.1f}"
            f"  {marks}".rstrip())
    lines += [f"  [{n}] {text}" for text, n in notes.items()]
    return lines


def result_columns(study: Study, summary) -> list[str]:
    """:data:`RESULT_COLUMNS` and the columns of a summary hook."""
    return list(RESULT_COLUMNS) + list(getattr(summary, "columns", []))


def _write_csv(path: Path, columns: list[str], rows: list[dict]):
    """A table written atomically (see :func:`radiosim.files.atomic_write`)."""
    with atomic_write(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns)
        writer.writeheader()
        writer.writerows({k: format_value(v) for k, v in row.items()} for row in rows)


def _measure_group(scene: Scene, cases, seeds, run=None) -> list:
    """(measurement, warning texts) of each ``(camera, integration time, start)`` case, case
    ``i``'s noise from ``seeds[i]``; the cases share one pass over the scene's frames in parts
    (:func:`~radiosim.acquisition.measure_many_statistics`), here or one task a part on the
    Dask engine's ``run``."""
    statistics, caught = recorded_call(measure_many_statistics, scene, cases, None, run)
    out = []
    for ((camera, _, _), (window, stats)), seed in zip(zip(cases, statistics), seeds):
        m, texts = recorded_call(camera.read_out, stats, window, scene,
                                 np.random.default_rng(seed))
        out.append((m, caught + texts))
    return out


def _moved(result: StudyResult, staging: Path, target: Path) -> StudyResult:
    """``result`` with its paths moved from the staging folder to the committed one."""
    def move(path):
        return None if path is None else target / Path(path).relative_to(staging)

    return dataclasses.replace(result, table=move(result.table),
                               exr_directory=move(result.exr_directory),
                               history=move(result.history))


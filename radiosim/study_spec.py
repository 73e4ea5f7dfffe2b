"""
A study file read and checked: its ``[scene]``, ``[cameras.NAME]``, ``[[sweeps]]``,
``[uncertainty]`` and ``[hooks]`` tables (the format is in :mod:`radiosim.study`), each
refused with one line naming the table, the key, the value and what was expected, before any
measurement.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from radiosim.camera import Camera
from radiosim.checks import check_count, check_positive
from radiosim.config import read_number, reject_unknown
from radiosim.errors import RadiosimError
from radiosim.files import check_name, safe_name
from radiosim.io.scenes import SCENE_TYPES, STUDY_SCENE_TYPES
from radiosim.response import RESPONSES
from radiosim.scenes.base import Scene
from radiosim.uncertainty import INPUTS, MAX_DRAWS, distribution_from_table
from radiosim.units import MICRO, shift

__all__ = ["Sweep", "UncertaintySpec", "HOOKS", "load_hook", "ALIGNMENTS", "STUDY_KEYS",
           "UNCERTAINTY_KEYS", "SWEEP_KEYS", "SCENE_KEYS", "CAMERA_KEYS", "ENVIRONMENT_KEYS",
           "camera_from_table", "scene_from_table", "exr_name"]

#: How a window is aligned on the scene's event (a sweep's ``alignment``).
ALIGNMENTS = ("centred", "starting", "ending")
#: The top-level keys of a study file.
STUDY_KEYS = ("name", "description", "scene", "cameras", "sweeps", "hooks", "uncertainty")
#: The keys of an [uncertainty] table (its inputs in [uncertainty.inputs]).
UNCERTAINTY_KEYS = ("camera", "integration_time_us", "t_start_us", "draws", "seed", "batch",
                    "inputs")
#: The keys of a [[sweeps]] table.
SWEEP_KEYS = ("name", "cameras", "response", "pixel_pitch_um", "pixel_samples",
              "integration_time_us", "integration_time_frames", "alignment", "kind")
#: The keys of each [scene] type (from the registry of scene types,
#: :data:`radiosim.io.scenes.SCENE_TYPES`), and of a [cameras.NAME] table.
SCENE_KEYS = STUDY_SCENE_TYPES
CAMERA_KEYS = ("preset", "file", "response", "assumed_emissivity", "pixel_pitch_um",
               "assumed_reflected_temperature_K")
#: The keys of a scene's environment (any type): see :meth:`Scene.set_environment`.
ENVIRONMENT_KEYS = ("reflected_temperature_K", "reflection_view_um", "path_transmission",
                    "path_temperature_K", "surroundings_temperature_K")
#: The hooks a study file may name, and what each is called with.
HOOKS = {"summary": "summary(measurement, scene) -> dict of extra columns",
         "pixel": "pixel(scene, pixel_pitch) -> the scene cropped to one pixel",
         "figures": "figures(folder, scene) -> list of PNG paths written"}


def load_hook(spec: str, what: str = "hook") -> Callable:
    """The function named ``"package.module:function"``."""
    module, _, name = str(spec).partition(":")
    if not module or not name:
        raise RadiosimError(f"{what} {spec!r} must be 'module:function'")
    try:
        return getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as exc:
        raise RadiosimError(f"{what} {spec!r} cannot be loaded: {exc}") from None


@dataclass(frozen=True)
class UncertaintySpec:
    """
    A study's uncertainty budget: ``[uncertainty]`` with ``camera`` (a study camera's name),
    ``integration_time_us``, optional ``t_start_us``, ``draws`` (absent: adaptive), ``seed``,
    ``batch``, and ``[uncertainty.inputs]`` tables of distributions in each input's edge unit
    (``{distribution = "uniform", low = 0.2, high = 0.4}``; µm for lengths, µs for times; see
    :data:`radiosim.uncertainty.INPUTS`).
    """

    camera: str
    integration_time: float
    t_start: float | None
    draws: int | None
    seed: int
    batch: int
    inputs: dict

    @classmethod
    def from_dict(cls, table: dict, cameras: dict) -> UncertaintySpec:
        if not isinstance(table, dict):
            raise RadiosimError(f"[uncertainty] must be a table, got {table!r}")
        table = dict(table)
        reject_unknown([k for k in table if k not in UNCERTAINTY_KEYS], UNCERTAINTY_KEYS,
                       "[uncertainty]")
        camera = table.get("camera")
        if camera not in cameras:
            raise RadiosimError(f"[uncertainty] camera must be one of the study's cameras "
                                f"({', '.join(cameras)}), got {camera!r}")
        t_int = read_number(table, "integration_time_us", "[uncertainty]", MICRO)
        if t_int is None:
            raise RadiosimError("[uncertainty] needs integration_time_us")
        t_start = read_number(table, "t_start_us", "[uncertainty]", MICRO)
        counts = {}
        for key, default, least in (("draws", None, 2), ("seed", 0, 0), ("batch", 50, 1)):
            value = table.get(key, default)
            if value is not None:
                check_count(value, f"[uncertainty] {key}", least, integers_only=True)
            if key == "draws" and value is not None and value > MAX_DRAWS:
                raise RadiosimError(f"[uncertainty] draws = {value} is above radiosim's bound "
                                    f"of {MAX_DRAWS} draws; give at most {MAX_DRAWS} (or no "
                                    "draws: the adaptive procedure)")
            counts[key] = value
        inputs = table.get("inputs", {})
        if not isinstance(inputs, dict) or not inputs:
            raise RadiosimError("[uncertainty.inputs] must name at least one input: "
                                f"{', '.join(INPUTS)}")
        reject_unknown([k for k in inputs if k not in INPUTS], INPUTS, "[uncertainty.inputs]")
        return cls(camera, check_positive(t_int, "integration_time", "s"), t_start,
                   counts["draws"], counts["seed"], counts["batch"],
                   {name: distribution_from_table(t, name) for name, t in inputs.items()})


@dataclass(frozen=True)
class Sweep:
    """One sweep of a study: the product of its lists is measured with each camera."""

    name: str
    cameras: tuple[str, ...]
    responses: tuple[str | None, ...] = (None,)
    pixel_pitches: tuple[float | None, ...] = (None,)  # [m]; None: the camera's own
    pixel_samples: tuple[int, ...] = ()
    integration_times: tuple[float, ...] = ()  # [s]
    integration_frames: tuple[int, ...] = ()
    alignments: tuple[str, ...] = ("centred",)
    kind: str = "field"

    @classmethod
    def from_dict(cls, data: dict, cameras) -> Sweep:
        data = dict(data)
        name = check_name(data.pop("name", "sweep"), "[[sweeps]] name")
        reject_unknown([k for k in data if k not in SWEEP_KEYS], SWEEP_KEYS, f"sweep {name!r}")
        for key in ("cameras", "response", "alignment"):
            if key in data and not isinstance(data[key], list):
                raise RadiosimError(f"sweep {name!r}: {key} must be a list, e.g. {key} = "
                                    f"[{data[key]!r}], got {data[key]!r}")
        for key in ("response", "alignment"):
            if key in data and not data[key]:
                raise RadiosimError(f"sweep {name!r}: {key} = [] measures nothing; list at "
                                    f"least one (or leave {key} out)")
        names = tuple(data.pop("cameras", ()))
        unknown = [c for c in names if c not in cameras]
        if not names or unknown:
            raise RadiosimError(f"sweep {name!r}: cameras must name [cameras.*] tables "
                                f"({', '.join(cameras)}); got {list(names)}")
        _no_repeats(name, "cameras", names)

        def numbers(key, exponent=0, whole=False):
            values = data.pop(key, None)
            if values is None:
                return ()
            if not isinstance(values, list) or not values or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0
                    and math.isfinite(v) for v in values):
                hint = (" (numbers written as strings? drop the quotes)"
                        if isinstance(values, list) and any(isinstance(v, str) for v in values)
                        else "")
                raise RadiosimError(f"sweep {name!r}: {key} must be a list of positive numbers, "
                                    f"got {values!r}{hint}")
            if whole and any(v != int(v) for v in values):  # never rounded behind the user
                raise RadiosimError(f"sweep {name!r}: {key} must be whole numbers, got "
                                    f"{next(v for v in values if v != int(v))!r} in {values!r}")
            _no_repeats(name, key, values)
            return tuple(shift(v, exponent) for v in values)

        times = numbers("integration_time_us", -6)
        frames = numbers("integration_time_frames", whole=True)
        if bool(times) == bool(frames):
            raise RadiosimError(f"sweep {name!r}: give integration_time_us or "
                                "integration_time_frames (one of them)")
        pitches, samples = numbers("pixel_pitch_um", -6), numbers("pixel_samples", whole=True)
        if pitches and samples:
            raise RadiosimError(f"sweep {name!r}: give pixel_pitch_um or pixel_samples, not both")
        responses = tuple(data.pop("response", [None]))
        for r in responses:
            if r is not None and r not in RESPONSES:
                raise RadiosimError(f"sweep {name!r}: response must be one of "
                                    f"{', '.join(map(repr, RESPONSES))}, got {r!r}")
        _no_repeats(name, "response", responses)
        alignments = tuple(data.pop("alignment", ["centred"]))
        for a in alignments:
            if a not in ALIGNMENTS:
                raise RadiosimError(f"sweep {name!r}: alignment must be one of "
                                    f"{', '.join(ALIGNMENTS)}, got {a!r}")
        _no_repeats(name, "alignment", alignments)
        kind = data.pop("kind", "field")
        if kind not in ("field", "pixel"):
            raise RadiosimError(f"sweep {name!r}: kind must be 'field' or 'pixel', got {kind!r}")
        return cls(name=name, cameras=names, responses=responses,
                   pixel_pitches=pitches or (None,), pixel_samples=tuple(int(s) for s in samples),
                   integration_times=times, integration_frames=tuple(int(f) for f in frames),
                   alignments=alignments, kind=kind)


def _no_repeats(sweep: str, key: str, values) -> None:
    """Refuse a value listed twice in a sweep: its rows would repeat and their files clash."""
    seen = set()
    for value in values:
        if value in seen:
            raise RadiosimError(f"sweep {sweep!r}: {key} lists {value!r} twice; list each "
                                "value once")
        seen.add(value)


def _number(table: dict, key: str, what: str):
    """A number of a study table (None if absent); strings and booleans are refused."""
    return read_number(table, key, what)


def camera_from_table(table: dict, name: str, base: Path) -> Camera:
    """The camera of a ``[cameras.NAME]`` table (``file`` relative to ``base``)."""
    if not isinstance(table, dict):
        raise RadiosimError(f"[cameras.{name}] must be a table, got {table!r}")
    table = dict(table)
    reject_unknown([k for k in table if k not in CAMERA_KEYS], CAMERA_KEYS,
                   f"[cameras.{name}]")
    if "preset" in table and "file" in table:
        raise RadiosimError(f"camera {name!r}: give preset or file, not both")
    if "file" in table:
        camera = Camera.from_toml(base / table.pop("file"))
    else:
        preset = table.pop("preset", None)
        if preset is None:
            raise RadiosimError(f"camera {name!r}: needs preset = … or file = …")
        if preset == "linear-ideal":
            pitch = _number(table, "pixel_pitch_um", f"[cameras.{name}]")
            if pitch is None:
                raise RadiosimError(f"camera {name!r}: linear-ideal needs pixel_pitch_um")
            camera = Camera.linear_ideal(shift(pitch, -6))
        else:
            camera = Camera.preset(preset)
    changes = {}
    if "response" in table:
        changes["response"] = table.pop("response")
    if "assumed_emissivity" in table:
        changes["assumed_emissivity"] = _number(table, "assumed_emissivity",
                                                f"[cameras.{name}]")
    if "assumed_reflected_temperature_K" in table:
        changes["assumed_reflected_temperature"] = _number(
            table, "assumed_reflected_temperature_K", f"[cameras.{name}]")
    if "pixel_pitch_um" in table:
        pitch = _number(table, "pixel_pitch_um", f"[cameras.{name}]")
        camera = camera.with_pixel_pitch(shift(pitch, -6))
    return camera.replace(name=name, **changes)


def scene_from_table(spec: dict, base: Path) -> Scene:
    """The scene of a ``[scene]`` table (its files relative to ``base``), with its
    environment; its ``type`` is looked up in the registry of scene types
    (:data:`radiosim.io.scenes.SCENE_TYPES`)."""
    spec = dict(spec)
    kind = spec.get("type")
    if kind not in SCENE_KEYS:
        *first, last = SCENE_KEYS
        raise RadiosimError(f"scene type {kind!r} is not {', '.join(first)} or {last}")
    allowed = (*SCENE_KEYS[kind], *ENVIRONMENT_KEYS)
    reject_unknown([k for k in spec if k not in allowed], allowed, f"[scene] ({kind})")
    spec.pop("type")
    environment = {k: spec.pop(k) for k in ENVIRONMENT_KEYS if k in spec}
    build = next(t.from_table for t in SCENE_TYPES.values() if t.table == kind)
    return _set_environment(build(spec, base), environment)


def _set_environment(scene: Scene, table: dict) -> Scene:
    """The [scene] table's environment keys applied: ``reflected_temperature_K`` is a number,
    or ``"tool"`` on the segmented chip (its reflected field, over ``reflection_view_um``)."""
    if not table:
        return scene
    reflected = table.get("reflected_temperature_K")
    if reflected == "tool":
        if not hasattr(scene, "reflected_field"):
            raise RadiosimError("[scene] reflected_temperature_K = \"tool\" needs the "
                                "segmented-chip scene (the tool's reflection)")
        view = _number(table, "reflection_view_um", "[scene]")
        reflected = scene.reflected_field(*(() if view is None else (shift(view, -6),)))
    elif reflected is not None:
        reflected = _number(table, "reflected_temperature_K", "[scene]")
    elif "reflection_view_um" in table:
        raise RadiosimError("[scene] reflection_view_um needs reflected_temperature_K = \"tool\"")
    options = {}
    for key, name in (("path_transmission", "path_transmission"),
                      ("path_temperature_K", "path_temperature"),
                      ("surroundings_temperature_K", "surroundings_temperature")):
        if key in table:
            options[name] = _number(table, key, "[scene]")
    return scene.set_environment(reflected_temperature=reflected, **options)


def exr_name(sweep: Sweep, name: str, camera: Camera, t_int: float, alignment: str) -> str:
    """The EXR file of one field measurement of a study."""
    return (f"{safe_name(sweep.name, 'sweep name')}_{safe_name(name, 'camera name')}_"
            f"{camera.response}_{t_int * 1e6:g}us_{camera.fpa.pixel_pitch * 1e6:.4g}um_"
            f"{alignment}.exr")

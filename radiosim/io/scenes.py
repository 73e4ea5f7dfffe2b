"""
The scene registry: every scene type by name, with what it reads, and :func:`read_scene`, which
reads a scene file by its suffix.

:data:`SCENE_TYPES` is to scenes what :data:`radiosim.psf.PSF_TYPES` is to point-spread
functions: one :class:`SceneType` record per type, naming the scene class it builds, the files
it reads (their suffixes and the reader of :mod:`radiosim.io`), what the caller must state
because the file does not, and, for the types a study may name, the keys of its ``[scene]``
table and the function that builds the scene from them. Studies
(:func:`radiosim.study_spec.scene_from_table`), the ``radiosim measure`` command (through
:func:`read_scene`) and this registry's own listing use it; a new scene type is one record
here (and its scene class and reader).

:func:`read_scene` raises :class:`SceneArgumentError` (a :class:`~radiosim.errors.RadiosimError`)
for what the caller gave or left out — keywords it names by their Python names, so that a
front end (the command) can state them in its own words (its options).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from radiosim.checks import check_positive
from radiosim.config import read_number
from radiosim.errors import RadiosimError
from radiosim.files import why_not_a_file
from radiosim.io.fea import read_fea_mesh, read_fea_nodes
from radiosim.io.frames import read_frames
from radiosim.scenes import (ChipParameters, ExrSequence, FeaMesh, FeaNodes, FrameStack,
                             MovingGaussianBand, SegmentedChip, StepEdge, UniformBlackbody)
from radiosim.scenes.base import Scene
from radiosim.units import AMBIENT_TEMPERATURE, shift

__all__ = ["SceneType", "SCENE_TYPES", "STUDY_SCENE_TYPES", "scene_type", "scene_type_of",
           "read_scene", "SceneArgumentError"]


@dataclass(frozen=True)
class SceneType:
    """
    One scene type of the registry (:data:`SCENE_TYPES`).

    Attributes
    ----------
    name : str
        The type's name (a key of :data:`SCENE_TYPES`).
    scene : type
        The :class:`~radiosim.scenes.Scene` class it builds.
    reads : str
        What it is made from, in words.
    reader : callable or None
        The :mod:`radiosim.io` function that reads its files; ``None``: built from
        parameters, no file.
    from_path : bool
        Whether :func:`read_scene` reads it from a path and its keywords alone (an FEA mesh
        series needs its times and field: its reader is called directly).
    needs : tuple of str
        The keywords of :func:`read_scene` that its files do not state (the caller must).
    options : tuple of str
        The keywords of :func:`read_scene` that only this type takes (beyond ``dt``, ``dx``,
        ``units``).
    table : str or None
        The ``type`` a study's ``[scene]`` table gives it (``None``: not in studies); two
        types may share one (``frames`` reads NumPy stacks and EXR sequences alike).
    table_keys : tuple of str
        The keys of that ``[scene]`` table besides ``type`` and the environment's.
    from_table : callable or None
        ``from_table(spec, base) → Scene``: the scene of a ``[scene]`` table (its ``type``
        and environment keys removed; files relative to ``base``); it removes the keys it
        reads.
    """

    name: str
    scene: type
    reads: str
    reader: Callable | None = None
    from_path: bool = False
    needs: tuple[str, ...] = ()
    options: tuple[str, ...] = ()
    table: str | None = None
    table_keys: tuple[str, ...] = ()
    from_table: Callable | None = None

    @property
    def suffixes(self) -> tuple[str, ...]:
        """The file suffixes it reads (lower case; its scene class's ``SUFFIXES``)."""
        return tuple(getattr(self.scene, "SUFFIXES", ()))


class SceneArgumentError(RadiosimError):
    """
    :func:`read_scene` refused what it was given for a file: ``reason`` is ``"mesh"`` (a mesh
    file, read by :func:`~radiosim.io.read_fea_mesh`), ``"not-taken"`` (``keywords`` that
    the file's type does not take), ``"missing"`` (``keywords`` the file does not state and the
    caller did not give) or ``"units"`` (an FEA file's units stated nowhere); ``path`` is the
    file.
    """

    def __init__(self, message: str, path: Path, reason: str, keywords: tuple[str, ...] = ()):
        super().__init__(message)
        self.path, self.reason, self.keywords = path, reason, tuple(keywords)


# -- [scene] tables of a study ----------------------------------------------------------------


def _length(spec: dict, key: str, default=None):
    """``spec[key]`` (removed) in µm or µs, as SI [m, s]; ``default`` (edge unit) if absent."""
    value = read_number(spec, key, "[scene]")
    if value is not None and not (value > 0 or (key == "event_time_us" and value == 0)):
        raise RadiosimError(f"[scene] {key} = {value!r}: expected a positive number "
                            f"({'µm' if key.endswith('_um') else 'µs'})")
    value = default if value is None else value
    return None if value is None else shift(value, -6)


def _path(spec: dict, kind: str) -> str:
    value = spec.pop("path", None)
    if not isinstance(value, str) or not value:
        raise RadiosimError(f"[scene] of type {kind!r} needs path = \"…\" (the file to read), "
                            f"got {value!r}")
    return value


def _chip_from_table(spec: dict, base: Path) -> Scene:
    emissivity = spec.pop("emissivity", 1.0)
    params = spec.pop("params", None)
    params = ChipParameters.from_toml(base / params) if params else None
    return SegmentedChip(params, dx=_length(spec, "dx_um", 960 / 1440),
                         dt=_length(spec, "dt_us", 0.2), emissivity=emissivity)


def _frames_from_table(spec: dict, base: Path) -> Scene:
    emissivity = spec.pop("emissivity", 1.0)
    spec_event = spec.get("event_time_us")
    numpy_stack = str(spec.get("path", "")).lower().endswith(FrameStack.SUFFIXES)
    missing = [k for k in ("dt_us", "dx_um", "units") if k not in spec]
    if numpy_stack and missing:
        raise RadiosimError(f"[scene] of type 'frames' with a NumPy stack needs "
                            f"{', '.join(missing)} (the file carries no grid nor unit)")
    event = _length(spec, "event_time_us")
    path = _path(spec, "frames")
    try:
        return read_frames(base / path, dt=_length(spec, "dt_us"), dx=_length(spec, "dx_um"),
                           units=spec.pop("units", None), emissivity=emissivity,
                           event_time=event)
    except RadiosimError as exc:  # the reader states seconds: add what the file says
        if event is None or "event_time" not in str(exc):
            raise
        raise RadiosimError(f"event_time_us = {spec_event!r}: {exc}") from None


def _fill(spec: dict) -> float:
    value = read_number(spec, "fill_K", "[scene]")
    if value is None:
        return AMBIENT_TEMPERATURE
    return check_positive(value, "[scene] fill_K", "K")


def _fea_from_table(spec: dict, base: Path) -> Scene:
    emissivity = spec.pop("emissivity", 1.0)
    return read_fea_nodes(base / _path(spec, "fea"), dx=_length(spec, "dx_um"),
                          dt=_length(spec, "dt_us"), units=spec.pop("units", None),
                          fill=_fill(spec), emissivity=emissivity)


_FRAMES_KEYS = ("path", "dt_us", "dx_um", "units", "emissivity", "event_time_us")

#: The scene types by name (:class:`SceneType`).
SCENE_TYPES = {t.name: t for t in (
    SceneType("segmented-chip", SegmentedChip, "no file: the built-in model of segmented chip "
              "formation (its parameters from an optional TOML file)", table="segmented-chip",
              table_keys=("params", "dx_um", "dt_us", "emissivity"),
              from_table=_chip_from_table),
    SceneType("frames", FrameStack, "a NumPy stack of temperature frames (.npy, or one array "
              "of an .npz): no grid nor unit, the caller states them", read_frames, True,
              needs=("dt", "dx", "units"), table="frames", table_keys=_FRAMES_KEYS,
              from_table=_frames_from_table),
    SceneType("exr-sequence", ExrSequence, "EXR frames, one file per frame (a folder or a "
              "glob): grid and unit from their headers, or stated", read_frames, True,
              table="frames", table_keys=_FRAMES_KEYS, from_table=_frames_from_table),
    SceneType("fea", FeaNodes, "an FEA nodal export (.csv of time, x, y, temperature), "
              "resampled on a grid of pitch dx; its units from its header or stated",
              read_fea_nodes, True, needs=("dx",), options=("time_unit", "length_unit", "fill"),
              table="fea", table_keys=("path", "dx_um", "dt_us", "units", "fill_K",
                                       "emissivity"),
              from_table=_fea_from_table),
    SceneType("fea-mesh", FeaMesh, "a time series of FEA meshes (meshio: ParaView .pvd, VTK, "
              "XDMF, Exodus, Gmsh), resampled by its own cells; times, field and units "
              "stated to its reader", read_fea_mesh),
    SceneType("uniform-blackbody", UniformBlackbody, "no file: one temperature everywhere"),
    SceneType("moving-gaussian-band", MovingGaussianBand, "no file: a Gaussian hot band "
              "moving at constant speed over a uniform background"),
    SceneType("step-edge", StepEdge, "no file: a straight edge between a hot and a cold "
              "half-plane"),
)}

#: The ``[scene]`` types of a study: ``type`` → the keys of its table (``type`` first).
STUDY_SCENE_TYPES = {}
for _t in SCENE_TYPES.values():
    if _t.table is not None:
        STUDY_SCENE_TYPES.setdefault(_t.table, ("type", *_t.table_keys))
del _t


def scene_type(name: str) -> SceneType:
    """The registry's record of scene type ``name``."""
    if name not in SCENE_TYPES:
        raise RadiosimError(f"unknown scene type {name!r}; expected one of "
                            f"{', '.join(SCENE_TYPES)}")
    return SCENE_TYPES[name]


def scene_type_of(path) -> SceneType:
    """
    The scene type of a file by its suffix: a stack, a nodal CSV, a mesh; anything else (a
    folder, a glob, ``.exr`` files) is read as EXR frames.

    Examples
    --------
    >>> scene_type_of("run.npz").name, scene_type_of("nodes.CSV").name
    ('frames', 'fea')
    >>> scene_type_of("frames/").name, scene_type_of("case.pvd").name
    ('exr-sequence', 'fea-mesh')
    """
    suffix = Path(path).suffix.lower()
    for entry in SCENE_TYPES.values():
        if entry.reader is not None and suffix in entry.suffixes:
            return entry
    return SCENE_TYPES["exr-sequence"]


def read_scene(path, *, dt=None, dx=None, units=None, time_unit=None, length_unit=None,
               fill=None, emissivity=1.0) -> Scene:
    """
    A scene from a file, by its suffix (:func:`scene_type_of`): a NumPy stack
    (:func:`~radiosim.io.read_frames`), a folder or glob of EXR frames (the same), or an FEA
    nodal CSV (:func:`~radiosim.io.read_fea_nodes`).

    Parameters
    ----------
    path
        The file, folder or glob pattern.
    dt, dx
        Frame interval [s] and sample pitch [m]: required where the file does not state them
        (a stack: both; a CSV: ``dx``, ``dt`` defaulting to the file's step).
    units
        Temperature unit of the file, ``"K"`` or ``"C"`` (required for a stack).
    time_unit, length_unit
        An FEA CSV's time and length units where its header does not state them (a unit given
        here that contradicts the header is refused by the reader).
    fill
        Temperature [K] outside an FEA mesh; default :data:`~radiosim.units.AMBIENT_TEMPERATURE`.
    emissivity
        The scene's emissivity (as for :class:`~radiosim.FrameStack`).

    Returns
    -------
    Scene

    Raises
    ------
    SceneArgumentError
        A mesh file (read it with :func:`~radiosim.io.read_fea_mesh`, giving its times),
        ``fill``, ``time_unit`` or ``length_unit`` for a file other than a CSV, a keyword in
        :attr:`SceneType.needs` not given, or a CSV's units stated nowhere.
    RadiosimError
        A path that does not exist, and whatever the reader refuses.
    """
    text = str(path)
    path = Path(path)
    why = None if any(c in text for c in "*?[") or path.is_dir() else why_not_a_file(path)
    if why is not None:
        raise RadiosimError(f"{path} {why} (expected a .npy/.npz stack, a folder or glob of "
                            ".exr frames, or an FEA nodal .csv)")
    entry = scene_type_of(path)
    if not entry.from_path:
        raise SceneArgumentError(
            f"{path}: FEA meshes are read with their times and units by "
            f"radiosim.io.{entry.reader.__name__} (docs/howto.md); read_scene takes .npy/.npz "
            "stacks, EXR frames or a nodal .csv", path, "mesh")
    given = {"time_unit": time_unit, "length_unit": length_unit, "fill": fill}
    if "fill" not in entry.options and fill is not None:
        raise SceneArgumentError(
            f"fill = {fill!r} K: {path} is not an FEA nodal .csv; a stack or EXR frames cover "
            "the whole field (expected fill only with a .csv, for the points outside the mesh)",
            path, "not-taken", ("fill",))
    units_given = tuple(k for k in ("time_unit", "length_unit")
                        if given[k] and k not in entry.options)
    if units_given:
        raise SceneArgumentError(
            f"{' and '.join(f'{k} = {given[k]!r}' for k in units_given)}: {path} is not an FEA "
            "nodal .csv; the units of its frames are dt, dx and units (expected time_unit and "
            "length_unit only with a .csv)", path, "not-taken", units_given)
    stated = {"dt": dt, "dx": dx, "units": units}
    missing = tuple(k for k in entry.needs if stated[k] is None)
    if missing:
        raise SceneArgumentError(
            f"{path}: give {', '.join(missing)} (the file does not state "
            f"{'them' if len(missing) > 1 else 'it'}; e.g. dt=0.2e-6, dx=0.5e-6 [s, m], "
            "units='C')", path, "missing", missing)
    if entry.reader is read_fea_nodes:
        # The caller's statements, each passed as given (the reader checks them against the
        # file's own header and refuses a contradiction); None: the file's header alone.
        table = {k: v for k, v in (("time", time_unit), ("length", length_unit),
                                   ("temperature", units)) if v} or None
        try:
            return read_fea_nodes(path, dx=dx, dt=dt, units=table,
                                  fill=AMBIENT_TEMPERATURE if fill is None else fill,
                                  emissivity=emissivity)
        except RadiosimError as exc:
            if "stated nowhere" not in str(exc):
                raise
            raise SceneArgumentError(
                f"{path}: give the units with time_unit, length_unit and units (or a header "
                "line '# units: time=…, length=…, temperature=…')", path, "units",
                ("time_unit", "length_unit", "units")) from None
    return entry.reader(path, dt=dt, dx=dx, units=units, emissivity=emissivity)

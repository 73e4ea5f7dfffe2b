"""
FEA nodal exports: scattered, moving nodes resampled onto a regular grid, step by step.

The file is a CSV with the columns ``time, x, y, temperature`` (any order, named in a header
row); each distinct time is one output step of the simulation, and nodes need not be on a grid
nor stay in place between steps (remeshing). Units are stated by the caller or in a header
comment ``# units: time=us, length=um, temperature=C``.

Each step is triangulated (Delaunay) and interpolated linearly inside the mesh. Triangles whose
longest edge exceeds ``max_edge`` are not part of the mesh (a Delaunay triangulation also fills
the concave gaps of a cutting simulation, such as the air between chip and tool); samples
outside the mesh get the stated ``fill`` temperature.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import re
from pathlib import Path

import numpy as np
from radiosim.checks import check_positive
from radiosim.errors import RadiosimError
from radiosim.scenes.fea_nodes import INTERPOLATIONS, FeaMesh, FeaNodes, triangulate
from radiosim.units import (AMBIENT_TEMPERATURE, TEMPERATURE_OFFSETS, UNITS, readable_time,
                            to_kelvin)

__all__ = ["read_fea_nodes", "FeaNodes", "read_fea_mesh", "FeaMesh"]

#: Length and time units accepted for FEA files, with their factor to SI.
LENGTH_UNITS = {unit: 10.0**exponent for unit, (exponent, _) in UNITS["length"].items()}
TIME_UNITS = {unit: 10.0**exponent for unit, (exponent, _) in UNITS["time"].items()}
_COLUMNS = ("time", "x", "y", "temperature")
#: A grid larger than this is a unit slip, not a cutting simulation (2 × 10⁸ samples).
MAX_GRID_SAMPLES = 200_000_000


class _decoding:
    """Turn a decoding error while reading ``path`` into one line naming it."""

    def __init__(self, path):
        self.path = path

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, trace):
        if isinstance(exc, UnicodeDecodeError):
            raise RadiosimError(f"{self.path} is not a UTF-8 text file (byte {exc.start}: "
                                f"{exc.object[exc.start:exc.start + 1]!r}); save the CSV as "
                                "UTF-8") from None
        return False


#: The quantity of each column, whose unit a suffix in its name may state.
_QUANTITY = {"time": "time", "x": "length", "y": "length", "temperature": "temperature"}
_SUFFIX = re.compile(r"^(?P<name>time|x|y|temperature)(?:\s*[_ ]\s*|\s*)"
                     r"(?:[\[(]\s*(?P<bracketed>[^\])]+?)\s*[\])]"
                     r"|(?P<plain>[A-Za-z\u00b5\u03bc]+))?$",
                     re.IGNORECASE)


def _micro(unit: str) -> str:
    """A unit with its micro prefix as ``u``: the micro sign (U+00B5) and the Greek mu
    (U+03BC, what many fonts and NFKC normalisation give) alike."""
    return unit.replace("\u00b5", "u").replace("\u03bc", "u")


def _grid(xy: np.ndarray, bounds, dx: float, where: str, hint: str):
    """The sample grid over ``bounds`` (x0, x1, y0, y1) [m], default the nodes' extent ``xy``:
    origin (x of column 0's left edge, y of row 0's top edge) [m] and shape (rows, columns).
    A grid of no sample, or of more than MAX_GRID_SAMPLES (a unit slip), raises."""
    if bounds is None:
        bounds = (xy[:, 0].min(), xy[:, 0].max(), xy[:, 1].min(), xy[:, 1].max())
    x0, x1, y0, y1 = (float(b) for b in bounds)
    shape = (int(math.floor((y1 - y0) / dx + 1e-9)), int(math.floor((x1 - x0) / dx + 1e-9)))
    if min(shape) < 1:
        raise RadiosimError(f"{where}: the grid {bounds} holds no {dx:g} m sample")
    if shape[0] * shape[1] > MAX_GRID_SAMPLES:
        raise RadiosimError(
            f"{where}: the nodes span {x1 - x0:.3g} × {y1 - y0:.3g} m, which at dx = {dx:g} m is "
            f"a grid of {shape[0]} × {shape[1]} samples; is the length unit right"
            + (f" ({hint})" if hint else "?"))
    return (x0, y1), shape


def _header(path, number, line, columns):
    """Indices of (time, x, y, temperature) in a header row, its width, and the units its
    names state (``time_us``, ``x [um]``, ``temperature_C``) as quantity → (unit, column
    name); ``columns`` maps a column to its name. Two columns read as one raise."""
    names = [c.strip() for c in line]
    lower = [n.lower() for n in names]
    columns = {k: v for k, v in (columns or {}).items()}
    unknown = set(columns) - set(_COLUMNS)
    if unknown:
        raise RadiosimError(f"columns maps {sorted(unknown)}; it maps {', '.join(_COLUMNS)} to "
                            "the file's column names")
    found, stated = {}, {}
    for column in _COLUMNS:
        if column in columns:
            wanted = str(columns[column]).strip().lower()
            if wanted not in lower:
                raise RadiosimError(f"{path}, line {number}: no column {columns[column]!r} "
                                    f"(for {column}); the header has {', '.join(names)}")
            index = lower.index(wanted)
            twice = [i for i, n in enumerate(lower) if n == wanted]
            if len(twice) > 1:
                raise RadiosimError(f"{path}, line {number}: columns {twice[0] + 1} and "
                                    f"{twice[1] + 1} are both named {names[twice[0]]!r} (for "
                                    f"{column}); a column name must be unique")
        else:
            matches = [(i, _SUFFIX.match(n)) for i, n in enumerate(names)]
            matches = [(i, m) for i, m in matches if m and m["name"].lower() == column]
            if not matches:
                continue
            if len(matches) > 1:
                (i, _), (j, _) = matches[:2]
                raise RadiosimError(f"{path}, line {number}: columns {i + 1} ({names[i]!r}) and "
                                    f"{j + 1} ({names[j]!r}) both read as {column}; keep one, "
                                    f"or say which with columns={{'{column}': …}}")
            index, match = matches[0]
            unit = match["bracketed"] or match["plain"]
            if unit:
                unit = _micro(unit)
                quantity = _QUANTITY[column]
                if quantity in stated and stated[quantity][0] != unit:
                    raise RadiosimError(f"{path}, line {number}: the columns state two "
                                        f"{quantity} units, {stated[quantity][0]} "
                                        f"({stated[quantity][1]!r}) and {unit} ({names[index]!r})")
                stated[quantity] = (unit, names[index])
        found[column] = index
    missing = [c for c in _COLUMNS if c not in found]
    if missing:
        raise RadiosimError(f"{path}, line {number}: header lacks column(s) "
                            f"{', '.join(missing)}; expected {', '.join(_COLUMNS)} (unit "
                            "suffixes such as time_us or temperature_C are read), or map "
                            "them with columns={…}")
    return [found[c] for c in _COLUMNS], len(names), stated


def _parse(path: Path, columns=None):
    """Rows of (time, x, y, temperature) and the units stated in the file (a ``# units:``
    comment, or suffixes of the column names), if any."""
    stated, where = {}, {}
    try:
        handle = path.open(newline="", encoding="utf-8-sig")  # a BOM (Excel's CSV UTF-8) too
    except OSError as exc:
        raise RadiosimError(f"cannot read FEA file {path}: {exc}") from exc
    rows = []
    with handle, _decoding(path):
        header = None
        for number, line in enumerate(csv.reader(handle), start=1):
            if not line or not "".join(line).strip():
                continue
            first = line[0].strip()
            if first.startswith("#"):
                text = ",".join(line).lstrip("#").strip()
                if text.lower().startswith("units:"):
                    for item in text[6:].split(","):
                        key, sep, value = item.partition("=")
                        if sep:
                            key, value = key.strip().lower(), _micro(value.strip())
                            if key in stated and stated[key] != value:
                                raise RadiosimError(
                                    f"{path}, line {number}: '# units:' states {key}={value}, "
                                    f"but {where[key]} states {key}={stated[key]}")
                            stated[key], where[key] = value, f"line {number}"
                continue
            if header is None:
                header, width, suffixes = _header(path, number, line, columns)
                for key, (unit, name) in suffixes.items():
                    if key in stated and stated[key] != unit:
                        raise RadiosimError(
                            f"{path}, line {number}: column {name!r} states {key} in {unit}, "
                            f"but {where[key]}'s '# units:' states {key}={stated[key]}")
                    stated[key], where[key] = unit, f"line {number}"
                continue
            if len(line) != width:
                raise RadiosimError(f"{path}, line {number}: expected {width} fields, got "
                                    f"{len(line)}")
            try:
                values = [float(line[i]) for i in header]
            except ValueError:
                raise RadiosimError(f"{path}, line {number}: a value is not a number: "
                                    f"{','.join(line)!r}") from None
            if not all(math.isfinite(v) for v in values):
                name, value = next((c, v) for c, v in zip(_COLUMNS, values)
                                   if not math.isfinite(v))
                text = line[header[_COLUMNS.index(name)]].strip()
                raise RadiosimError(f"{path}, line {number}: {name} is {text!r} (NaN or "
                                    "infinite); expected a finite number")
            rows.append(values)
    if header is None or not rows:
        raise RadiosimError(f"{path}: no data (expected a header {','.join(_COLUMNS)} and rows)")
    return np.array(rows), stated, where


def _unique_nodes(path, k, t, rows, xy, temperature, units):
    """A step's nodes with exact duplicates merged; two temperatures for one node raise,
    naming the node and both data rows."""
    unique, first, inverse = np.unique(xy, axis=0, return_index=True, return_inverse=True)
    if unique.shape[0] == xy.shape[0]:
        return xy, temperature
    inverse = inverse.reshape(-1)
    kept = temperature[first]
    clash = np.flatnonzero(temperature != kept[inverse])
    if clash.size:
        i = int(clash[0])
        j = int(first[inverse[i]])
        scale = LENGTH_UNITS[units["length"]]
        raise RadiosimError(
            f"{path}: step {k} (t = {readable_time(t)}) gives the node at x = {xy[i, 0] / scale:g}, "
            f"y = {xy[i, 1] / scale:g} {units['length']} two temperatures, "
            f"{temperature[j]:g} K (data row {rows[j] + 1}) and {temperature[i]:g} K (data row "
            f"{rows[i] + 1}); a node has one temperature per step")
    return unique, kept


def _check_interpolation(interpolation, where) -> None:
    if interpolation not in INTERPOLATIONS:
        raise RadiosimError(f"{where}: interpolation={interpolation!r} is not one of "
                            f"{', '.join(map(repr, INTERPOLATIONS))}")


def _merge_units(path, stated: dict, where: dict, given) -> dict:
    """The file's units with the caller's: a caller's unit that contradicts the file's raises,
    naming both (and where the file states it)."""
    units = dict(stated)
    for key, value in (given or {}).items():
        if value is None:
            continue
        value = _micro(str(value).strip())
        if key in stated and _canonical(key, stated[key]) != _canonical(key, value):
            flag = {"temperature": "--units", "time": "--time-unit",
                    "length": "--length-unit"}.get(key, "units=")
            raise RadiosimError(f"{path}: the given {key} unit {value} ({flag}; units= in "
                                f"Python) contradicts the file's {key}={stated[key]} "
                                f"({where.get(key, 'header')}); drop the option or correct the "
                                "file")
        units[key] = value
    return units


def _canonical(key: str, unit: str) -> str:
    """A unit as the tables name it (``degC`` and ``celsius`` are ``C``), else as given."""
    if key == "temperature":
        return {"k": "K", "kelvin": "K", "c": "C", "°c": "C", "degc": "C",
                "celsius": "C"}.get(unit.strip().lower(), unit)
    return unit


def _refuse_split_steps(path, time: np.ndarray) -> None:
    """Refuse a time stamp given to two separate blocks of rows (two node sets labelled with
    one time: a copied or mistyped step), in one pass. A file grouped by node (each row
    another time than the last) is fine: its runs of one time are single rows."""
    edges = np.flatnonzero(np.diff(time) != 0) + 1
    starts = np.concatenate([[0], edges])
    lengths = np.diff(np.concatenate([starts, [time.size]]))
    blocks = starts[lengths >= 3]  # runs that could be a node set of their own
    seen: dict[float, int] = {}
    for start in blocks:
        t = float(time[start])
        if t in seen:
            raise RadiosimError(
                f"{path}: time stamp {readable_time(t)} is given to two separate blocks of "
                f"rows (data rows {seen[t] + 1} and {start + 1} on): two node sets with one "
                "time; each step needs its own time stamp")
        seen[t] = int(start)


def read_fea_nodes(path, dx, dt=None, units=None, fill=AMBIENT_TEMPERATURE, bounds=None,
                   max_edge=None, emissivity=1.0, columns=None, interpolation="hold") -> FeaNodes:
    """
    Read an FEA nodal CSV (time, x, y, temperature) and resample it onto a regular grid.

    Parameters
    ----------
    path
        The CSV file.
    dx
        Sample pitch of the output grid [m].
    dt
        Frame interval [s]; ``None``: the step of the file's times, which must be uniform.
        With ``interpolation="hold"`` a given ``dt`` must match that step; with ``"linear"``
        it may be any interval (finer frames follow the field more closely).
    units
        Dict with ``time`` (s, ms, us, ns), ``length`` (m, mm, um) and ``temperature`` (K, C);
        keys not given come from the header comment ``# units: time=…, length=…,
        temperature=…`` or the columns' unit suffixes; a unit stated nowhere is an error, and
        so is a unit given here that contradicts the file's.
    fill
        Temperature outside the mesh [K] (default the ambient 293.15 K,
        :data:`~radiosim.units.AMBIENT_TEMPERATURE`).
    bounds
        (x_min, x_max, y_min, y_max) of the grid [m]; ``None``: the nodes' extent over all
        steps. Row 0 of the frames is the top (y_max).
    max_edge
        Longest triangle edge that is part of the mesh [m]; ``None``: 4 × the median edge of
        the first step's triangulation.
    emissivity
        As for :class:`~radiosim.FrameStack`.
    columns
        The file's names of the columns ``time``, ``x``, ``y``, ``temperature``, where they
        differ (``{"temperature": "NT11"}``); names with a unit suffix (``time_s``,
        ``x_um``, ``temperature [C]``) are found without it, and state their unit.
    interpolation
        Between the file's steps: ``"hold"`` (default; each step holds until the next) or
        ``"linear"`` (each frame is the field at its mid-time, linear in time between the
        two steps around it).

    Returns
    -------
    FeaNodes
        A scene on the file's own time axis: frame k covers [k·dt, (k+1)·dt) [s] of the
        file's time, so a window's ``t_start`` is in the file's time; the first time stamp is
        the scene's ``t0`` [s] (not moved to 0) and frames before it are refused.
    """
    path = Path(path)
    _check_interpolation(interpolation, path)
    fill = check_positive(fill, "fill (temperature outside the mesh)", "K")
    dx = check_positive(dx, "dx (sample pitch; --dx on the command line)", "m")
    if dt is not None:
        dt = check_positive(dt, "dt (frame interval; --dt on the command line)", "s")
    data, stated, where = _parse(path, columns)
    units = _merge_units(path, stated, where, units)
    for key, table in (("time", TIME_UNITS), ("length", LENGTH_UNITS),
                       ("temperature", TEMPERATURE_OFFSETS)):
        if key not in units:
            raise RadiosimError(f"{path}: the {key} unit is stated nowhere; pass "
                                f"units={{'{key}': …}} ({', '.join(table)}) or add a header "
                                f"'# units: time=…, length=…, temperature=…'")
        if units[key] not in table:
            raise RadiosimError(f"{path}: {key} unit {units[key]!r} is not one of "
                                f"{', '.join(table)}")
    time = data[:, 0] * TIME_UNITS[units["time"]]
    xy = data[:, 1:3] * LENGTH_UNITS[units["length"]]
    temperature = to_kelvin(data[:, 3], units["temperature"])
    if np.any(temperature <= 0):
        line = int(np.argmax(temperature <= 0))
        raise RadiosimError(f"{path}: data row {line + 1} has temperature "
                            f"{temperature[line]:g} K ≤ 0 (wrong unit?)")

    _refuse_split_steps(path, time)
    times, inverse = np.unique(time, return_inverse=True)
    steps = []
    for k in range(times.size):
        mine = inverse == k
        if mine.sum() < 3:
            raise RadiosimError(f"{path}: step {k} (t = {readable_time(times[k])}) has {mine.sum()} "
                                "node(s); at least 3 are needed")
        steps.append(_unique_nodes(path, k, times[k], np.flatnonzero(mine), xy[mine],
                                   temperature[mine], units))
    if times.size > 1:
        step = np.diff(times)
        uneven = np.abs(step - step.mean()) > 1e-6 * step.mean()
        if uneven.any():
            k = int(np.argmax(uneven))
            raise RadiosimError(f"{path}: steps are not evenly spaced in time (step {k} → {k + 1}"
                                f" is {step[k]:g} s, the mean is {step.mean():g} s)")
        if (dt is not None and interpolation != "linear"
                and abs(dt - step.mean()) > 1e-6 * step.mean()):
            raise RadiosimError(f"{path}: dt = {dt:g} s does not match the file's step "
                                f"{step.mean():g} s (a finer dt needs interpolation='linear')")
    elif dt is None:
        raise RadiosimError(f"{path}: a single step; pass dt [s]")
    origin, shape = _grid(xy, bounds, dx, str(path), f"µm data read as {units['length']}?")
    if max_edge is None:
        tri = triangulate(steps[0][0], f"{path}: step 0 (t = {readable_time(times[0])})")
        corners = steps[0][0][tri.simplices]
        max_edge = 4 * float(np.median(np.linalg.norm(corners - np.roll(corners, 1, axis=1),
                                                      axis=2)))
    return FeaNodes(steps, times, dx, origin, shape, float(fill), float(max_edge),
                    emissivity, str(path), dt=dt, interpolation=interpolation)


# -- FEA meshes through meshio ---------------------------------------------------------------

#: 2-D cell types and the corner nodes that make their triangles.
_TRIANGLES_OF = {"triangle": [(0, 1, 2)], "triangle6": [(0, 1, 2)], "triangle7": [(0, 1, 2)],
                 "quad": [(0, 1, 2), (0, 2, 3)], "quad8": [(0, 1, 2), (0, 2, 3)],
                 "quad9": [(0, 1, 2), (0, 2, 3)]}


def _mesh_steps(source, times, time_unit):
    """(time [s] or None, points, cells, point_data, cell_data) of each step of ``source``."""
    import meshio

    def read(path):
        path = Path(path)
        if not path.is_file():
            raise RadiosimError(f"FEA mesh file {path} does not exist")
        try:  # meshio reports some failures on stderr and exits: keep both to one line
            with contextlib.redirect_stderr(io.StringIO()), \
                    contextlib.redirect_stdout(io.StringIO()):
                return meshio.read(path)
        except (Exception, SystemExit) as exc:
            detail = str(exc) if not isinstance(exc, SystemExit) else "not a readable mesh"
            raise RadiosimError(f"cannot read FEA mesh {path}: {detail}") from None

    if isinstance(source, (str, Path)) and Path(source).suffix.lower() == ".pvd":
        import xml.etree.ElementTree as ElementTree

        path = Path(source)
        try:
            sets = ElementTree.parse(path).getroot().iter("DataSet")
            entries = [(float(d.get("timestep")), path.parent / d.get("file")) for d in sets]
        except (OSError, ElementTree.ParseError, TypeError, ValueError) as exc:
            raise RadiosimError(f"cannot read the ParaView collection {path}: {exc}") from None
        if not entries:
            raise RadiosimError(f"{path} lists no DataSet")
        if time_unit is None:
            raise RadiosimError(f"{path}: its timesteps' unit is stated nowhere; pass "
                                f"units={{'time': …}} ({', '.join(TIME_UNITS)})")
        for t, file in sorted(entries):
            mesh = read(file)
            yield t * TIME_UNITS[time_unit], mesh.points, mesh.cells, mesh.point_data, \
                mesh.cell_data
        return
    if isinstance(source, (str, Path)) and Path(source).suffix.lower() in (".xdmf", ".xmf"):
        from meshio.xdmf import TimeSeriesReader

        path = Path(source)
        if time_unit is None:
            raise RadiosimError(f"{path}: its times' unit is stated nowhere; pass "
                                f"units={{'time': …}} ({', '.join(TIME_UNITS)})")
        try:
            with TimeSeriesReader(path) as reader:
                points, cells = reader.read_points_cells()
                for k in range(reader.num_steps):
                    t, point_data, cell_data = reader.read_data(k)
                    yield float(t) * TIME_UNITS[time_unit], points, cells, point_data, cell_data
        except RadiosimError:
            raise
        except Exception as exc:
            raise RadiosimError(f"cannot read the XDMF time series {path}: {exc}") from None
        return
    files = [source] if isinstance(source, (str, Path)) else list(source)
    if times is None or len(times) != len(files):
        raise RadiosimError(f"a list of {len(files)} mesh file(s) needs times [s], one per file "
                            f"(got {None if times is None else len(times)})")
    for t, file in zip(times, files):
        mesh = read(file)
        yield float(t), mesh.points, mesh.cells, mesh.point_data, mesh.cell_data


def _triangles(cells, where):
    """The triangles of every 2-D cell, and for each the index of its cell (block, row)."""
    triangles, owners = [], []
    for b, block in enumerate(cells):
        kind, data = block.type, np.asarray(block.data)
        if kind in _TRIANGLES_OF:
            corners = _TRIANGLES_OF[kind]
        elif kind.startswith("polygon"):
            corners = [(0, i, i + 1) for i in range(1, data.shape[1] - 1)]
        else:
            continue  # points, lines and 3-D cells are not part of a 2-D field
        for c in corners:
            triangles.append(data[:, c])
            owners.append(np.column_stack([np.full(data.shape[0], b), np.arange(data.shape[0])]))
    if not triangles:
        raise RadiosimError(f"{where}: no 2-D cells (triangles, quads or polygons)")
    return np.concatenate(triangles).astype(np.intp), np.concatenate(owners)


def _temperature_unit(field: str, units: dict, where: str) -> str:
    named = next((unit for unit in TEMPERATURE_OFFSETS
                  if field.endswith(f"_{unit}") or field.endswith(f"[{unit}]")), None)
    if "temperature" in units:
        if named is not None and named != units["temperature"]:
            raise RadiosimError(f"{where}: units temperature={units['temperature']} contradicts "
                                f"the field's name {field!r} (temperature in {named}); drop "
                                "one or correct it")
        return units["temperature"]
    if named is not None:
        return named
    raise RadiosimError(f"{where}: the temperature unit of field {field!r} is stated nowhere; "
                        f"pass units={{'temperature': …}} ({', '.join(TEMPERATURE_OFFSETS)}) or "
                        "name the field with a unit suffix (temperature_C)")


def read_fea_mesh(source, dx, times=None, field: str = "temperature", units=None,
                  fill=AMBIENT_TEMPERATURE, bounds=None, emissivity=1.0, interpolation="hold",
                  dt=None) -> FeaMesh:
    """
    Read a time series of FEA meshes (meshio: VTU, VTK, XDMF, Exodus, …) and resample it onto a
    regular grid, inside the mesh by its own cells, outside by ``fill``.

    Parameters
    ----------
    source
        A list of mesh files (with ``times``), a ParaView ``.pvd`` collection, or an XDMF time
        series (``.xdmf``).
    dx
        Sample pitch of the output grid [m].
    times
        The list's times [s].
    field
        Name of the temperature data, point data (interpolated linearly in each triangle) or
        cell data (constant over its cell).
    units
        ``length`` (m, mm, um) of the coordinates, ``temperature`` (K, C; else read from the
        field's suffix, ``temperature_C``) and ``time`` (of a collection's or series' times).
    fill
        Temperature outside the mesh [K].
    bounds
        (x_min, x_max, y_min, y_max) of the grid [m]; ``None``: the meshes' extent.
    emissivity
        As for :class:`~radiosim.FrameStack`.
    interpolation
        ``"hold"`` (default) or ``"linear"`` between steps, as for :func:`read_fea_nodes`.
    dt
        Frame interval [s] with ``interpolation="linear"``; ``None``: the steps' interval.

    Returns
    -------
    FeaMesh
        A scene on the series' own time axis (the steps must be evenly spaced): frame k
        covers [k·dt, (k+1)·dt) [s], the first step's time is the scene's ``t0`` (not moved
        to 0), and a window's ``t_start`` is in that time.
    """
    units = dict(units or {})
    where = str(source if isinstance(source, (str, Path)) else "the mesh files")
    _check_interpolation(interpolation, where)
    if units.get("length") not in LENGTH_UNITS:
        raise RadiosimError(f"{where}: the length unit of the coordinates must be stated: "
                            f"units={{'length': …}} ({', '.join(LENGTH_UNITS)})")
    if "temperature" in units and units["temperature"] not in TEMPERATURE_OFFSETS:
        raise RadiosimError(f"temperature unit {units['temperature']!r} is not one of "
                            f"{', '.join(TEMPERATURE_OFFSETS)}")
    if "time" in units and units["time"] not in TIME_UNITS:
        raise RadiosimError(f"time unit {units['time']!r} is not one of {', '.join(TIME_UNITS)}")
    dx = check_positive(dx, "dx (sample pitch)", "m")
    fill = check_positive(fill, "fill (temperature outside the mesh)", "K")
    scale = LENGTH_UNITS[units["length"]]
    steps, step_times = [], []
    for k, (t, points, cells, point_data, cell_data) in enumerate(
            _mesh_steps(source, times, units.get("time"))):
        here = f"{where}, step {k}"
        if not math.isfinite(t):
            raise RadiosimError(f"{here}: its time is {t!r}; expected a finite time [s]")
        xy = np.asarray(points, dtype=float)[:, :2] * scale
        bad = ~np.isfinite(xy).all(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            raise RadiosimError(f"{here}: node {i} has coordinates {points[i][:2].tolist()} "
                                f"{units['length']}; expected finite numbers")
        triangles, owners = _triangles(cells, here)
        if field in point_data:
            values, kind = _scalar(point_data[field], field, "point", here), "point"
        elif field in cell_data:
            blocks = [_scalar(b, field, "cell", here) for b in cell_data[field]]
            starts = np.cumsum([0] + [b.size for b in blocks[:-1]])  # each block's first cell
            values, kind = np.concatenate(blocks)[starts[owners[:, 0]] + owners[:, 1]], "cell"
        else:
            names = sorted({*point_data, *cell_data})
            raise RadiosimError(f"{here}: no field {field!r}; the mesh holds "
                                f"{', '.join(names) or 'no data'}")
        values = to_kelvin(values, _temperature_unit(field, units, here))
        if not np.all(np.isfinite(values)) or np.any(values <= 0):
            bad = values[~(np.isfinite(values) & (values > 0))][0]
            raise RadiosimError(f"{here}: field {field!r} holds {bad!r} K (NaN, infinite or "
                                "≤ 0: wrong unit?)")
        steps.append((xy, triangles, values, kind))
        step_times.append(float(t))
    step_times = np.asarray(step_times)
    own_times = isinstance(source, (str, Path)) and Path(source).suffix.lower() in (
        ".pvd", ".xdmf", ".xmf")
    if own_times and times is not None:  # the file states its times: a contradiction is refused
        given = np.asarray(times, dtype=float).reshape(-1)
        if given.size != step_times.size or not np.allclose(given, step_times, rtol=1e-9,
                                                             atol=0.0):
            raise RadiosimError(f"{where}: times={given.tolist()} s contradict the file's own "
                                f"times {step_times.tolist()} s; drop times (the file states "
                                "them) or correct them")
    if step_times.size > 1:
        step = np.diff(step_times)
        if np.any(step == 0):
            k = int(np.argmax(step == 0))
            raise RadiosimError(f"{where}: time stamp {readable_time(step_times[k])} twice "
                                f"(steps {k} and {k + 1}); one time stamp per step")
        if np.any(step <= 0) or np.any(np.abs(step - step.mean()) > 1e-6 * step.mean()):
            raise RadiosimError(f"{where}: the steps are not evenly spaced and increasing in "
                                f"time ({step_times.tolist()} s)")
        if dt is None:
            dt = float(step.mean())
        else:
            dt = check_positive(dt, "dt (frame interval)", "s")
            if interpolation != "linear" and abs(dt - step.mean()) > 1e-6 * step.mean():
                raise RadiosimError(f"{where}: dt = {dt:g} s does not match the steps' "
                                    f"{step.mean():g} s (a finer dt needs "
                                    "interpolation='linear')")
    else:
        raise RadiosimError(f"{where}: a single step; a scene needs at least two")
    origin, shape = _grid(np.concatenate([s[0] for s in steps]), bounds, dx, where, "")
    return FeaMesh(steps, step_times, dt, dx, origin, shape, float(fill), emissivity, where,
                   interpolation=interpolation)


def _scalar(data, field: str, kind: str, where: str) -> np.ndarray:
    """A field's values as one number per point or cell; a vector or tensor field raises,
    naming the field and its shape."""
    values = np.asarray(data, dtype=float)
    if values.ndim > 1 and int(np.prod(values.shape[1:])) != 1:
        raise RadiosimError(f"{where}: {kind} field {field!r} has shape {values.shape} "
                            f"({int(np.prod(values.shape[1:]))} components per {kind}); a "
                            "temperature is one number per point or cell")
    return values.reshape(-1)

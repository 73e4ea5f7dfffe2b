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

import csv
import math
from pathlib import Path

import numpy as np
from radiosim.checks import check_positive
from radiosim.errors import RadiosimError
from radiosim.scenes.fea_nodes import FeaNodes, triangulate
from radiosim.units import TEMPERATURE_OFFSETS, UNITS, to_kelvin

__all__ = ["read_fea_nodes", "FeaNodes"]

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


def _parse(path: Path):
    """Rows of (time, x, y, temperature) and the units stated in the header, if any."""
    stated = {}
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
                            stated[key.strip().lower()] = value.strip()
                continue
            if header is None:
                names = [c.strip().lower() for c in line]
                missing = [c for c in _COLUMNS if c not in names]
                if missing:
                    raise RadiosimError(f"{path}, line {number}: header lacks column(s) "
                                        f"{', '.join(missing)}; expected {', '.join(_COLUMNS)}")
                header = [names.index(c) for c in _COLUMNS]
                width = len(names)
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
                raise RadiosimError(f"{path}, line {number}: NaN or infinite value")
            rows.append(values)
    if header is None or not rows:
        raise RadiosimError(f"{path}: no data (expected a header {','.join(_COLUMNS)} and rows)")
    return np.array(rows), stated


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
            f"{path}: step {k} (t = {t:g} s) gives the node at x = {xy[i, 0] / scale:g}, "
            f"y = {xy[i, 1] / scale:g} {units['length']} two temperatures, "
            f"{temperature[j]:g} K (data row {rows[j] + 1}) and {temperature[i]:g} K (data row "
            f"{rows[i] + 1}); a node has one temperature per step")
    return unique, kept


def read_fea_nodes(path, dx, dt=None, units=None, fill=293.15, bounds=None, max_edge=None,
                   emissivity=1.0) -> FeaNodes:
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
        If given, it must match them.
    units
        Dict with ``time`` (s, ms, us, ns), ``length`` (m, mm, um) and ``temperature`` (K, C);
        keys not given come from the header comment ``# units: time=…, length=…,
        temperature=…``; a unit stated nowhere is an error.
    fill
        Temperature outside the mesh [K] (e.g. the ambient 293.15 K).
    bounds
        (x_min, x_max, y_min, y_max) of the grid [m]; ``None``: the nodes' extent over all
        steps. Row 0 of the frames is the top (y_max).
    max_edge
        Longest triangle edge that is part of the mesh [m]; ``None``: 4 × the median edge of
        the first step's triangulation.
    emissivity
        As for :class:`~radiosim.FrameStack`.

    Returns
    -------
    FeaNodes
        A scene with one frame per step.
    """
    path = Path(path)
    fill = check_positive(fill, "fill (temperature outside the mesh)", "K")
    dx = check_positive(dx, "dx (sample pitch; --dx on the command line)", "m")
    if dt is not None:
        dt = check_positive(dt, "dt (frame interval; --dt on the command line)", "s")
    data, stated = _parse(path)
    units = {**stated, **(units or {})}
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

    times, inverse = np.unique(time, return_inverse=True)
    steps = []
    for k in range(times.size):
        mine = inverse == k
        if mine.sum() < 3:
            raise RadiosimError(f"{path}: step {k} (t = {times[k]:g} s) has {mine.sum()} "
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
        if dt is not None and abs(dt - step.mean()) > 1e-6 * step.mean():
            raise RadiosimError(f"{path}: dt = {dt:g} s does not match the file's step "
                                f"{step.mean():g} s")
    elif dt is None:
        raise RadiosimError(f"{path}: a single step; pass dt [s]")
    if bounds is None:
        bounds = (xy[:, 0].min(), xy[:, 0].max(), xy[:, 1].min(), xy[:, 1].max())
    x0, x1, y0, y1 = (float(b) for b in bounds)
    shape = (int(math.floor((y1 - y0) / dx + 1e-9)), int(math.floor((x1 - x0) / dx + 1e-9)))
    if min(shape) < 1:
        raise RadiosimError(f"{path}: the grid {bounds} holds no {dx:g} m sample")
    if shape[0] * shape[1] > MAX_GRID_SAMPLES:
        raise RadiosimError(
            f"{path}: the nodes span {x1 - x0:.3g} × {y1 - y0:.3g} m, which at dx = {dx:g} m is "
            f"a grid of {shape[0]} × {shape[1]} samples; is the length unit right (µm data "
            f"read as {units['length']}?)")
    if max_edge is None:
        tri = triangulate(steps[0][0], f"{path}: step 0 (t = {times[0]:g} s)")
        corners = steps[0][0][tri.simplices]
        max_edge = 4 * float(np.median(np.linalg.norm(corners - np.roll(corners, 1, axis=1),
                                                      axis=2)))
    scene = FeaNodes(steps, times, dx, (x0, y1), shape, float(fill), float(max_edge),
                     emissivity, str(path))
    if dt is not None:
        scene.dt = check_positive(dt, "dt", "s")
    return scene

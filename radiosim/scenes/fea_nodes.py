"""
Scenes resampled from FEA output, one frame per simulation step.

-   :class:`FeaNodes`: scattered nodes (a nodal CSV export, :func:`radiosim.io.read_fea_nodes`);
    each step is triangulated (Delaunay) and interpolated linearly inside the mesh; triangles
    whose longest edge exceeds ``max_edge`` are not part of the mesh.
-   :class:`FeaMesh`: the solver's own mesh (:func:`radiosim.io.read_fea_mesh`, via meshio):
    every 2-D cell split into triangles, point data interpolated linearly inside each triangle
    (barycentric), cell data constant over its cell; the mesh may move or be remeshed from step
    to step.

Samples outside the mesh get the stated ``fill`` temperature.

Time: the scenes keep the file's own time origin, and their frames are aligned to its time
stamps: frame k covers [o + k·dt, o + (k+1)·dt) of the file's time, the origin o ∈ [0, dt)
the first time stamp's phase (``frame_origin``: a file whose first time stamp is 5.5 µs, in
frames of 1 µs, has o = 0.5 µs and frame 5 starting at 5.5 µs). A window's ``t_start`` is in
the data's time, the first time stamp is the scene's ``t0`` [s] and the first frame
(``first_frame``) starts there; frames before it are refused when read. Between snapshots the
field is held (``interpolation="hold"``, sample-and-hold: each snapshot holds until the next;
``dt`` is the snapshots' step, so frame k is one snapshot and a window's mean is the exact
sample-and-hold average whatever the file's origin) or linear in time
(``interpolation="linear"``: each frame is the exact mean over its interval of the field
linear between the snapshots around it, any ``dt``).

In linear mode a window's mean is exact for the piecewise-linear field when the window starts
and ends on frame edges, and for a field linear in time also when the window lasts a whole
number of frames; otherwise each partial frame at its ends is taken at the frame's mean, and
the error is at most max abs(∂T/∂t) · dt² / (4 · t_int) [K] (each end's piece p of a frame
contributes at most abs(∂T/∂t) · p (dt − p) / 2 ≤ abs(∂T/∂t) · dt² / 8 to the integral): a finer
``dt`` bounds it (``dt`` = step / 4 with a window of one step: ≤ 1/64 of the step's change).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import Delaunay

from radiosim.errors import RadiosimError
from radiosim.scenes.base import Region, Scene, check_emissivity
from radiosim.units import readable_time, readable_times

__all__ = ["FeaNodes", "FeaMesh", "triangulate", "INTERPOLATIONS"]

#: How the field varies between snapshots: held until the next, or linear in time.
INTERPOLATIONS = ("hold", "linear")
_SNAP = 1e-9  # times within this many frame intervals (or steps) of an edge are on it
#: A first time stamp more frame intervals than this from t = 0 is a unit slip.
_MAX_FRAMES = 2**40


def _snap(value: float) -> float:
    nearest = round(value)
    return float(nearest) if abs(value - nearest) <= _SNAP * max(1.0, abs(value)) else value


class _Snapshots(Scene):
    """
    Frames on the file's own time axis from snapshots at ``times`` [s] (the subclass grids
    snapshot ``j`` over a region with :meth:`_snapshot`).

    Attributes
    ----------
    times : numpy.ndarray
        The snapshots' times [s], as the file states them (not moved to 0).
    t0 : float
        The first snapshot's time [s]: the data's time origin.
    frame_origin : float
        Start of frame 0 [s], in [0, dt): the first time stamp's phase on the frame grid.
    first_frame : int
        The first frame holding data, starting at ``t0``; frame k covers
        [frame_origin + k·dt, frame_origin + (k+1)·dt) [s].
    interpolation : str
        ``"hold"`` or ``"linear"``.
    """

    def _timeline(self, times, dt, interpolation, source):
        self.times = np.asarray(times, dtype=float)
        if interpolation not in INTERPOLATIONS:
            raise RadiosimError(f"{source}: interpolation {interpolation!r} is not one of "
                                f"{', '.join(INTERPOLATIONS)}")
        self.interpolation = interpolation
        self.step = (float(np.mean(np.diff(self.times))) if self.times.size > 1
                     else None)  # between snapshots [s]
        if interpolation == "linear" and self.step is None:
            raise RadiosimError(f"{source}: interpolation='linear' needs two snapshots or more; "
                                "the file has one")
        self.dt = float(dt if dt is not None else self.step)
        self.t0 = float(self.times[0])
        end = self.times[-1] + (self.step or self.dt) if interpolation == "hold" else \
            self.times[-1]
        if not (abs(self.t0) / self.dt < _MAX_FRAMES and abs(end) / self.dt < _MAX_FRAMES):
            raise RadiosimError(f"{source}: its times run {self.t0:g}–{end:g} s, more than "
                                f"{_MAX_FRAMES} frames of {self.dt:g} s from t = 0; is the time "
                                "unit right?")
        # Frames aligned to the first time stamp: frame first_frame starts at t0 (o ∈ [0, dt)).
        whole = math.floor(_snap(self.t0 / self.dt))
        self.frame_origin = max(0.0, self.t0 - whole * self.dt)
        if self.frame_origin < _SNAP * self.dt:
            self.frame_origin = 0.0
        self.first_frame = max(0, math.ceil(_snap((self.t0 - self.frame_origin) / self.dt)))
        self.n_frames = math.floor(_snap((end - self.frame_origin) / self.dt))
        if self.n_frames <= self.first_frame:
            raise RadiosimError(f"{source}: no whole frame of dt = {self.dt:g} s lies within its "
                                f"times {self.t0:g}–{end:g} s at t ≥ 0 (a scene's windows start "
                                "at t ≥ 0 of the file's time)")

    def _weights(self, k: int) -> list[tuple[int, float]]:
        """Frame ``k`` as (snapshot, weight) pairs: the snapshots' shares of the field's exact
        mean over the frame's interval."""
        a = self.frame_start(k)
        if k < self.first_frame:
            (low, high), unit = readable_times(a, a + self.dt)
            span = f"{low}–{high} {unit}"
            raise RadiosimError(
                f"frame {k} covers {span}, before {self._source}'s first time stamp "
                f"{readable_time(self.t0)}; windows are in the file's own time: start them at "
                f"t_start ≥ {readable_time(self.t0)}")
        n = self.times.size
        step = self.step or self.dt
        ua = _snap((a - self.t0) / step)  # the frame in steps from the first snapshot
        ub = _snap((a + self.dt - self.t0) / step)
        weights: dict[int, float] = {}
        if self.interpolation == "linear":
            # ∫ of the hat functions of the snapshots j, j + 1 over each segment's part [p, q]
            for j in range(max(int(math.floor(ua)), 0), min(int(math.ceil(ub)), n - 1)):
                p, q = max(ua, j), min(ub, j + 1.0)
                if q > p:
                    weights[j] = weights.get(j, 0.0) + ((j + 1 - p) ** 2 - (j + 1 - q) ** 2) / 2
                    weights[j + 1] = weights.get(j + 1, 0.0) + ((q - j) ** 2 - (p - j) ** 2) / 2
        else:  # each snapshot holds over [t_j, t_j + step)
            for j in range(max(int(math.floor(ua)), 0), min(int(math.ceil(ub)), n)):
                overlap = min(ub, j + 1.0) - max(ua, j)
                if overlap > 0:
                    weights[j] = overlap
        total = ub - ua
        return [(j, w / total) for j, w in weights.items() if w > 0]

    def _read(self, k: int, region: Region) -> np.ndarray:
        weights = self._weights(k)
        if len(weights) == 1 and weights[0][1] == 1:
            return self._snapshot(weights[0][0], region)
        return sum(w * self._snapshot(j, region) for j, w in weights)

    def _describe_time(self) -> dict:
        return {"t0_s": self.t0, "first_frame": self.first_frame,
                "frame_origin_s": self.frame_origin, "interpolation": self.interpolation}


def triangulate(points: np.ndarray, where: str):
    """
    The Delaunay triangulation of FEA nodes (x, y) [m], or one line naming what is wrong
    (collinear or coincident nodes), never qhull's own report.
    """
    points = np.asarray(points, dtype=float)
    if points.shape[0] < 3:
        raise RadiosimError(f"{where}: {points.shape[0]} node(s); at least 3 are needed")
    centred = points - points.mean(axis=0)
    scale = float(np.abs(centred).max()) or 1.0
    if np.linalg.matrix_rank(centred / scale, tol=1e-9) < 2:
        raise RadiosimError(f"{where}: its {points.shape[0]} nodes are collinear (or coincide); "
                            "a 2-D mesh needs nodes that span an area")
    try:
        return Delaunay(points)
    except Exception as exc:  # qhull's errors carry a long report: keep its first line
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise RadiosimError(f"{where}: cannot triangulate its {points.shape[0]} nodes "
                            f"({first})") from None


class FeaNodes(_Snapshots):
    """
    A scene resampled from FEA nodes, one snapshot per simulation step, on the file's own
    time axis (see the module's notes: ``t0``, ``first_frame``, ``interpolation``).

    Build it with :func:`read_fea_nodes`. Frames are interpolated on demand (the triangulations
    of the last two steps are kept), so memory holds the nodes, not a gridded stack.
    """

    #: The files it is read from (:func:`radiosim.io.read_fea_nodes`): a nodal CSV.
    SUFFIXES = (".csv",)

    def __init__(self, steps, times, dx, origin, shape, fill, max_edge, emissivity, source,
                 dt=None, interpolation="hold"):
        self._steps = steps  # list of (points [m], temperature [K])
        self._source = source
        self._timeline(times, dt, interpolation, source)
        self.dx = dx
        self.origin = origin  # (x of column 0's left edge, y of row 0's top edge) [m]
        self.shape = shape
        self.fill = fill
        self.max_edge = max_edge
        self.emissivity = check_emissivity(emissivity, shape)
        self.event_time = None
        self._triangulations: dict[int, tuple] = {}

    def _mesh(self, k):
        cached = self._triangulations.get(k)  # one read: another thread may replace the dict
        if cached is None:
            points, _ = self._steps[k]
            tri = triangulate(points, f"step {k} (t = {readable_time(self.times[k])}) of {self._source}")
            corners = points[tri.simplices]
            edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
            cached = (tri, edges <= self.max_edge)
            kept = {j: v for j, v in self._triangulations.items() if abs(j - k) == 1}
            self._triangulations = {**kept, k: cached}  # keep the neighbours (interpolation)
        return cached

    def _snapshot(self, k: int, region: Region) -> np.ndarray:
        tri, valid = self._mesh(k)
        _, temperature = self._steps[k]
        rows = np.arange(region[0].start, region[0].stop)
        cols = np.arange(region[1].start, region[1].stop)
        x = self.origin[0] + (cols + 0.5) * self.dx
        y = self.origin[1] - (rows + 0.5) * self.dx
        grid = np.column_stack([np.tile(x, rows.size), np.repeat(y, cols.size)])
        simplex = tri.find_simplex(grid)
        inside = simplex >= 0
        inside[inside] = valid[simplex[inside]]
        out = np.full(grid.shape[0], self.fill)
        s = simplex[inside]
        transform = tri.transform[s]
        bary = np.einsum("ijk,ik->ij", transform[:, :2], grid[inside] - transform[:, 2])
        weights = np.column_stack([bary, 1 - bary.sum(axis=1)])
        out[inside] = np.einsum("ij,ij->i", weights, temperature[tri.simplices[s]])
        return out.reshape(rows.size, cols.size)

    def describe(self) -> dict:
        return super().describe() | {"source": self._source, "fill_K": self.fill,
                                     "max_edge_m": self.max_edge} | self._describe_time()




class FeaMesh(_Snapshots):
    """
    A scene resampled from an FEA mesh's own cells, one snapshot per step, on the file's own
    time axis (see the module's notes: ``t0``, ``first_frame``, ``interpolation``).

    Build it with :func:`radiosim.io.read_fea_mesh`. Each step holds its nodes (x, y) [m], its
    triangles (node indices; quads and higher-order cells split by the reader), and its
    temperature [K] per node or per triangle; a sample at a triangle's inside takes the
    triangle's linear interpolation (or its cell's value), elsewhere ``fill``.
    """

    #: The mesh files it is read from, through meshio (:func:`radiosim.io.read_fea_mesh`): a
    #: ParaView collection, VTK, XDMF, Exodus and Gmsh files.
    SUFFIXES = (".pvd", ".vtu", ".vtk", ".xdmf", ".xmf", ".exo", ".e", ".msh")

    def __init__(self, steps, times, dt, dx, origin, shape, fill, emissivity, source,
                 interpolation="hold"):
        self._steps = steps  # list of (points [m], triangles, values [K], "point" | "cell")
        self._source = source
        self._timeline(times, dt, interpolation, source)
        self.dx = dx
        self.origin = origin  # (x of column 0's left edge, y of row 0's top edge) [m]
        self.shape = shape
        self.fill = fill
        self.emissivity = check_emissivity(emissivity, shape)
        self.event_time = None
        self._finders: dict[int, object] = {}

    def _finder(self, k):
        finder = self._finders.get(k)  # one read: another thread may replace the dict
        if finder is None:
            from matplotlib.tri import Triangulation

            points, triangles, _, _ = self._steps[k]
            try:
                mesh = Triangulation(points[:, 0], points[:, 1], triangles)
                finder = mesh.get_trifinder()
            except (ValueError, RuntimeError) as exc:
                raise RadiosimError(f"step {k} of {self._source}: its cells do not form a valid "
                                    f"2-D mesh (overlapping or degenerate triangles: "
                                    f"{exc})") from None
            kept = {j: v for j, v in self._finders.items() if abs(j - k) == 1}
            self._finders = {**kept, k: finder}  # keep the neighbours (interpolation)
        return finder

    def _snapshot(self, k: int, region: Region) -> np.ndarray:
        points, triangles, values, kind = self._steps[k]
        rows = np.arange(region[0].start, region[0].stop)
        cols = np.arange(region[1].start, region[1].stop)
        x = np.tile(self.origin[0] + (cols + 0.5) * self.dx, rows.size)
        y = np.repeat(self.origin[1] - (rows + 0.5) * self.dx, cols.size)
        cell = self._finder(k)(x, y)
        inside = cell >= 0
        out = np.full(x.size, self.fill)
        c = cell[inside]
        if kind == "cell":
            out[inside] = values[c]
        else:  # barycentric weights of each sample in its own triangle
            a, b, d = (points[triangles[c, i]] for i in range(3))
            px, py = x[inside], y[inside]
            det = (b[:, 1] - d[:, 1]) * (a[:, 0] - d[:, 0]) + (d[:, 0] - b[:, 0]) * (
                a[:, 1] - d[:, 1])
            w1 = ((b[:, 1] - d[:, 1]) * (px - d[:, 0]) + (d[:, 0] - b[:, 0]) * (py - d[:, 1])) / det
            w2 = ((d[:, 1] - a[:, 1]) * (px - d[:, 0]) + (a[:, 0] - d[:, 0]) * (py - d[:, 1])) / det
            w3 = 1.0 - w1 - w2
            out[inside] = (w1 * values[triangles[c, 0]] + w2 * values[triangles[c, 1]]
                           + w3 * values[triangles[c, 2]])
        return out.reshape(rows.size, cols.size)

    def describe(self) -> dict:
        return super().describe() | {"source": self._source, "fill_K": self.fill} | \
            self._describe_time()

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
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from radiosim.errors import RadiosimError
from radiosim.scenes.base import Region, Scene, check_emissivity

__all__ = ["FeaNodes", "FeaMesh", "triangulate"]


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


class FeaNodes(Scene):
    """
    A scene resampled from FEA nodes, one frame per simulation step.

    Build it with :func:`read_fea_nodes`. Frames are interpolated on demand (the triangulation
    of each step is kept), so memory holds the nodes, not a gridded stack.
    """

    def __init__(self, steps, times, dx, origin, shape, fill, max_edge, emissivity, source):
        self._steps = steps  # list of (points [m], temperature [K])
        self.times = times
        self.dt = float(np.mean(np.diff(times))) if len(times) > 1 else None
        self.dx = dx
        self.origin = origin  # (x of column 0's left edge, y of row 0's top edge) [m]
        self.shape = shape
        self.n_frames = len(steps)
        self.fill = fill
        self.max_edge = max_edge
        self.emissivity = check_emissivity(emissivity, shape)
        self.event_time = None
        self._source = source
        self._triangulations: dict[int, tuple] = {}

    def _mesh(self, k):
        cached = self._triangulations.get(k)  # one read: another thread may replace the dict
        if cached is None:
            points, _ = self._steps[k]
            tri = triangulate(points, f"step {k} (t = {self.times[k]:g} s) of {self._source}")
            corners = points[tri.simplices]
            edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
            cached = (tri, edges <= self.max_edge)
            self._triangulations = {k: cached}  # keep the latest only
        return cached

    def _read(self, k: int, region: Region) -> np.ndarray:
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
                                     "max_edge_m": self.max_edge}




class FeaMesh(Scene):
    """
    A scene resampled from an FEA mesh's own cells, one frame per step.

    Build it with :func:`radiosim.io.read_fea_mesh`. Each step holds its nodes (x, y) [m], its
    triangles (node indices; quads and higher-order cells split by the reader), and its
    temperature [K] per node or per triangle; a sample at a triangle's inside takes the
    triangle's linear interpolation (or its cell's value), elsewhere ``fill``.
    """

    def __init__(self, steps, times, dt, dx, origin, shape, fill, emissivity, source):
        self._steps = steps  # list of (points [m], triangles, values [K], "point" | "cell")
        self.times = times
        self.dt = dt
        self.dx = dx
        self.origin = origin  # (x of column 0's left edge, y of row 0's top edge) [m]
        self.shape = shape
        self.n_frames = len(steps)
        self.fill = fill
        self.emissivity = check_emissivity(emissivity, shape)
        self.event_time = None
        self._source = source
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
            self._finders = {k: finder}  # keep the latest only
        return finder

    def _read(self, k: int, region: Region) -> np.ndarray:
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
        return super().describe() | {"source": self._source, "fill_K": self.fill}

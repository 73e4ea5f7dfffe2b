"""
A scene resampled from scattered FEA nodes, one frame per simulation step.

Each step is triangulated (Delaunay) and interpolated linearly inside the mesh; triangles whose
longest edge exceeds ``max_edge`` are not part of the mesh, and samples outside it get the stated
``fill`` temperature. :func:`radiosim.io.read_fea_nodes` builds it from a nodal CSV export.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from radiosim.errors import RadiosimError
from radiosim.scenes.base import Region, Scene, check_emissivity

__all__ = ["FeaNodes", "triangulate"]


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
        if k not in self._triangulations:
            points, _ = self._steps[k]
            tri = triangulate(points, f"step {k} (t = {self.times[k]:g} s) of {self._source}")
            corners = points[tri.simplices]
            edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
            self._triangulations = {k: (tri, edges <= self.max_edge)}  # keep the latest only
        return self._triangulations[k]

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



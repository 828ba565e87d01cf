"""Ground-truth occupancy grid of one floor of a scene, and obstacle inflation.

Built from the scene mesh directly (not from the navmesh): a cell (0.05 m by default) is
*occupied* when the robot's body, the slab from ``floor + max_climb`` to
``floor + h_robot``, intersects a triangle there (triangles are clipped to the slab and
rasterised conservatively: clipped edges mark every cell they cross, interiors mark the
cells whose centres they cover), or when the cell has no floor, i.e. no walkable
triangle (slope <= max_slope) within ``±max_climb`` of the floor height. Obstacles are
then inflated by a margin with an exact Euclidean distance transform (cell centres).

Grid layout: ``occupied[row, col]``; row follows world +z, col world +x; the centre of
cell (r, c) is ``(x0 + (c + 0.5)·res, z0 + (r + 0.5)·res)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from scipy.ndimage import distance_transform_edt

from rvn_data.scenes.scene import Scene, SceneError


@njit(cache=True)
def _clip(px, py, pz, n, level, keep_above):
    """Sutherland-Hodgman clip of a polygon against the plane y = level."""
    ox = np.empty(8)
    oy = np.empty(8)
    oz = np.empty(8)
    m = 0
    for i in range(n):
        j = (i + 1) % n
        di = py[i] - level if keep_above else level - py[i]
        dj = py[j] - level if keep_above else level - py[j]
        if di >= 0.0:
            ox[m], oy[m], oz[m] = px[i], py[i], pz[i]
            m += 1
        if (di >= 0.0) != (dj >= 0.0):
            t = di / (di - dj)
            ox[m] = px[i] + t * (px[j] - px[i])
            oy[m] = py[i] + t * (py[j] - py[i])
            oz[m] = pz[i] + t * (pz[j] - pz[i])
            m += 1
    return ox, oy, oz, m


@njit(cache=True)
def _mark(out, x, z, x0, z0, res):
    c = int(math.floor((x - x0) / res))
    r = int(math.floor((z - z0) / res))
    if 0 <= r < out.shape[0] and 0 <= c < out.shape[1]:
        out[r, c] = True


@njit(cache=True)
def _rasterise(verts, faces, lo, hi, min_abs_ny, x0, z0, res, out):
    """Mark cells covered by the parts of triangles inside the slab lo <= y <= hi.

    Only triangles whose |normal_y| >= min_abs_ny count (0 = every triangle)."""
    px = np.empty(3)
    py = np.empty(3)
    pz = np.empty(3)
    for f in range(faces.shape[0]):
        for k in range(3):
            v = faces[f, k]
            px[k], py[k], pz[k] = verts[v, 0], verts[v, 1], verts[v, 2]
        if max(py[0], py[1], py[2]) < lo or min(py[0], py[1], py[2]) > hi:
            continue
        if min_abs_ny > 0.0:
            ux, uy, uz = px[1] - px[0], py[1] - py[0], pz[1] - pz[0]
            vx, vy, vz = px[2] - px[0], py[2] - py[0], pz[2] - pz[0]
            nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            norm = math.sqrt(nx * nx + ny * ny + nz * nz)
            if norm == 0.0 or abs(ny) / norm < min_abs_ny:
                continue
        ax, ay, az, m = _clip(px, py, pz, 3, lo, True)
        bx, by, bz, m = _clip(ax, ay, az, m, hi, False)
        if m == 0:
            continue
        # edges: sample every half cell
        for i in range(m):
            j = (i + 1) % m
            length = math.hypot(bx[j] - bx[i], bz[j] - bz[i])
            steps = int(length / (0.5 * res)) + 1
            for s in range(steps + 1):
                t = s / steps
                _mark(out, bx[i] + t * (bx[j] - bx[i]), bz[i] + t * (bz[j] - bz[i]), x0, z0, res)
        # interior: cell centres inside the (convex) clipped polygon
        area = 0.0
        for i in range(m):
            j = (i + 1) % m
            area += bx[i] * bz[j] - bx[j] * bz[i]
        if abs(area) < 1e-12:
            continue
        sign = 1.0 if area > 0 else -1.0
        c0 = max(int(math.floor((bx[:m].min() - x0) / res)), 0)
        c1 = min(int(math.floor((bx[:m].max() - x0) / res)), out.shape[1] - 1)
        r0 = max(int(math.floor((bz[:m].min() - z0) / res)), 0)
        r1 = min(int(math.floor((bz[:m].max() - z0) / res)), out.shape[0] - 1)
        for r in range(r0, r1 + 1):
            cz = z0 + (r + 0.5) * res
            for c in range(c0, c1 + 1):
                cx = x0 + (c + 0.5) * res
                inside = True
                for i in range(m):
                    j = (i + 1) % m
                    cross = (bx[j] - bx[i]) * (cz - bz[i]) - (bz[j] - bz[i]) * (cx - bx[i])
                    if cross * sign < 0.0:
                        inside = False
                        break
                if inside:
                    out[r, c] = True


@dataclass
class OccupancyGrid:
    """Occupied cells of one floor (see module docstring for the layout)."""

    occupied: np.ndarray  # bool [rows, cols]
    origin: tuple[float, float]  # world (x0, z0) of the grid's corner
    resolution: float
    floor_height: float
    _clearance: np.ndarray | None = field(default=None, repr=False)
    _move_costs: dict = field(default_factory=dict, repr=False)

    @property
    def shape(self) -> tuple[int, int]:
        return self.occupied.shape

    def clearance(self) -> np.ndarray:
        """Distance (m) from each cell centre to the nearest occupied cell centre."""
        if self._clearance is None:
            self._clearance = (distance_transform_edt(~self.occupied) * self.resolution).astype(np.float32)
        return self._clearance

    def move_cost(self, clearance_pref: float | None, clearance_weight: float) -> np.ndarray | None:
        """Per-cell A* move-cost factor (>= 1) of the soft clearance (planning/astar.py), computed
        once per setting and kept; None when it is off."""
        if clearance_pref is None or clearance_weight <= 0:
            return None
        if not clearance_pref > 0:
            raise ValueError(f"clearance_pref={clearance_pref} must be positive (metres) or null")
        key = (float(clearance_pref), float(clearance_weight))
        if key not in self._move_costs:
            short = np.clip((clearance_pref - self.clearance().astype(np.float64)) / clearance_pref, 0.0, None)
            self._move_costs[key] = 1.0 + clearance_weight * short
        return self._move_costs[key]

    def inflate(self, margin: float) -> np.ndarray:
        """Free cells (bool) once obstacles are inflated by `margin` metres."""
        return self.clearance() > margin

    def to_cell(self, position: np.ndarray) -> np.ndarray:
        """World point(s) [..., 3] → (row, col) int64 [..., 2] (may lie outside the grid)."""
        p = np.asarray(position, dtype=np.float64)
        col = np.floor((p[..., 0] - self.origin[0]) / self.resolution)
        row = np.floor((p[..., 2] - self.origin[1]) / self.resolution)
        return np.stack([row, col], axis=-1).astype(np.int64)

    def to_world(self, cells: np.ndarray) -> np.ndarray:
        """(row, col) [..., 2] → world cell centres [..., 3] at the floor height."""
        rc = np.asarray(cells, dtype=np.float64)
        x = self.origin[0] + (rc[..., 1] + 0.5) * self.resolution
        z = self.origin[1] + (rc[..., 0] + 0.5) * self.resolution
        return np.stack([x, np.full_like(x, self.floor_height), z], axis=-1)

    def contains(self, cell: np.ndarray) -> bool:
        r, c = int(cell[0]), int(cell[1])
        return 0 <= r < self.shape[0] and 0 <= c < self.shape[1]


def occupancy_grid(scene: Scene, floor_height: float, resolution: float = 0.05, h_robot: float = 1.0,
                   max_climb: float = 0.2, max_slope_deg: float = 45.0) -> OccupancyGrid:
    """Rasterise `scene` at `floor_height` into an `OccupancyGrid` (module docstring)."""
    if not (resolution > 0 and h_robot > max_climb >= 0):
        raise ValueError(f"occupancy: need resolution > 0 and h_robot > max_climb >= 0, got "
                         f"resolution={resolution}, h_robot={h_robot}, max_climb={max_climb}")
    verts, faces = scene.triangles()
    if len(faces) == 0:
        raise SceneError(f"scene {scene.scene_id}: no triangles, cannot build an occupancy grid")
    lo_b, hi_b = scene.bounds
    x0, z0 = lo_b[0] - resolution, lo_b[2] - resolution
    cols = int(math.ceil((hi_b[0] - x0) / resolution)) + 2
    rows = int(math.ceil((hi_b[2] - z0) / resolution)) + 2
    v = np.ascontiguousarray(verts, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    body = np.zeros((rows, cols), np.bool_)
    _rasterise(v, f, floor_height + max_climb, floor_height + h_robot, 0.0, x0, z0, resolution, body)
    floor = np.zeros((rows, cols), np.bool_)
    min_ny = math.cos(math.radians(max_slope_deg))
    _rasterise(v, f, floor_height - max_climb, floor_height + max_climb, min_ny, x0, z0, resolution, floor)
    return OccupancyGrid(occupied=body | ~floor, origin=(float(x0), float(z0)),
                         resolution=float(resolution), floor_height=float(floor_height))

"""`NavGrid`: one 2-D layer of the navigation mesh as arrays, for planners and maps.

Cell (row, col) of a layer covers world x in [x0 + col·cs, x0 + (col+1)·cs) and
z in [z0 + row·cs, z0 + (row+1)·cs); its centre is at +cs/2. Rows grow with world z, so
row 0 is the far (-z) side; seen from above with +x to the right, -z is up: a top-down
image of a layer is its arrays flipped nowhere (row 0 at the top is -z).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class NavGrid:
    """A layer: `free` (walkable surface of this layer, before erosion), `height` (floor y
    in metres, NaN where not free), `clearance` (metres from the cell centre to the nearest
    obstacle or drop, 0 inside obstacles), `island` (island id, -1 where not navigable) and
    `navigable` (island >= 0, i.e. free with clearance >= agent_radius on a kept island).
    `x0`, `z0`: world corner of cell (0, 0); `cs`: cell size; `r0`, `c0`: the layer's offset
    in the scene-wide grid (`NavMesh.scene_grid_shape`)."""

    x0: float
    z0: float
    cs: float
    r0: int
    c0: int
    free: np.ndarray
    height: np.ndarray
    clearance: np.ndarray
    island: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.free.shape

    @property
    def navigable(self) -> np.ndarray:
        return self.island >= 0

    def occupancy(self, margin: float) -> np.ndarray:
        """Free cells whose centre is at least `margin` m from any obstacle (bool [rows, cols]);
        planners inflate obstacles by a margin larger or smaller than the robot radius."""
        return self.free & (self.clearance >= margin)

    def world_to_grid(self, points: np.ndarray) -> np.ndarray:
        """World points [..., 3] → integer (row, col) [..., 2] (may lie outside the grid)."""
        p = np.asarray(points, dtype=np.float64)
        col = np.floor((p[..., 0] - self.x0) / self.cs).astype(np.int64)
        row = np.floor((p[..., 2] - self.z0) / self.cs).astype(np.int64)
        return np.stack([row, col], axis=-1)

    def grid_to_world(self, rc: np.ndarray) -> np.ndarray:
        """(row, col) [..., 2] → world cell centres [..., 3] with y = floor height (NaN if none)."""
        rc = np.asarray(rc, dtype=np.int64)
        row, col = rc[..., 0], rc[..., 1]
        x = self.x0 + (col + 0.5) * self.cs
        z = self.z0 + (row + 0.5) * self.cs
        inside = (row >= 0) & (row < self.shape[0]) & (col >= 0) & (col < self.shape[1])
        y = np.full(np.shape(row), np.nan)
        y[inside] = self.height[row[inside], col[inside]]
        return np.stack([x, y, z], axis=-1)

    def contains(self, rc: np.ndarray) -> np.ndarray:
        rc = np.asarray(rc)
        return (rc[..., 0] >= 0) & (rc[..., 0] < self.shape[0]) & (rc[..., 1] >= 0) & (rc[..., 1] < self.shape[1])


@dataclass
class Packed:
    """All layers flattened for the compiled query kernels (see kernels.py)."""

    meta: np.ndarray       # int64 [L, 5]: r0, c0, rows, cols, offset into the flat arrays
    height: np.ndarray     # float64 [total], NaN where not free
    clearance: np.ndarray  # float64 [total]
    island: np.ndarray     # int64 [total]
    x0: float
    z0: float
    cs: float


def pack(layers: list[NavGrid], x0: float, z0: float, cs: float) -> Packed:
    meta = np.zeros((len(layers), 5), np.int64)
    off = 0
    for k, g in enumerate(layers):
        meta[k] = (g.r0, g.c0, g.shape[0], g.shape[1], off)
        off += g.free.size
    cat = lambda name, dt: (np.concatenate([getattr(g, name).ravel() for g in layers]).astype(dt)
                            if layers else np.zeros(0, dt))
    return Packed(meta, cat("height", np.float64), cat("clearance", np.float64),
                  cat("island", np.int64), float(x0), float(z0), float(cs))

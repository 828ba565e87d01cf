"""Where on a navmesh points are drawn: uniform points of a set of islands, and the shape of each island (what
Habitat's PointNav rule asks of an island, and which floor it is on).

Habitat's episode generator (habitat-lab `pointnav_generator.py`) draws starts and goals anywhere on the navmesh
but rejects a point whose island's radius is under ``ISLAND_RADIUS_LIMIT`` = 1.5 m, the radius being the largest
distance of the island's polygon vertices from their centroid (habitat-sim's `IslandSystem`): a table top or a
bed the navmesh covers, unreachable from the floor, is an island too small to navigate. RVN measures it on cells:
the largest distance (3-D, floor heights) of an island's cell centres from their centroid. `navmesh.islands=all`
applies the rule (`NavMesh.sampled_islands`); ``rvn-scene info`` prints each island's radius and floor height.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


class IslandShapes(NamedTuple):
    radii: list[float]  # m, largest distance of an island's cell centres from their centroid
    heights: list[float]  # m, mean floor height of its cells


def island_shapes(navmesh) -> IslandShapes:
    """Every island's radius and floor height, in island order."""
    centres = []
    for g, off in zip(navmesh.layers, navmesh.offsets):
        rows, cols = np.nonzero(g.island >= 0)
        height = navmesh.packed.height[off + rows * g.shape[1] + cols]
        centres.append(np.stack([g.x0 + (cols + 0.5) * g.cs, height, g.z0 + (rows + 0.5) * g.cs,
                                 g.island[rows, cols]], -1))
    c = np.concatenate(centres)
    radii, heights = [], []
    for i in range(navmesh.num_islands):
        pts = c[c[:, 3] == i, :3]
        radii.append(float(np.sqrt(((pts - pts.mean(0)) ** 2).sum(1).max())) if len(pts) else 0.0)
        heights.append(float(pts[:, 1].mean()) if len(pts) else math.nan)
    return IslandShapes(radii, heights)


def wide_islands(navmesh, min_radius: float) -> list[int]:
    """The islands besides the main one whose radius is at least ``min_radius``: what navmesh.islands=all adds."""
    radii = navmesh.island_shapes.radii
    return [i for i in range(1, navmesh.num_islands) if radii[i] >= min_radius]


def sample_point(navmesh, rng: np.random.Generator, islands: list[int]) -> np.ndarray:
    """A point [3] uniformly distributed over the navigable cells of ``islands`` together: a cell drawn uniformly,
    then a point uniform in it, redrawn while it is off the cell's island (a cell at a clearance edge); after 64
    draws the last cell's centre."""
    for i in islands:
        if not 0 <= i < navmesh.num_islands:
            raise ValueError(f"island={i} out of range: navmesh of {navmesh.scene_id!r} has "
                             f"{navmesh.num_islands} island(s)")
    key = tuple(islands)
    if key not in navmesh._island_cells:
        navmesh._island_cells[key] = np.concatenate(
            [off + np.flatnonzero(np.isin(g.island.ravel(), islands)) for g, off in zip(navmesh.layers, navmesh.offsets)])
    cells, height = navmesh._island_cells[key], navmesh.packed.height
    for _ in range(64):
        f = int(cells[rng.integers(len(cells))])
        k = int(np.searchsorted(navmesh.offsets, f, side="right") - 1)
        g = navmesh.layers[k]
        i, j = divmod(f - int(navmesh.offsets[k]), g.shape[1])
        u = rng.random(2)
        p = np.array([g.x0 + (j + u[0]) * g.cs, height[f], g.z0 + (i + u[1]) * g.cs])
        if navmesh.island_of(p) == g.island[i, j]:
            return p
    return g.grid_to_world(np.array([i, j]))

"""The floors a scene's maps draw a panel each of (rvn-gen's dataset maps, rvn-eval's trace maps).

A navmesh stores a scene's walkable surface as layers: in each column of the scene-wide grid, the lowest surface is in
layer 0, the next above it in layer 1, and so on. A layer is not a floor: on a two-storey house with stairs the
upper floor's cells are in layer 1 where the ground floor lies beneath them and in layer 0 where it does not, and
the floor under the stairs' top steps is a small layer of its own. Nor is an island a floor: stairs join two floors
into one island. So a map finds floors by height: a floor is a height at which at least `FLOOR_AREA` of the sampled
islands' navigable cells lie (within `BIN`; bins within `SAME_FLOOR` of each other are one floor, at their
area-weighted mean height), a point belongs to the floor nearest its height, and a floor's panel shows every layer's
cells within `SAME_FLOOR` of it (`floor_grid`: the lower or upper steps of a flight of stairs with it).
"""
from __future__ import annotations

import numpy as np

from rvn_data.conventions import SAME_FLOOR
from rvn_data.navmesh.grid import NavGrid

FLOOR_AREA = 2.0  # m², the least navigable area at one height that makes a floor (a flight of stairs spreads thinner)
BIN = 0.1  # m, the height bins a floor's area is counted in
MARGIN = 2  # cells around a floor's panel (as the navmesh's layers have)


def floor_heights(navmesh) -> list[float]:
    """The floors of the navmesh's sampled islands (`NavMesh.sampled_islands`), lowest first (m)."""
    P = navmesh.packed
    on = np.isin(P.island, navmesh.sampled_islands)
    heights = P.height[on]
    if heights.size == 0:
        return [0.0]
    binned = np.round(heights / BIN).astype(np.int64)
    bins, counts = np.unique(binned, return_counts=True)
    area = counts * navmesh.settings.cell_size ** 2
    kept = bins[area >= FLOOR_AREA]
    if kept.size == 0:  # no flat part that large: one floor, at the area's mean height
        return [float(heights.mean())]
    floors, group = [], [kept[0]]
    for b in kept[1:]:
        if (b - group[0]) * BIN > SAME_FLOOR:
            floors.append(group)
            group = []
        group.append(b)
    floors.append(group)
    return [float(heights[np.isin(binned, group)].mean()) for group in floors]


def nearest_floor(floors: list[float], y: float) -> float:
    """The height among ``floors`` (`floor_heights`) nearest ``y``."""
    return min(floors, key=lambda h: abs(h - float(y)))


def by_floor(navmesh, points) -> list[tuple[float, list[int]]]:
    """(floor height, indices of ``points``) for each floor holding some of ``points`` (world [3], each on the floor
    nearest its height), lowest first: the panels of a map a floor."""
    floors = floor_heights(navmesh)
    groups: dict[float, list[int]] = {}
    for i, p in enumerate(points):
        groups.setdefault(nearest_floor(floors, p[1]), []).append(i)
    return sorted(groups.items())


def floor_grid(navmesh, y: float) -> NavGrid:
    """The navmesh's walkable cells within `SAME_FLOOR` of height ``y`` from every layer (in a column with several,
    the nearest; other cells no floor, clearance 0), as one layer cropped to them with a margin of `MARGIN` cells (a
    single-floor scene's: its layer's extent)."""
    rows, cols = navmesh.scene_grid_shape
    free = np.zeros((rows, cols), bool)
    height = np.full((rows, cols), np.nan, np.float32)
    clearance = np.zeros((rows, cols), np.float32)
    island = np.full((rows, cols), -1, np.int32)
    gap = np.full((rows, cols), np.inf)
    for g in navmesh.layers:
        view = (slice(g.r0, g.r0 + g.shape[0]), slice(g.c0, g.c0 + g.shape[1]))
        d = np.abs(np.where(g.free, g.height, np.inf) - y)
        take = (d <= SAME_FLOOR) & (d < gap[view])
        gap[view] = np.where(take, d, gap[view])
        for out, src in ((free, g.free), (height, g.height), (clearance, g.clearance), (island, g.island)):
            out[view] = np.where(take, src, out[view])
    rr, cc = np.nonzero(free)
    if rr.size == 0:
        rr, cc = np.array([0, rows - 1]), np.array([0, cols - 1])
    r0, r1 = max(int(rr.min()) - MARGIN, 0), min(int(rr.max()) + 1 + MARGIN, rows)
    c0, c1 = max(int(cc.min()) - MARGIN, 0), min(int(cc.max()) + 1 + MARGIN, cols)
    cs = navmesh.settings.cell_size
    crop = (slice(r0, r1), slice(c0, c1))
    return NavGrid(navmesh.x0 + c0 * cs, navmesh.z0 + r0 * cs, cs, r0, c0, free[crop], height[crop],
                   clearance[crop], island[crop])

"""A* on an inflated occupancy grid (8-connected, compiled with numba) and path pruning.

Moves: 4 straight (cost 1 cell) and 4 diagonal (cost √2, only when both straight
neighbours are free, so a path never cuts an obstacle's corner). Heuristic: octile
distance (admissible and consistent, so the path is a shortest 8-connected path).
Pruning pulls the string: from each kept waypoint, the next one is the farthest later
path cell still in line of sight on the free grid.

Soft clearance (``clearance_pref``, off by default): the inflation margin is a hard limit,
and on top of it each move costs ``1 + clearance_weight * (clearance_pref - c) / clearance_pref``
times its length where the clearance c (metres to the nearest obstacle) is below
``clearance_pref``: the cost-decaying inflation of ROS costmaps. Paths then keep to the
middle of corridors and round corners widely instead of grazing the margin, and pruning
never shortcuts closer to an obstacle than the path it replaces (or ``clearance_pref``).
A discrete-action follower drifts up to d_step·sin(θ_step/2) ≈ 6.5 cm sideways per step, so
paths that graze the margin are the ones that collide (rvn-gen's "collided" rejections).
"""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from rvn_data.planning.occupancy import OccupancyGrid

SQRT2 = math.sqrt(2.0)


@njit(cache=True)
def _octile(r, c, gr, gc):
    dr = abs(r - gr)
    dc = abs(c - gc)
    return max(dr, dc) + (SQRT2 - 1.0) * min(dr, dc)


@njit(cache=True)
def _astar(free, cost, weighted, sr, sc, gr, gc):
    """Cheapest 8-connected path, a move costing its length (times the mean ``cost`` >= 1 of its
    two cells when ``weighted``); returns (cells int64 [K, 2], cost in cells) or ([], inf)."""
    rows, cols = free.shape
    n = rows * cols
    g = np.full(n, np.inf)
    parent = np.full(n, -1, np.int64)
    closed = np.zeros(n, np.bool_)
    start = sr * cols + sc
    goal = gr * cols + gc
    g[start] = 0.0
    heap = [(_octile(sr, sc, gr, gc), start)]
    drs = (-1, 1, 0, 0, -1, -1, 1, 1)
    dcs = (0, 0, -1, 1, -1, 1, -1, 1)
    while len(heap) > 0:
        _, u = heapq.heappop(heap)
        if closed[u]:
            continue
        closed[u] = True
        if u == goal:
            break
        ur = u // cols
        uc = u - ur * cols
        for k in range(8):
            vr = ur + drs[k]
            vc = uc + dcs[k]
            if vr < 0 or vr >= rows or vc < 0 or vc >= cols or not free[vr, vc]:
                continue
            step = 1.0
            if k >= 4:
                if not (free[ur, vc] and free[vr, uc]):
                    continue
                step = SQRT2
            v = vr * cols + vc
            if closed[v]:
                continue
            if weighted:
                step *= 0.5 * (cost[ur, uc] + cost[vr, vc])
            cand = g[u] + step
            if cand < g[v]:
                g[v] = cand
                parent[v] = u
                heapq.heappush(heap, (cand + _octile(vr, vc, gr, gc), v))
    if not closed[goal]:
        return np.zeros((0, 2), np.int64), np.inf
    count = 1
    v = goal
    while v != start:
        v = parent[v]
        count += 1
    out = np.empty((count, 2), np.int64)
    v = goal
    for i in range(count - 1, -1, -1):
        out[i, 0] = v // cols
        out[i, 1] = v - (v // cols) * cols
        v = parent[v]
    return out, g[goal]


@njit(cache=True)
def _line_of_sight(level, thresh, r0, c0, r1, c1):
    """True when every cell the segment between two cell centres touches has ``level >= thresh``."""
    dr = r1 - r0
    dc = c1 - c0
    steps = int(4 * max(abs(dr), abs(dc))) + 1
    for s in range(steps + 1):
        t = s / steps
        r = r0 + 0.5 + t * dr
        c = c0 + 0.5 + t * dc
        # the segment's cells, plus a quarter-cell of slack on each side
        for er in (-0.25, 0.25):
            for ec in (-0.25, 0.25):
                if level[int(math.floor(r + er)), int(math.floor(c + ec))] < thresh:
                    return False
    return True


@njit(cache=True)
def _prune(level, cells, cap):
    """Keep a cell when the segment to the next kept one stays at ``level`` >= the smaller of
    ``cap`` and the lowest level of the path cells it replaces."""
    keep = np.empty(cells.shape[0], np.int64)
    keep[0] = 0
    m = 1
    i = 0
    last = cells.shape[0] - 1
    while i < last:
        j = i + 1
        low = min(level[cells[i, 0], cells[i, 1]], level[cells[j, 0], cells[j, 1]])
        while j + 1 <= last:
            low_next = min(low, level[cells[j + 1, 0], cells[j + 1, 1]])
            if not _line_of_sight(level, min(cap, low_next), cells[i, 0], cells[i, 1], cells[j + 1, 0], cells[j + 1, 1]):
                break
            low = low_next
            j += 1
        keep[m] = j
        m += 1
        i = j
    return cells[keep[:m]]


@dataclass(frozen=True)
class Plan:
    """A planned path: `cells` of the A* path, pruned `waypoints` (world [K, 3], first =
    start, last = goal), `length` (metres along the waypoints) and `grid_length` (metres
    along the 8-connected A* cells)."""

    cells: np.ndarray
    waypoints: np.ndarray
    length: float
    grid_length: float


def astar(free: np.ndarray, start: tuple[int, int], goal: tuple[int, int],
          cost: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """A* from cell `start` to cell `goal` on bool grid `free` → (cells [K, 2], cost in
    cells: the length when ``cost`` is None, else the length weighted by the per-cell factor
    ``cost`` >= 1); ``(empty, inf)`` when no path exists or an end is not free."""
    free = np.ascontiguousarray(free, dtype=np.bool_)
    weighted = cost is not None
    cost = np.ascontiguousarray(cost, dtype=np.float64) if weighted else np.ones((1, 1))
    rows, cols = free.shape
    for r, c in (start, goal):
        if not (0 <= r < rows and 0 <= c < cols and free[r, c]):
            return np.zeros((0, 2), np.int64), math.inf
    return _astar(free, cost, weighted, int(start[0]), int(start[1]), int(goal[0]), int(goal[1]))


def prune_path(free: np.ndarray, cells: np.ndarray, clearance: np.ndarray | None = None,
               clearance_pref: float | None = None) -> np.ndarray:
    """String-pulled subset of `cells` (first and last kept) with line of sight on `free`;
    with ``clearance`` and ``clearance_pref``, a shortcut may not pass closer to an obstacle
    than the path cells it replaces (nor than ``clearance_pref``)."""
    if len(cells) <= 2:
        return np.asarray(cells, np.int64)
    level = np.zeros((free.shape[0] + 2, free.shape[1] + 2), np.float64)
    if clearance is None or clearance_pref is None:
        level[1:-1, 1:-1] = free
        cap = 1.0
    else:
        level[1:-1, 1:-1] = np.where(free, clearance, 0.0)
        cap = float(clearance_pref)
    return _prune(level, np.asarray(cells, np.int64) + 1, cap) - 1


def plan_path(grid: OccupancyGrid, free: np.ndarray, start: np.ndarray, goal: np.ndarray,
              clearance_pref: float | None = None, clearance_weight: float = 0.0) -> Plan | None:
    """Plan from world point `start` to `goal` on the inflated grid `free`; None when
    either end is blocked or no path exists. Waypoints: exact start, pruned cell centres,
    exact goal. ``clearance_pref``/``clearance_weight``: the soft clearance (module docstring)."""
    s = grid.to_cell(start)
    g = grid.to_cell(goal)
    cost = grid.move_cost(clearance_pref, clearance_weight)
    cells, _ = astar(free, (int(s[0]), int(s[1])), (int(g[0]), int(g[1])), cost)
    if len(cells) == 0:
        return None
    length = float(np.linalg.norm(np.diff(cells, axis=0), axis=1).sum())
    pruned = prune_path(free, cells, grid.clearance() if cost is not None else None, clearance_pref)
    pts = grid.to_world(pruned)
    pts[0] = start
    pts[-1] = goal
    pts[:, 1] = grid.floor_height
    polyline = float(np.linalg.norm(np.diff(pts[:, [0, 2]], axis=0), axis=1).sum())
    return Plan(cells=cells, waypoints=pts, length=polyline, grid_length=float(length) * grid.resolution)


def exit_point(grid: OccupancyGrid, free: np.ndarray, start: np.ndarray, reach: float) -> np.ndarray | None:
    """Centre of the free cell nearest to a ``start`` that lies inside the inflation (a pose on
    the navmesh but closer to an obstacle than the margin), at most ``reach`` metres away (keep
    it below a wall's thickness plus both clearances, so it is never behind a wall); None if
    there is none. Ties go to the first cell in row-major order (deterministic)."""
    k = int(math.ceil(reach / grid.resolution))
    r0, c0 = (int(v) for v in grid.to_cell(start))
    rows = np.arange(max(r0 - k, 0), min(r0 + k + 1, free.shape[0]))
    cols = np.arange(max(c0 - k, 0), min(c0 + k + 1, free.shape[1]))
    if rows.size == 0 or cols.size == 0:
        return None
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    centres = grid.to_world(np.stack([rr, cc], axis=-1))
    d = np.hypot(centres[..., 0] - start[0], centres[..., 2] - start[2])
    d[~free[rr, cc]] = np.inf
    best = np.unravel_index(int(np.argmin(d)), d.shape)
    if not d[best] <= reach:
        return None
    out = centres[best].copy()
    out[1] = start[1]
    return out


def append_goal(plan: Plan, goal: np.ndarray) -> Plan:
    """``plan`` (made to an `exit_point` of ``goal``) with the true ``goal`` after it."""
    pts = np.concatenate([plan.waypoints, np.asarray(goal, np.float64)[None]], axis=0)
    pts[-1, 1] = plan.waypoints[-1, 1]
    tail = float(np.hypot(*(pts[-1, [0, 2]] - pts[-2, [0, 2]])))
    return Plan(cells=plan.cells, waypoints=pts, length=plan.length + tail, grid_length=plan.grid_length + tail)


def prepend_start(plan: Plan, start: np.ndarray) -> Plan:
    """``plan`` (made from an `exit_point`) with the true ``start`` in front of it."""
    pts = np.concatenate([np.asarray(start, np.float64)[None], plan.waypoints], axis=0)
    pts[0, 1] = plan.waypoints[0, 1]
    lead = float(np.hypot(*(pts[1, [0, 2]] - pts[0, [0, 2]])))
    return Plan(cells=plan.cells, waypoints=pts, length=plan.length + lead, grid_length=plan.grid_length + lead)

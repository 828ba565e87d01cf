"""`navmesh.profile=habitat`: Recast's build semantics, as habitat-sim bakes a navmesh.

What differs from the `rvn` profile (`build.py`), following recastnavigation's Recast.cpp,
RecastFilter.cpp and RecastArea.cpp with habitat-sim's conversion of its NavMeshSettings:

- the heightfield has Recast's grid: origin at the mesh's bounds minimum, cell height
  `HABITAT_CELL_HEIGHT` (0.2 m), spans snapped down/up with a span at least one voxel tall
  (so a floor surface sits up to 0.2 m above the floor, and obstacles 0.2–0.4 m high can be
  within one voxel of it: climbable);
- climb is `floor(max_climb / ch)` voxels, clearance `ceil(agent_height / ch)`;
- a surface next to a drop of more than the climb, or among neighbours whose heights
  spread more than the climb, is a ledge (`rcFilterLedgeSpans`);
- erosion is `rcErodeWalkableArea` with the radius rounded up to whole cells: a chamfer
  distance (2 per side step, 3 per diagonal) from the cells that miss a connected walkable
  4-neighbour; a cell stays when its distance is at least twice the radius in cells. A cell
  any obstacle piece touches holds no floor surface, so the edge lies `ceil(r / cs)` cells
  from the cells the obstacle touches: 0.20–0.25 m from the geometry for r = 0.18, corners
  cut by the chamfer, gaps narrower than about the rounded diameter closed.

The result is stored as RVN layers: a cell's clearance is the agent radius plus (minus) the
distance from its centre to the edge of Recast's kept cells, so the bilinear clearance
crosses the radius exactly on that edge and the kept cells' area is what islands add up.
Heights are the true floor heights of the pieces that made each surface, not the snapped
voxel tops, so the simulator's agent stands on the floor.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy import ndimage

from rvn_data.navmesh.clip import divide_poly

HABITAT_CELL_HEIGHT = 0.2  # m, habitat-sim's NavMeshSettings.cellHeight
_BIG = 1 << 30
_DR = np.array([0, 1, 0, -1], np.int64)  # +x, +z, -x, -z (surfaces.py's order)
_DC = np.array([1, 0, -1, 0], np.int64)


@njit(cache=True)
def rasterize_recast(verts, faces, walk, bmin, bmax, cs, ch, nx, nz, emit,
                     o_cell, o_smin, o_smax, o_walk, o_box, o_ytop):
    """Recast's `rasterizeTri` (recastnavigation 1.6) in float32 on a grid with one cell of
    margin (cell (r, c) is Recast's (z, x) = (r - 1, c - 1)); counts (emit=False) or writes
    the clipped pieces. Vertices, bounds and cell sizes are float32 as in Recast, so faces on
    cell boundaries fall in the cells Recast puts them in."""
    cs32 = np.float32(cs)
    ics = np.float32(1.0) / cs32
    ich = np.float32(1.0) / np.float32(ch)
    w = nx - 2
    h = nz - 2
    by = bmax[1] - bmin[1]
    inp = np.empty((12, 3), np.float32)
    p1 = np.empty((12, 3), np.float32)
    p2 = np.empty((12, 3), np.float32)
    row = np.empty((12, 3), np.float32)
    count = 0
    for t in range(faces.shape[0]):
        zmin = np.float32(1e30)
        zmax = np.float32(-1e30)
        for a in range(3):
            for c in range(3):
                inp[a, c] = verts[faces[t, a], c]
            zmin = min(zmin, inp[a, 2])
            zmax = max(zmax, inp[a, 2])
        z0 = min(max(int((zmin - bmin[2]) * ics), -1), h - 1)
        z1 = min(max(int((zmax - bmin[2]) * ics), 0), h - 1)
        nin = 3
        for z in range(z0, z1 + 1):
            cz = bmin[2] + np.float32(z) * cs32
            nrow, nin = divide_poly(inp, nin, row, p1, cz + cs32, 2)
            inp, p1 = p1, inp
            if nrow < 3 or z < 0:
                continue
            xmin = row[0, 0]
            xmax = row[0, 0]
            for a in range(1, nrow):
                xmin = min(xmin, row[a, 0])
                xmax = max(xmax, row[a, 0])
            x0 = int((xmin - bmin[0]) * ics)
            x1 = int((xmax - bmin[0]) * ics)
            if x1 < 0 or x0 >= w:
                continue
            x0 = min(max(x0, -1), w - 1)
            x1 = min(max(x1, 0), w - 1)
            nv2 = nrow
            for x in range(x0, x1 + 1):
                cx = bmin[0] + np.float32(x) * cs32
                nv, nv2 = divide_poly(row, nv2, p1, p2, cx + cs32, 0)
                row, p2 = p2, row
                if nv < 3 or x < 0:
                    continue
                ylo, yhi, bx0, bx1, bz0, bz1 = piece_bounds(p1, nv)
                smin = ylo - bmin[1]
                smax = yhi - bmin[1]
                if smax < 0 or smin > by:
                    continue
                smin = max(smin, np.float32(0.0))
                smax = min(smax, by)
                if emit:
                    vmin = int(math.floor(smin * ich))
                    o_cell[count] = (z + 1) * nx + (x + 1)
                    o_smin[count] = vmin
                    o_smax[count] = max(int(math.ceil(smax * ich)), vmin + 1)
                    o_walk[count] = walk[t]
                    o_box[count, 0] = bx0
                    o_box[count, 1] = bx1
                    o_box[count, 2] = bz0
                    o_box[count, 3] = bz1
                    o_ytop[count] = yhi
                count += 1
    return count


@njit(cache=True)
def piece_bounds(p, nv):
    """(y min, y max, x min, x max, z min, z max) of the first ``nv`` vertices of polygon ``p``."""
    ylo = p[0, 1]
    yhi = p[0, 1]
    bx0 = p[0, 0]
    bx1 = p[0, 0]
    bz0 = p[0, 2]
    bz1 = p[0, 2]
    for a in range(1, nv):
        ylo = min(ylo, p[a, 1])
        yhi = max(yhi, p[a, 1])
        bx0 = min(bx0, p[a, 0])
        bx1 = max(bx1, p[a, 0])
        bz0 = min(bz0, p[a, 2])
        bz1 = max(bz1, p[a, 2])
    return ylo, yhi, bx0, bx1, bz0, bz1


def recast_voxels(st) -> tuple[int, int]:
    """(climb, clearance) in voxels of `HABITAT_CELL_HEIGHT`, as habitat-sim converts them."""
    ch = HABITAT_CELL_HEIGHT
    return int(math.floor(st.max_climb / ch + 1e-6)), int(math.ceil(st.agent_height / ch - 1e-6))


@njit(cache=True)
def ledge_surfaces(start, smin, smax, span, cell, nx, nz, climb, hcells):
    """Recast's ledge filter per surface: True where a 4-neighbour column drops more than
    `climb` below it (or has no floor within reach), or where the reachable neighbour floors
    spread more than `climb`."""
    n = span.shape[0]
    out = np.zeros(n, np.bool_)
    for s in range(n):
        k = span[s]
        c = cell[s]
        bot = smax[k]
        top = smin[k + 1] if k + 1 < start[c + 1] else _BIG
        r = c // nx
        col = c % nx
        minh = _BIG
        asmin = bot
        asmax = bot
        for d in range(4):
            rr = r + _DR[d]
            cc = col + _DC[d]
            if rr < 0 or rr >= nz or cc < 0 or cc >= nx:
                minh = min(minh, -climb - bot)
                continue
            nc = rr * nx + cc
            # from minus infinity to the first span
            nbot = -climb
            ntop = smin[start[nc]] if start[nc] < start[nc + 1] else _BIG
            if min(top, ntop) - max(bot, nbot) > hcells:
                minh = min(minh, nbot - bot)
            for q in range(start[nc], start[nc + 1]):
                nbot = smax[q]
                ntop = smin[q + 1] if q + 1 < start[nc + 1] else _BIG
                if min(top, ntop) - max(bot, nbot) > hcells:
                    minh = min(minh, nbot - bot)
                    if abs(nbot - bot) <= climb:
                        asmin = min(asmin, nbot)
                        asmax = max(asmax, nbot)
        if minh < -climb or asmax - asmin > climb:
            out[s] = True
    return out


@njit(cache=True)
def surface_heights(span, cell, smax, rstart, rmax, rwalk, rytop, y0, ch):
    """True floor height (m) of each surface: the highest top of the walkable pieces whose
    voxel top is the span's top (of any piece there when none is walkable)."""
    n = span.shape[0]
    out = np.empty(n)
    for s in range(n):
        c = cell[s]
        top = smax[span[s]]
        best = -1e30
        anyp = -1e30
        for q in range(rstart[c], rstart[c + 1]):
            if rmax[q] == top:
                anyp = max(anyp, rytop[q])
                if rwalk[q]:
                    best = max(best, rytop[q])
        out[s] = best if best > -1e29 else (anyp if anyp > -1e29 else y0 + top * ch)
    return out


@njit(cache=True)
def _chamfer_step(dist, conn, i, j, d, e):
    """Recast's chamfer update from the side neighbour in direction d (+2) and from that
    neighbour's neighbour in direction e (+3, the diagonal), through connected cells only."""
    if conn[i, j, d]:
        ai = i + _DR[d]
        aj = j + _DC[d]
        dist[i, j] = min(dist[i, j], dist[ai, aj] + 2)
        if conn[ai, aj, e]:
            dist[i, j] = min(dist[i, j], dist[ai + _DR[e], aj + _DC[e]] + 3)


@njit(cache=True)
def chamfer_erode(lsurf, walk, nbr, radius_cells):
    """Recast's `rcErodeWalkableArea` on one layer: kept cells (bool [rows, cols]).

    `walk[i, j]`: the layer's surface there is walkable (not a ledge); two cells are connected
    when the surface of one is linked (`nbr`) to the surface in the other."""
    rows, cols = lsurf.shape
    dist = np.full((rows, cols), 255, np.int64)
    conn = np.zeros((rows, cols, 4), np.bool_)
    for i in range(rows):
        for j in range(cols):
            s = lsurf[i, j]
            if s < 0 or not walk[i, j]:
                continue
            nc = 0
            for d in range(4):
                ii = i + _DR[d]
                jj = j + _DC[d]
                if 0 <= ii < rows and 0 <= jj < cols and lsurf[ii, jj] >= 0 and walk[ii, jj] \
                        and nbr[s, d] == lsurf[ii, jj]:
                    conn[i, j, d] = True
                    nc += 1
            if nc < 4:
                dist[i, j] = 0
    # pass 1 from -x and -z (their -z / +x diagonals), pass 2 from +x and +z (their +z / -x diagonals)
    for i in range(rows):
        for j in range(cols):
            if lsurf[i, j] >= 0 and walk[i, j]:
                _chamfer_step(dist, conn, i, j, 2, 3)
                _chamfer_step(dist, conn, i, j, 3, 0)
    for i in range(rows - 1, -1, -1):
        for j in range(cols - 1, -1, -1):
            if lsurf[i, j] >= 0 and walk[i, j]:
                _chamfer_step(dist, conn, i, j, 0, 1)
                _chamfer_step(dist, conn, i, j, 1, 2)
    keep = np.zeros((rows, cols), np.bool_)
    for i in range(rows):
        for j in range(cols):
            if lsurf[i, j] >= 0 and walk[i, j] and min(dist[i, j], 255) >= 2 * radius_cells:
                keep[i, j] = True
    return keep


def clearance_from_kept(keep: np.ndarray, r: float, cs: float) -> np.ndarray:
    """Clearance (m) whose bilinear interpolation crosses `r` on the edge of the kept cells:
    r + (distance to the nearest other cell centre - cs/2) inside, r - (...) outside, >= 0."""
    if not keep.any():
        return np.zeros(keep.shape)
    inside = ndimage.distance_transform_edt(keep) if (~keep).any() else np.full(keep.shape, 1e3)
    outside = ndimage.distance_transform_edt(~keep)
    return np.where(keep, r + (inside - 0.5) * cs, np.maximum(r - (outside - 0.5) * cs, 0.0))


def recast_layer(lsurf: np.ndarray, ledge: np.ndarray, nbr: np.ndarray, st) -> np.ndarray:
    """Clearance of one layer under the habitat profile."""
    walk = np.where(lsurf >= 0, ~ledge[np.maximum(lsurf, 0)], False)
    radius_cells = int(math.ceil(st.agent_radius / st.cell_size - 1e-6))
    keep = chamfer_erode(lsurf, walk, nbr, radius_cells)
    return clearance_from_kept(keep, st.agent_radius, st.cell_size)

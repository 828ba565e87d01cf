"""Walkable surfaces, their links, regions (2-D layers) and obstacle boxes (Recast steps 3-5).

A *surface* is the top of a walkable span with at least `agent_height` of free space above
it. Two surfaces in 4-neighbouring cells are *linked* when their heights differ by at most
`max_climb` and the free gap they share is at least `agent_height`. A *region* is a linked
flood fill that never holds two surfaces of the same cell, so it is a 2-D layer; surfaces
skipped because their cell was taken start a new region and touch the first at a *seam*.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

_DR = np.array([0, 1, 0, -1], np.int64)
_DC = np.array([1, 0, -1, 0], np.int64)
_BIG = 1 << 30


@njit(cache=True)
def find_surfaces(start, smin, smax, walk, hcells):
    """Walkable span tops with clearance >= hcells voxels: (span, cell, height, ceiling) and
    a per-cell CSR `sstart` over the surfaces."""
    ncells = start.shape[0] - 1
    n = 0
    for c in range(ncells):
        for k in range(start[c], start[c + 1]):
            ceil = smin[k + 1] if k + 1 < start[c + 1] else _BIG
            if walk[k] and ceil - smax[k] >= hcells:
                n += 1
    span = np.empty(n, np.int64)
    cell = np.empty(n, np.int64)
    height = np.empty(n, np.int64)
    ceiling = np.empty(n, np.int64)
    sstart = np.zeros(ncells + 1, np.int64)
    m = 0
    for c in range(ncells):
        sstart[c] = m
        for k in range(start[c], start[c + 1]):
            ceil = smin[k + 1] if k + 1 < start[c + 1] else _BIG
            if walk[k] and ceil - smax[k] >= hcells:
                span[m] = k
                cell[m] = c
                height[m] = smax[k]
                ceiling[m] = ceil
                m += 1
    sstart[ncells] = m
    return span, cell, height, ceiling, sstart


@njit(cache=True)
def link_surfaces(cell, height, ceiling, sstart, nx, nz, climb, hcells):
    """nbr[s, d]: the surface linked to s in direction d (+x, +z, -x, -z), or -1."""
    n = cell.shape[0]
    nbr = np.full((n, 4), -1, np.int64)
    for s in range(n):
        r = cell[s] // nx
        c = cell[s] % nx
        for d in range(4):
            rr = r + _DR[d]
            cc = c + _DC[d]
            if rr < 0 or rr >= nz or cc < 0 or cc >= nx:
                continue
            nc = rr * nx + cc
            best = -1
            bestdh = _BIG
            for t in range(sstart[nc], sstart[nc + 1]):
                dh = abs(height[t] - height[s])
                gap = min(ceiling[s], ceiling[t]) - max(height[s], height[t])
                if dh <= climb and gap >= hcells and dh < bestdh:
                    best = t
                    bestdh = dh
            nbr[s, d] = best
    return nbr


@njit(cache=True)
def build_regions(cell, nbr, ncells):
    """Flood-fill regions over links with at most one surface per cell; returns region id per
    surface, the number of regions, and seam pairs (s, t) linked across regions."""
    n = cell.shape[0]
    region = np.full(n, -1, np.int64)
    stamp = np.full(ncells, -1, np.int64)
    queue = np.empty(n, np.int64)
    nreg = 0
    for s0 in range(n):
        if region[s0] >= 0:
            continue
        rid = nreg
        nreg += 1
        region[s0] = rid
        stamp[cell[s0]] = rid
        head = 0
        tail = 1
        queue[0] = s0
        while head < tail:
            s = queue[head]
            head += 1
            for d in range(4):
                t = nbr[s, d]
                if t >= 0 and region[t] < 0 and stamp[cell[t]] != rid:
                    region[t] = rid
                    stamp[cell[t]] = rid
                    queue[tail] = t
                    tail += 1
    nseam = 0
    for s in range(n):
        for d in range(2):
            t = nbr[s, d]
            if t >= 0 and region[t] != region[s]:
                nseam += 1
    seams = np.empty((nseam, 2), np.int64)
    k = 0
    for s in range(n):
        for d in range(2):
            t = nbr[s, d]
            if t >= 0 and region[t] != region[s]:
                seams[k, 0] = s
                seams[k, 1] = t
                k += 1
    return region, nreg, seams


@njit(cache=True)
def obstacle_boxes(r0, c0, lsurf, href, nx, rstart, rmin, rmax, rwalk, rbox, nbr,
                   climb, hcells, x0, z0, cs):
    """x/z box [nzl, nxl, 4] of the obstacle in each cell of a layer (NaN: none).

    The obstacle of a cell is the geometry within the height band (href + climb,
    href + agent_height) of the layer's floor there: the box of the non-walkable pieces
    clipped into the cell that reach into the band (of the walkable ones when there are no
    others: the top of a step too high to climb), whatever spans they merged into, so a lintel
    above the band does not widen a jamb's box to the whole cell. A cell without a surface of the layer
    and without such geometry (a drop, an unlinked surface) is blocked entirely. Second
    output: for a free cell whose 4-neighbour holds a surface of the layer while no surface
    there is linked to it, the box of the shared edge(s) (see `edge_clearance`); a neighbour
    linked across a seam is no obstacle."""
    nzl, nxl = lsurf.shape
    out = np.full((nzl, nxl, 4), np.nan, np.float32)
    edge = np.full((nzl, nxl, 4), np.nan, np.float32)
    for i in range(nzl):
        for j in range(nxl):
            c = (r0 + i) * nx + (c0 + j)
            h = href[i, j]
            bx0 = 1e30
            bx1 = -1e30
            bz0 = 1e30
            bz1 = -1e30
            found = False
            solid = False  # a non-walkable piece in the band: walkable pieces no longer count
            for k in range(rstart[c], rstart[c + 1]):
                if rmax[k] > h + climb and rmin[k] < h + hcells:
                    if not rwalk[k] and not solid:
                        solid = True
                        bx0 = 1e30
                        bx1 = -1e30
                        bz0 = 1e30
                        bz1 = -1e30
                    elif rwalk[k] and solid:
                        continue
                    b = rbox[k]
                    bx0 = min(bx0, b[0])
                    bx1 = max(bx1, b[1])
                    bz0 = min(bz0, b[2])
                    bz1 = max(bz1, b[3])
                    found = True
            cx0 = x0 + (c0 + j) * cs
            cz0 = z0 + (r0 + i) * cs
            s = lsurf[i, j]
            if s < 0 and not found:
                bx0, bx1, bz0, bz1 = cx0, cx0 + cs, cz0, cz0 + cs
                found = True
            elif s >= 0:
                ex0 = 1e30
                ex1 = -1e30
                ez0 = 1e30
                ez1 = -1e30
                for d in range(4):
                    ii = i + _DR[d]
                    jj = j + _DC[d]
                    if ii < 0 or ii >= nzl or jj < 0 or jj >= nxl:
                        continue
                    t = lsurf[ii, jj]
                    if t >= 0 and nbr[s, d] < 0:  # occupied by a surface not linked to s
                        ex0 = min(ex0, cx0 + cs if d == 0 else cx0)
                        ex1 = max(ex1, cx0 if d == 2 else cx0 + cs)
                        ez0 = min(ez0, cz0 + cs if d == 1 else cz0)
                        ez1 = max(ez1, cz0 if d == 3 else cz0 + cs)
                if ex0 < 1e29:
                    edge[i, j, 0] = ex0
                    edge[i, j, 1] = ex1
                    edge[i, j, 2] = ez0
                    edge[i, j, 3] = ez1
            if found:
                out[i, j, 0] = bx0
                out[i, j, 1] = bx1
                out[i, j, 2] = bz0
                out[i, j, 3] = bz1
    return out, edge


@njit(cache=True)
def edge_clearance(edge, lsurf, height, xc, zc, window, hcells):
    """Distance (m) from each cell centre to the edge boxes within `window` cells that belong
    to surfaces less than agent_height (hcells voxels) above or below the cell's surface, so
    an edge on an upper floor does not erode the floor under it (inf if none)."""
    nzl, nxl = lsurf.shape
    out = np.full((nzl, nxl), np.inf)
    for i in range(nzl):
        for j in range(nxl):
            if np.isnan(edge[i, j, 0]):
                continue
            he = height[lsurf[i, j]]
            for ii in range(max(i - window, 0), min(i + window + 1, nzl)):
                for jj in range(max(j - window, 0), min(j + window + 1, nxl)):
                    t = lsurf[ii, jj]
                    if t >= 0 and abs(height[t] - he) >= hcells:
                        continue
                    dx = max(edge[i, j, 0] - xc[jj], xc[jj] - edge[i, j, 1], 0.0)
                    dz = max(edge[i, j, 2] - zc[ii], zc[ii] - edge[i, j, 3], 0.0)
                    d = math.sqrt(dx * dx + dz * dz)
                    if d < out[ii, jj]:
                        out[ii, jj] = d
    return out


@njit(cache=True)
def portal_surfaces(seeds, region, rid, nbr, depth):
    """Surfaces outside region `rid` within `depth` link steps of the seed surfaces (BFS over
    links, not entering `rid`): the other side of a seam, drawn into the layer so that
    erosion does not see the seam as an edge."""
    n = region.shape[0]
    dist = np.full(n, -1, np.int64)
    queue = np.empty(n, np.int64)
    tail = 0
    for s in seeds:
        if dist[s] < 0 and region[s] != rid:
            dist[s] = 0
            queue[tail] = s
            tail += 1
    head = 0
    while head < tail:
        s = queue[head]
        head += 1
        if dist[s] >= depth:
            continue
        for d in range(4):
            t = nbr[s, d]
            if t >= 0 and dist[t] < 0 and region[t] != rid:
                dist[t] = dist[s] + 1
                queue[tail] = t
                tail += 1
    return queue[:tail].copy()


def voxels(value: float, ch: float, up: bool) -> int:
    """A height in voxels, rounded up (clearances) or down (climb)."""
    v = value / ch
    return int(math.ceil(v - 1e-4)) if up else int(math.floor(v + 1e-4))

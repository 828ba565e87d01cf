"""Conservative rasterisation of a triangle mesh into a span heightfield (Recast step 1-3).

Every triangle is clipped against each grid cell it overlaps (Recast's `dividePoly`), so
a 3 cm pillar or a thin table leg marks every cell it touches. A cell keeps a sorted list
of solid spans [smin, smax] (in `cell_height` voxels above `y0`); overlapping spans merge
with Recast's rule (the span whose top is highest decides walkability, walkable wins when
the tops are within `max_climb`). The clipped pieces themselves are kept too, per cell: their
height range, walkability and x/z bounding box (sub-cell obstacle position, used by erosion:
only the pieces within the band an agent's body occupies count, so a lintel above a doorway
does not block the floor cell beside the jamb that its span merged with).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from rvn_data.navmesh.clip import divide_poly
from rvn_data.navmesh.recast_profile import piece_bounds, rasterize_recast



@njit(cache=True)
def _grown(a):
    """``a`` copied into an array of twice its rows."""
    out = np.empty((2 * a.shape[0],) + a.shape[1:], a.dtype)
    out[:a.shape[0]] = a
    return out


@njit(cache=True)
def _rasterize(verts, faces, walk, x0, z0, cs, nx, nz, y0, ch, capacity):
    """Clip every triangle to the cells it overlaps: its records (cell, smin, smax, walk, x/z box, top y) in one
    pass, into arrays of ``capacity`` rows grown as needed."""
    o_cell = np.empty(capacity, np.int64)
    o_smin = np.empty(capacity, np.int32)
    o_smax = np.empty(capacity, np.int32)
    o_walk = np.empty(capacity, np.bool_)
    o_box = np.empty((capacity, 4), np.float32)
    o_ytop = np.empty(capacity, np.float32)
    rest = np.empty((12, 3))
    rest2 = np.empty((12, 3))
    row = np.empty((12, 3))
    rrest = np.empty((12, 3))
    rrest2 = np.empty((12, 3))
    cell = np.empty((12, 3))
    count = 0
    for t in range(faces.shape[0]):
        zmin = 1e30
        zmax = -1e30
        for a in range(3):
            for c in range(3):
                rest[a, c] = verts[faces[t, a], c]
            zmin = min(zmin, rest[a, 2])
            zmax = max(zmax, rest[a, 2])
        r0 = max(int(math.floor((zmin - z0) / cs)), 0)
        r1 = min(int(math.floor((zmax - z0) / cs)), nz - 1)
        nrest = 3
        for r in range(r0, r1 + 1):
            nrow, nr2 = divide_poly(rest, nrest, row, rest2, z0 + (r + 1) * cs, 2)
            rest, rest2 = rest2, rest
            nrest = nr2
            if nrow < 3:
                if nrest < 3:
                    break
                continue
            xmin = 1e30
            xmax = -1e30
            for a in range(nrow):
                xmin = min(xmin, row[a, 0])
                xmax = max(xmax, row[a, 0])
            c0 = max(int(math.floor((xmin - x0) / cs)), 0)
            c1 = min(int(math.floor((xmax - x0) / cs)), nx - 1)
            for a in range(nrow):
                rrest[a, :] = row[a, :]
            nrr = nrow
            for col in range(c0, c1 + 1):
                ncell, nrr2 = divide_poly(rrest, nrr, cell, rrest2, x0 + (col + 1) * cs, 0)
                rrest, rrest2 = rrest2, rrest
                nrr = nrr2
                if ncell < 3:
                    if nrr < 3:
                        break
                    continue
                if count == o_cell.shape[0]:
                    o_cell, o_smin, o_smax = _grown(o_cell), _grown(o_smin), _grown(o_smax)
                    o_walk, o_box, o_ytop = _grown(o_walk), _grown(o_box), _grown(o_ytop)
                ylo, yhi, bx0, bx1, bz0, bz1 = piece_bounds(cell, ncell)
                smin = int(math.floor((ylo - y0) / ch + 1e-4))
                smax = max(int(math.ceil((yhi - y0) / ch - 1e-4)), smin)
                o_cell[count] = r * nx + col
                o_smin[count] = smin
                o_smax[count] = smax
                o_ytop[count] = yhi
                o_walk[count] = walk[t]
                o_box[count, 0] = bx0
                o_box[count, 1] = bx1
                o_box[count, 2] = bz0
                o_box[count, 3] = bz1
                count += 1
    return o_cell[:count], o_smin[:count], o_smax[:count], o_walk[:count], o_box[:count], o_ytop[:count]


@njit(cache=True)
def _merge(cell, smin, smax, walk, ncells, climb):
    """Merge sorted records into spans per cell; then Recast's low-hanging-obstacle filter."""
    n = cell.shape[0]
    start = np.zeros(ncells + 1, np.int64)
    s_min = np.empty(n, np.int32)
    s_max = np.empty(n, np.int32)
    s_walk = np.empty(n, np.bool_)
    m = -1
    prev_cell = -1
    for i in range(n):
        c = cell[i]
        if c != prev_cell or smin[i] > s_max[m]:
            m += 1
            s_min[m] = smin[i]
            s_max[m] = smax[i]
            s_walk[m] = walk[i]
            if c != prev_cell:
                for cc in range(prev_cell + 1, c + 1):
                    start[cc] = m
                prev_cell = c
            continue
        if abs(smax[i] - s_max[m]) <= climb:
            s_walk[m] = s_walk[m] or walk[i]
        elif smax[i] > s_max[m]:
            s_walk[m] = walk[i]
        s_max[m] = max(s_max[m], smax[i])
    m += 1
    for cc in range(prev_cell + 1, ncells + 1):
        start[cc] = m
    # Low-hanging obstacles: a non-walkable span whose top is within climb of the walkable
    # span below it becomes walkable (curbs, stair nosings).
    for c in range(ncells):
        prev_walk = False
        prev_top = 0
        for k in range(start[c], start[c + 1]):
            w = s_walk[k]
            if not w and prev_walk and s_max[k] - prev_top <= climb:
                s_walk[k] = True
            prev_walk = w
            prev_top = s_max[k]
    return start, s_min[:m].copy(), s_max[:m].copy(), s_walk[:m].copy()


@dataclass
class Heightfield:
    """Solid spans per grid cell. Cell (row, col) covers x in [x0 + col·cs, x0 + (col+1)·cs),
    z in [z0 + row·cs, ...); span heights are voxels: y = y0 + v·ch."""

    x0: float
    z0: float
    y0: float
    cs: float
    ch: float
    nx: int
    nz: int
    start: np.ndarray  # int64 [nz*nx + 1], spans of cell c are start[c]:start[c+1]
    smin: np.ndarray   # int32 [S]
    smax: np.ndarray   # int32 [S]
    walk: np.ndarray   # bool [S]
    rstart: np.ndarray  # int64 [nz*nx + 1], clipped pieces of cell c are rstart[c]:rstart[c+1]
    rmin: np.ndarray    # int32 [P] voxel range of each piece
    rmax: np.ndarray    # int32 [P]
    rwalk: np.ndarray   # bool [P] walkable (upward, not too steep)
    rbox: np.ndarray    # float32 [P, 4] x/z bbox of the piece (x0, x1, z0, z1)
    rytop: np.ndarray   # float32 [P] highest y of the piece (m)


def rasterize(vertices: np.ndarray, faces: np.ndarray, cs: float, ch: float,
              max_slope_deg: float, climb: int, recast: bool = False) -> Heightfield:
    """Rasterise a triangle soup (y up) conservatively into a span heightfield; `climb` (voxels)
    is the merge and low-hanging-obstacle threshold. `recast`:
    Recast's grid (origin at the bounds minimum, one cell of margin) and span snapping."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    norm = np.linalg.norm(n, axis=1)
    walk = n[:, 1] > math.cos(math.radians(max_slope_deg)) * np.maximum(norm, 1e-30)
    if recast:  # Recast's grid: origin at the float32 bounds minimum, width (bmax - bmin)/cs + 0.5
        v32 = v.astype(np.float32)
        lo32, hi32 = v32.min(0), v32.max(0)
        x0, z0, y0 = float(lo32[0]) - cs, float(lo32[2]) - cs, float(lo32[1])
        nx = int((hi32[0] - lo32[0]) / np.float32(cs) + np.float32(0.5)) + 2
        nz = int((hi32[2] - lo32[2]) / np.float32(cs) + np.float32(0.5)) + 2
        arrays = lambda n: (np.empty(n, np.int64), np.empty(n, np.int32), np.empty(n, np.int32),  # noqa: E731
                            np.empty(n, np.bool_), np.empty((n, 4), np.float32), np.empty(n, np.float32))
        records = arrays(rasterize_recast(v32, f, walk, lo32, hi32, cs, ch, nx, nz, False, *arrays(0)))  # count,
        rasterize_recast(v32, f, walk, lo32, hi32, cs, ch, nx, nz, True, *records)  # then write
    else:
        lo, hi = v.min(0), v.max(0)
        x0 = math.floor(lo[0] / cs) * cs - cs
        z0 = math.floor(lo[2] / cs) * cs - cs
        y0 = math.floor(lo[1] / ch) * ch - ch
        nx = int(math.ceil((hi[0] - x0) / cs)) + 2
        nz = int(math.ceil((hi[2] - z0) / cs)) + 2
        records = _rasterize(v, f, walk, x0, z0, cs, nx, nz, y0, ch, 4 * len(f) + 1024)
    o_cell, o_smin, o_smax, o_walk, o_box, o_ytop = records
    order = np.lexsort((o_smax, o_smin, o_cell))
    o_cell, o_smin, o_smax, o_walk, o_box, o_ytop = (
        a[order] for a in (o_cell, o_smin, o_smax, o_walk, o_box, o_ytop))
    start, smin, smax, swalk = _merge(o_cell, o_smin, o_smax, o_walk, nx * nz, climb)
    rstart = np.searchsorted(o_cell, np.arange(nx * nz + 1, dtype=np.int64)).astype(np.int64)
    return Heightfield(x0, z0, y0, cs, ch, nx, nz, start, smin, smax, swalk, rstart, o_smin, o_smax,
                       o_walk, o_box, o_ytop)

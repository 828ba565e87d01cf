"""Compiled point queries on the packed layers (see grid.Packed): locate, clearance,
navigability, marching along a segment, distance-field lookups and string pulling.

`meta[k] = (r0, c0, rows, cols, offset)` of layer k in the scene grid with origin
(x0, z0) and cell size cs. Clearance between cell centres is bilinear, so an obstacle face
is located to sub-cell accuracy. A point is navigable when it lies over a free cell of a
layer whose floor is within `tol` of its y, its clearance is >= r and it is on an island.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def locate(meta, height, x0, z0, cs, x, y, z, tol):
    """(layer, flat index) of the free cell under (x, z) whose floor is nearest to y within
    tol, or (-1, -1)."""
    gc = int(math.floor((x - x0) / cs))
    gr = int(math.floor((z - z0) / cs))
    best = -1
    bflat = -1
    bdh = tol
    for k in range(meta.shape[0]):
        i = gr - meta[k, 0]
        j = gc - meta[k, 1]
        if i < 0 or j < 0 or i >= meta[k, 2] or j >= meta[k, 3]:
            continue
        f = meta[k, 4] + i * meta[k, 3] + j
        h = height[f]
        if not np.isnan(h):
            dh = abs(h - y)
            if dh <= bdh:
                bdh = dh
                best = k
                bflat = f
    return best, bflat


@njit(cache=True)
def clearance_at(meta, clearance, x0, z0, cs, k, x, z):
    """Bilinear clearance of layer k at (x, z); cells outside the layer count as 0."""
    u = (x - x0) / cs - 0.5 - meta[k, 1]
    v = (z - z0) / cs - 0.5 - meta[k, 0]
    j = int(math.floor(u))
    i = int(math.floor(v))
    fu = u - j
    fv = v - i
    acc = 0.0
    for di in range(2):
        for dj in range(2):
            ii = i + di
            jj = j + dj
            w = (fv if di else 1.0 - fv) * (fu if dj else 1.0 - fu)
            if w == 0.0:
                continue
            if ii < 0 or jj < 0 or ii >= meta[k, 2] or jj >= meta[k, 3]:
                continue
            acc += w * clearance[meta[k, 4] + ii * meta[k, 3] + jj]
    return acc


@njit(cache=True)
def nav_point(meta, height, clearance, island, x0, z0, cs, x, y, z, tol, r):
    """(island or -1, layer, floor y) of a point; island -1 means not navigable."""
    k, f = locate(meta, height, x0, z0, cs, x, y, z, tol)
    if k < 0:
        return -1, -1, y
    h = height[f]
    isl = island[f]
    if isl < 0:  # border cell: take a navigable neighbour's island
        i = (f - meta[k, 4]) // meta[k, 3]
        j = (f - meta[k, 4]) % meta[k, 3]
        for di in range(-1, 2):
            for dj in range(-1, 2):
                ii = i + di
                jj = j + dj
                if 0 <= ii < meta[k, 2] and 0 <= jj < meta[k, 3]:
                    g = island[meta[k, 4] + ii * meta[k, 3] + jj]
                    if g >= 0:
                        isl = g
        if isl < 0:
            return -1, k, h
    if clearance_at(meta, clearance, x0, z0, cs, k, x, z) < r - 1e-9:
        return -1, k, h
    return isl, k, h


@njit(cache=True)
def march(meta, height, clearance, island, x0, z0, cs, x, y, z, dx, dz, length, r, tol, step):
    """Walk from (x, y, z) along the unit direction (dx, dz) for `length` metres; stop at the
    last navigable point on the start's island (bisection to ~1e-6 m). Returns (t, y)."""
    isl0, k, h = nav_point(meta, height, clearance, island, x0, z0, cs, x, y, z, tol, r)
    if isl0 < 0:
        return 0.0, y
    ycur = h
    tprev = 0.0
    n = int(math.ceil(length / step))
    for s in range(1, n + 1):
        t = min(s * step, length)
        isl, k, h = nav_point(meta, height, clearance, island, x0, z0, cs,
                              x + dx * t, ycur, z + dz * t, tol, r)
        if isl == isl0:
            tprev = t
            ycur = h
            continue
        lo = tprev
        hi = t
        for _ in range(14):
            mid = 0.5 * (lo + hi)
            isl, k, h = nav_point(meta, height, clearance, island, x0, z0, cs,
                                  x + dx * mid, ycur, z + dz * mid, tol, r)
            if isl == isl0:
                lo = mid
                ycur = h
            else:
                hi = mid
        return lo, ycur
    return length, ycur


@njit(cache=True)
def clearance_gradient(meta, height, clearance, x0, z0, cs, x, y, z, tol):
    """Gradient (d/dx, d/dz) of the clearance at a point (zero if off the mesh)."""
    k, f = locate(meta, height, x0, z0, cs, x, y, z, tol)
    if k < 0:
        return 0.0, 0.0
    e = 0.25 * cs
    gx = clearance_at(meta, clearance, x0, z0, cs, k, x + e, z) - clearance_at(meta, clearance, x0, z0, cs, k, x - e, z)
    gz = clearance_at(meta, clearance, x0, z0, cs, k, x, z + e) - clearance_at(meta, clearance, x0, z0, cs, k, x, z - e)
    return gx / (2 * e), gz / (2 * e)


@njit(cache=True)
def lookup_cells(meta, height, x0, z0, cs, x, y, z, tol):
    """Where `field_lookup` reads around a point: its layer k (-1 off the mesh, then nothing else
    counts), the cell f it lies in, its fractional grid coordinates (u, v), the bilinear 2x2's first
    cell (i0, j0) and its own cell (i, j)."""
    k, f = locate(meta, height, x0, z0, cs, x, y, z, tol)
    if k < 0:
        return k, f, 0.0, 0.0, 0, 0, 0, 0
    u = (z - z0) / cs - 0.5 - meta[k, 0]
    v = (x - x0) / cs - 0.5 - meta[k, 1]
    return k, f, u, v, int(math.floor(u)), int(math.floor(v)), (f - meta[k, 4]) // meta[k, 3], (f - meta[k, 4]) % meta[k, 3]


@njit(cache=True)
def field_lookup(meta, height, x0, z0, cs, node_of, field, pts, tol):
    """Geodesic distance at points [N, 3]: bilinear in the field of the 4 cell centres around
    a point when all are reachable, else min over the 3x3 reachable cells of
    field[cell] + |point - cell centre| (inf if none)."""
    out = np.full(pts.shape[0], np.inf)
    for n in range(pts.shape[0]):
        x, y, z = pts[n, 0], pts[n, 1], pts[n, 2]
        k, f, u, v, i0, j0, i, j = lookup_cells(meta, height, x0, z0, cs, x, y, z, tol)
        if k < 0:
            continue
        rows, cols, off = meta[k, 2], meta[k, 3], meta[k, 4]
        acc = 0.0
        for di in range(2):
            for dj in range(2):
                ii = i0 + di
                jj = j0 + dj
                w = (u - i0 if di else 1.0 - (u - i0)) * (v - j0 if dj else 1.0 - (v - j0))
                if ii < 0 or jj < 0 or ii >= rows or jj >= cols:
                    acc = np.inf
                    continue
                node = node_of[off + ii * cols + jj]
                acc += w * field[node] if node >= 0 else np.inf
        if np.isfinite(acc):
            out[n] = acc
            continue
        best = np.inf
        for di in range(-1, 2):
            for dj in range(-1, 2):
                ii = i + di
                jj = j + dj
                if ii < 0 or jj < 0 or ii >= rows or jj >= cols:
                    continue
                g = off + ii * cols + jj
                node = node_of[g]
                if node < 0 or not np.isfinite(field[node]):
                    continue
                cx = x0 + (meta[k, 1] + jj + 0.5) * cs
                cz = z0 + (meta[k, 0] + ii + 0.5) * cs
                d = field[node] + math.sqrt((cx - x) ** 2 + (cz - z) ** 2 + (height[g] - y) ** 2)
                best = min(best, d)
        out[n] = best
    return out


@njit(cache=True)
def field_support(meta, height, x0, z0, cs, node_of, pts, tol):
    """The graph nodes `field_lookup` may read for points [N, 3] (int64 [N, 13], -1 where none):
    the 4 cells of its bilinear lookup and the 3x3 cells around the point's cell."""
    out = np.full((pts.shape[0], 13), -1, np.int64)
    for n in range(pts.shape[0]):
        k, _, _, _, i0, j0, i, j = lookup_cells(meta, height, x0, z0, cs, pts[n, 0], pts[n, 1], pts[n, 2], tol)
        if k < 0:
            continue
        rows, cols, off = meta[k, 2], meta[k, 3], meta[k, 4]
        for c in range(13):  # c < 4: the bilinear 2x2 from (i0, j0); then the 3x3 around (i, j)
            ii = i0 + c // 2 if c < 4 else i + (c - 4) // 3 - 1
            jj = j0 + c % 2 if c < 4 else j + (c - 4) % 3 - 1
            if 0 <= ii < rows and 0 <= jj < cols:
                out[n, c] = node_of[off + ii * cols + jj]
    return out


@njit(cache=True)
def string_pull(meta, height, clearance, island, x0, z0, cs, pts, r, tol, step):
    """Greedy line-of-sight shortcutting of a grid path [K, 3]; returns the kept indices."""
    K = pts.shape[0]
    keep = np.empty(K, np.int64)
    keep[0] = 0
    m = 1
    i = 0
    while i < K - 1:
        j = i + 1
        while j + 1 < K:
            dx = pts[j + 1, 0] - pts[i, 0]
            dz = pts[j + 1, 2] - pts[i, 2]
            L = math.sqrt(dx * dx + dz * dz)
            if L > 0:
                t, y = march(meta, height, clearance, island, x0, z0, cs, pts[i, 0], pts[i, 1],
                             pts[i, 2], dx / L, dz / L, L, r, tol, step)
                if t < L - 1e-6 or abs(y - pts[j + 1, 1]) > tol:
                    break
            j += 1
        keep[m] = j
        m += 1
        i = j
    return keep[:m].copy()


@njit(cache=True)
def _clear(meta, height, clearance, island, x0, z0, cs, a, bx, by, bz, r, tol, step):
    """(segment a → (bx, bz) is navigable and ends within tol of height by (unless NaN),
    floor y at its end)."""
    dx = bx - a[0]
    dz = bz - a[2]
    L = math.sqrt(dx * dx + dz * dz)
    if L < 1e-12:
        return np.isnan(by) or abs(a[1] - by) <= tol, a[1]
    t, y = march(meta, height, clearance, island, x0, z0, cs, a[0], a[1], a[2], dx / L, dz / L, L, r, tol, step)
    return t >= L - 1e-7 and (np.isnan(by) or abs(y - by) <= tol), y


@njit(cache=True)
def _slide(meta, height, clearance, island, x0, z0, cs, a, b, vx, vy, vz, tx, tz, r, tol, step):
    """Largest move of vertex v towards (tx, tz) keeping a→v and v→b navigable: (s, y)."""
    lo = 0.0
    hi = 1.0
    ylo = vy
    for it in range(10):
        s = hi if it == 0 else 0.5 * (lo + hi)
        cx, cz = vx + s * (tx - vx), vz + s * (tz - vz)
        ok, y1 = _clear(meta, height, clearance, island, x0, z0, cs, a, cx, np.nan, cz, r, tol, step)
        if ok:
            ok, _ = _clear(meta, height, clearance, island, x0, z0, cs, np.array([cx, y1, cz]),
                           b[0], b[1], b[2], r, tol, step)
        if ok:
            lo = s
            ylo = y1
            if it == 0:
                break
        else:
            hi = s
    return lo, ylo


@njit(cache=True)
def relax_path(meta, height, clearance, island, x0, z0, cs, path, r, tol, step, iters):
    """Shorten a clear polyline by moving each interior vertex towards the chord of its
    neighbours or along either of its segments, whichever shortens most while both segments
    stay navigable (tightens string-pulled corners onto the obstacle margin)."""
    P = path.copy()
    M = P.shape[0]
    for _ in range(iters):
        for i in range(1, M - 1):
            a = P[i - 1]
            b = P[i + 1]
            vx, vy, vz = P[i, 0], P[i, 1], P[i, 2]
            ex, ez = b[0] - a[0], b[2] - a[2]
            ee = ex * ex + ez * ez
            u = 0.0 if ee < 1e-18 else max(0.0, min(1.0, ((vx - a[0]) * ex + (vz - a[2]) * ez) / ee))
            best = math.hypot(vx - a[0], vz - a[2]) + math.hypot(b[0] - vx, b[2] - vz)
            bx_, by_, bz_ = vx, vy, vz
            for d in range(3):
                if d == 0:
                    tx, tz = a[0] + u * ex, a[2] + u * ez
                elif d == 1:
                    tx, tz = a[0], a[2]
                else:
                    tx, tz = b[0], b[2]
                s, y = _slide(meta, height, clearance, island, x0, z0, cs, a, b, vx, vy, vz, tx, tz, r, tol, step)
                cx, cz = vx + s * (tx - vx), vz + s * (tz - vz)
                L = math.hypot(cx - a[0], cz - a[2]) + math.hypot(b[0] - cx, b[2] - cz)
                if s > 0.0 and L < best - 1e-9:
                    best = L
                    bx_, by_, bz_ = cx, y, cz
            P[i, 0] = bx_
            P[i, 1] = by_
            P[i, 2] = bz_
    return P

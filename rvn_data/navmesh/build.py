"""Build the navigation mesh layers of a scene: rasterise, surfaces, regions, erosion, islands.

Erosion is exact to sub-cell accuracy: each cell stores the x/z box of the obstacle geometry
clipped into it, and the clearance of a cell is the distance from its centre to the nearest box
(`_clearance`: the box of the nearest obstacle cell by `scipy.ndimage.distance_transform_edt`,
then the boxes of the cells a nearer one can lie in), and to the nearest edge between unlinked
surfaces of the layer (`edge_clearance`). Both are exact up to max(1 m, 2 x agent radius); farther
away, the first may be up to sqrt(2) cell sizes too large and the second is not computed.
A cell is navigable when its clearance is at least the agent radius.
Island areas integrate the sub-cell coverage clip((clearance - r)/cs + 1/2, 0, 1).
`navmesh.profile=habitat` swaps the heightfield and the erosion for Recast's
(`recast_profile`); surfaces, layers, seams and islands are shared.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from rvn_data.navmesh.grid import NavGrid
from rvn_data.navmesh.heightfield import Heightfield, rasterize
from rvn_data.navmesh.recast_profile import (HABITAT_CELL_HEIGHT, ledge_surfaces, recast_layer, recast_voxels,
                                             surface_heights)
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.navmesh.surfaces import (build_regions, find_surfaces, link_surfaces,
                                       edge_clearance, obstacle_boxes, portal_surfaces, voxels)
from rvn_data.scenes.scene import Scene, SceneError

_MARGIN = 2  # cells of blocked border kept around each layer


def _components(n: int, pairs: np.ndarray) -> np.ndarray:
    if n == 0:
        return np.zeros(0, np.int64)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)) if len(pairs) else \
        coo_matrix((n, n))
    return connected_components(g, directed=False)[1]


def _box_distance(b: np.ndarray, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Distance (m) from points (x, z) to x/z boxes b [..., 4] = (x0, x1, z0, z1); inf for a NaN box."""
    dx = np.maximum(np.maximum(b[..., 0] - x, x - b[..., 1]), 0.0)
    dz = np.maximum(np.maximum(b[..., 2] - z, z - b[..., 3]), 0.0)
    d = np.hypot(dx, dz)
    return np.where(np.isnan(d), np.inf, d)


def _clearance(box: np.ndarray, xc: np.ndarray, zc: np.ndarray, cs: float, reach: float,
               chunk: int = 1 << 20) -> np.ndarray:
    """Distance (m) from each cell centre (xc [cols], zc [rows]) to the nearest obstacle box: exact
    wherever it is below `reach` m, beyond that an upper bound at most sqrt(2)·cs too large.

    The box of the obstacle cell whose centre is nearest (distance transform: `near` cells away)
    bounds the clearance from above (`est`), but the box of a cell whose centre is a little farther
    can be nearer (thin posts, slanted walls). A box lies within its cell, so a nearer one belongs
    to an obstacle cell whose centre is `near` to est/cs + 1/sqrt(2) cells away: each cell whose
    clearance can be below `reach` (near - 1/sqrt(2) < reach/cs) measures the boxes of that
    annulus of cell offsets, `chunk` (cell, offset) pairs at a time."""
    obstacle = ~np.isnan(box[..., 0])
    if not obstacle.any():
        return np.full(box.shape[:2], np.inf)
    near, (ii, jj) = ndimage.distance_transform_edt(~obstacle, return_indices=True)
    est = _box_distance(box[ii, jj].astype(np.float64), xc[None, :], zc[:, None])
    half = math.sqrt(0.5)
    qi, qj = np.nonzero((near - half < reach / cs) & (est > 0))
    if len(qi) == 0:
        return est
    # each cell's annulus, in cells, 1e-3 wider each side: a float32 box may overhang its cell by a few µm
    lo, hi = near[qi, qj] - 1e-3, est[qi, qj] / cs + half + 1e-3
    # the offsets of the widest annulus, nearest first (a cell's annulus: offsets first:stop), as steps
    # in the flat index of the boxes padded by w NaN cells; int32 indices, twice as fast as int64
    w = int(np.ceil(hi.max()))
    cols = box.shape[1] + 2 * w
    di, dj = (a.ravel() for a in np.mgrid[-w:w + 1, -w:w + 1])
    length = np.hypot(di, dj)
    order = np.argsort(length, kind="stable")
    step, length = (di * cols + dj)[order].astype(np.int32), length[order]
    first = np.searchsorted(length, lo).astype(np.int32)
    count = np.searchsorted(length, hi, side="right").astype(np.int32) - first
    flat_box = np.pad(box.astype(np.float64), ((w, w), (w, w), (0, 0)), constant_values=np.nan).reshape(-1, 4)
    flat_obstacle = np.pad(obstacle, w).ravel()
    at = ((qi + w) * cols + qj + w).astype(np.int32)
    xq, zq, best = xc[qj], zc[qi], est[qi, qj]
    bounds = np.searchsorted(np.cumsum(count, dtype=np.int64), np.arange(chunk, count.sum(dtype=np.int64), chunk))
    for part in np.split(np.arange(len(qi), dtype=np.int32), np.unique(bounds)):
        n = count[part]
        q = np.repeat(part, n)  # (cell, offset) pairs, grouped by cell
        k = np.repeat(first[part] - (np.cumsum(n, dtype=np.int32) - n), n) + np.arange(n.sum(), dtype=np.int32)
        cell = at[q] + step[k]
        hit = flat_obstacle[cell]
        q, cell = q[hit], cell[hit]
        if len(q):
            d = _box_distance(flat_box[cell], xq[q], zq[q])
            start = np.flatnonzero(np.r_[True, q[1:] != q[:-1]])
            best[q[start]] = np.minimum(best[q[start]], np.minimum.reduceat(d, start))
    est[qi, qj] = best
    return est


def _layer(hf: Heightfield, rid, region, surf, nbr, seams, keep, st: NavMeshSettings, climb, hcells,
           recast=None):
    """Arrays of one region's layer: surface index per cell (own and seam portals), clearance.
    `recast`: (ledge per surface, true floor height per surface) under the habitat profile."""
    span, cell, height = surf
    own = np.flatnonzero(region == rid)
    # seam portals: surfaces of other kept regions near the seams, where the cell is empty
    sel = seams[(region[seams[:, 0]] == rid) ^ (region[seams[:, 1]] == rid)]
    seeds = np.where(region[sel[:, 0]] == rid, sel[:, 1], sel[:, 0])
    depth = int(np.ceil(1.5 * (st.agent_radius / st.cell_size + 2)))
    other = portal_surfaces(seeds, region, rid, nbr, depth) if len(seeds) else seeds
    other = other[keep[region[other]]]
    both = np.concatenate([own, other])
    rows, cols = cell[both] // hf.nx, cell[both] % hf.nx
    r0, c0 = max(rows.min() - _MARGIN, 0), max(cols.min() - _MARGIN, 0)
    r1, c1 = min(rows.max() + _MARGIN, hf.nz - 1), min(cols.max() + _MARGIN, hf.nx - 1)
    lsurf = np.full((r1 - r0 + 1, c1 - c0 + 1), -1, np.int64)
    pr, pc = cell[other] // hf.nx - r0, cell[other] % hf.nx - c0
    lsurf[pr[::-1], pc[::-1]] = other[::-1]  # nearest to the seam wins a contested cell
    lsurf[cell[own] // hf.nx - r0, cell[own] % hf.nx - c0] = own
    is_own = np.zeros(lsurf.shape, bool)
    is_own[cell[own] // hf.nx - r0, cell[own] % hf.nx - c0] = True
    if recast is not None:
        ledge, yfloor = recast
        clearance = recast_layer(lsurf, ledge, nbr, st)
        hgt = np.where(is_own, yfloor[np.maximum(lsurf, 0)], np.nan)
        return int(r0), int(c0), lsurf, is_own, hgt, clearance
    free = lsurf >= 0
    _, (ii, jj) = ndimage.distance_transform_edt(~free, return_indices=True)
    href = height[lsurf[ii, jj]].astype(np.float64)
    box, edge = obstacle_boxes(r0, c0, lsurf, href, hf.nx, hf.rstart, hf.rmin, hf.rmax, hf.rwalk, hf.rbox,
                               nbr, climb, hcells, hf.x0, hf.z0, hf.cs)
    xc = hf.x0 + (c0 + np.arange(lsurf.shape[1]) + 0.5) * hf.cs
    zc = hf.z0 + (r0 + np.arange(lsurf.shape[0]) + 0.5) * hf.cs
    window = int(np.ceil(max(1.0, 2 * st.agent_radius) / st.cell_size))  # cells: the clearance is exact that far
    clearance = _clearance(box, xc, zc, hf.cs, window * hf.cs)
    if not np.isnan(edge[..., 0]).all():
        clearance = np.minimum(clearance, edge_clearance(edge, lsurf, height, xc, zc, window, hcells))
    hgt = np.where(is_own, hf.y0 + height[np.maximum(lsurf, 0)] * hf.ch, np.nan)
    return int(r0), int(c0), lsurf, is_own, hgt, clearance


def scene_heightfield(verts: np.ndarray, faces: np.ndarray, st: NavMeshSettings) -> tuple[Heightfield, int, int]:
    """The heightfield of the settings' profile and its (climb, clearance) in voxels."""
    habitat = st.profile == "habitat"
    if habitat:
        ch = HABITAT_CELL_HEIGHT
        climb, hcells = recast_voxels(st)
    else:
        ch = st.cell_height
        climb, hcells = voxels(st.max_climb, ch, up=False), voxels(st.agent_height, ch, up=True)
    return rasterize(verts, faces, st.cell_size, ch, st.max_slope_deg, climb, recast=habitat), climb, hcells


def build_layers(scene: Scene, st: NavMeshSettings):
    """Returns (layers: list[NavGrid], island_areas: list[float] (largest first), scene grid
    (x0, z0, rows, cols), seam links int64 [K, 6] = (layer, row, col, layer, row, col))."""
    verts, faces = scene.triangles()
    if len(faces) == 0:
        raise SceneError(f"scene {scene.scene_id!r}: no triangles, nothing to build a navmesh from")
    habitat = st.profile == "habitat"
    hf, climb, hcells = scene_heightfield(verts, faces, st)
    span, cell, height, ceiling, sstart = find_surfaces(hf.start, hf.smin, hf.smax, hf.walk, hcells)
    if len(span) == 0:
        raise SceneError(f"scene {scene.scene_id!r}: no walkable surface (no upward face with "
                         f"slope <= {st.max_slope_deg} deg and {st.agent_height} m of clearance); "
                         "check the up axis (--up-axis) and the unit scale")
    nbr = link_surfaces(cell, height, ceiling, sstart, hf.nx, hf.nz, climb, hcells)
    recast = None
    if habitat:
        recast = (ledge_surfaces(hf.start, hf.smin, hf.smax, span, cell, hf.nx, hf.nz, climb, hcells),
                  surface_heights(span, cell, hf.smax, hf.rstart, hf.rmax, hf.rwalk, hf.rytop, hf.y0, hf.ch))
    region, nreg, seams = build_regions(cell, nbr, hf.nx * hf.nz)
    # regions joined by seams form one raw component; erosion only shrinks it
    comp = _components(nreg, np.stack([region[seams[:, 0]], region[seams[:, 1]]], 1))
    raw_area = np.bincount(comp[region], minlength=comp.max() + 1) * st.cell_size ** 2
    keep = raw_area[comp] >= max(st.min_island_area, 1e-9)
    layers, labels, offsets = [], [], []
    cs, r = st.cell_size, st.agent_radius
    total = 0
    where = {}  # region id -> layer index
    for rid in np.flatnonzero(keep):
        r0, c0, lsurf, is_own, hgt, clr = _layer(hf, rid, region, (span, cell, height), nbr, seams,
                                                 keep, st, climb, hcells, recast)
        nav = is_own & (clr >= r - 1e-9)
        lab, n = ndimage.label(nav)
        lab = np.where(lab > 0, lab - 1 + total, -1)
        cov = np.clip((clr - r) / cs + 0.5, 0.0, 1.0) * is_own
        partial = is_own & ~nav & (cov > 0)
        near = ndimage.grey_dilation(lab, size=(3, 3), mode="constant", cval=-1)
        where[rid] = len(layers)
        layers.append(NavGrid(hf.x0 + c0 * cs, hf.z0 + r0 * cs, cs, r0, c0, is_own, hgt.astype(np.float32),
                              clr.astype(np.float32), lab.astype(np.int32)))
        labels.append((lab, cov, partial, near))
        offsets.append(total)
        total += n
    # union islands across seams
    pairs, links = [], []
    for s, t in seams:
        a, b = where.get(region[s]), where.get(region[t])
        if a is None or b is None:
            continue
        la, lb = layers[a], layers[b]
        ia = la.island[cell[s] // hf.nx - la.r0, cell[s] % hf.nx - la.c0]
        ib = lb.island[cell[t] // hf.nx - lb.r0, cell[t] % hf.nx - lb.c0]
        if ia >= 0 and ib >= 0:
            pairs.append((ia, ib))
            links.append((a, cell[s] // hf.nx - la.r0, cell[s] % hf.nx - la.c0,
                          b, cell[t] // hf.nx - lb.r0, cell[t] % hf.nx - lb.c0))
    root = _components(total, np.array(pairs, np.int64).reshape(-1, 2))
    area = np.zeros(root.max() + 1 if total else 0)
    for lab, cov, partial, near in labels:
        m = lab >= 0
        np.add.at(area, root[lab[m]], cov[m] * cs * cs)
        p = partial & (near >= 0)
        np.add.at(area, root[near[p]], cov[p] * cs * cs)
    kept = np.flatnonzero(area >= st.min_island_area)
    if len(kept) == 0:
        best = area.max() if len(area) else 0.0
        raise SceneError(f"scene {scene.scene_id!r}: no navigable island of at least "
                         f"{st.min_island_area} m² for agent radius {r} m and height "
                         f"{st.agent_height} m (largest: {best:.2f} m²)")
    order = kept[np.argsort(-area[kept], kind="stable")]
    new_id = np.full(len(area), -1, np.int64)
    new_id[order] = np.arange(len(order))
    out, renum = [], {}
    for k, g in enumerate(layers):
        g.island = np.where(g.island >= 0, new_id[root[np.maximum(g.island, 0)]], -1).astype(np.int32)
        if (g.island >= 0).any():
            renum[k] = len(out)
            out.append(g)
    links = np.array([(renum[a], ra, ca, renum[b], rb, cb) for a, ra, ca, b, rb, cb in links
                      if a in renum and b in renum], np.int64).reshape(-1, 6)
    return out, [float(a) for a in area[order]], (hf.x0, hf.z0, hf.nz, hf.nx), links

"""A `NavMesh` from a Detour navmesh (`detour_format.DetourMesh`): the polygons' detail
triangles rasterised into RVN's layered grid.

A cell belongs to a polygon when its centre lies inside one of the polygon's detail
triangles (height interpolated on the triangle). Cells of one x/z position are ranked by
height (surfaces closer than half a metre are one surface); rank k forms layer k, and
4-neighbours in different layers within `max_climb` are joined by seam links. Recast's
polygons are already eroded by the agent radius, so a cell's clearance is the agent radius
plus its horizontal distance to the nearest boundary edge (edges with no neighbour polygon)
inside the mesh, and the radius minus that distance outside: the bilinear clearance reaches
the agent radius on the polygon boundary. Cells the polygons cover only in part are floor
cells without an island, as in `NavMesh.build`, so points up to the boundary are navigable. Islands are the connected cells (4-neighbours
within `max_climb`, and the links); an island's area is the horizontal area of the detail
triangles of its polygons, and islands smaller than `min_island_area` are dropped.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from rvn_data.navmesh.detour_format import POLYTYPE_OFFMESH, DetourMesh
from rvn_data.navmesh.grid import NavGrid
from rvn_data.navmesh.settings import NavMeshSettings

SAME_SURFACE = 0.5  # m, samples of one cell closer than this in height are one surface
Y_WEIGHT = 4.0      # boundary search: 1 m of height counts as 4 m of horizontal distance
_MARGIN = 2         # cells around the samples in every layer


@njit(cache=True)
def _rasterise(tris, x0, z0, cs, counts, out_rc, out_h, out_t):
    """Cell centres inside each triangle (x/z): row, col, interpolated height, triangle."""
    n = 0
    for t in range(tris.shape[0]):
        ax, ay, az = tris[t, 0, 0], tris[t, 0, 1], tris[t, 0, 2]
        bx, by, bz = tris[t, 1, 0], tris[t, 1, 1], tris[t, 1, 2]
        cx, cy, cz = tris[t, 2, 0], tris[t, 2, 1], tris[t, 2, 2]
        det = (bx - ax) * (cz - az) - (cx - ax) * (bz - az)
        if abs(det) < 1e-12:
            continue
        j0 = int(math.floor((min(ax, bx, cx) - x0) / cs - 0.5)) + 1
        j1 = int(math.floor((max(ax, bx, cx) - x0) / cs - 0.5))
        i0 = int(math.floor((min(az, bz, cz) - z0) / cs - 0.5)) + 1
        i1 = int(math.floor((max(az, bz, cz) - z0) / cs - 0.5))
        for i in range(i0, i1 + 1):
            pz = z0 + (i + 0.5) * cs
            for j in range(j0, j1 + 1):
                px = x0 + (j + 0.5) * cs
                u = ((px - ax) * (cz - az) - (cx - ax) * (pz - az)) / det
                v = ((bx - ax) * (pz - az) - (px - ax) * (bz - az)) / det
                if u >= -1e-9 and v >= -1e-9 and u + v <= 1.0 + 1e-9 and n < out_h.shape[0]:
                    out_rc[n, 0] = i
                    out_rc[n, 1] = j
                    out_h[n] = ay + u * (by - ay) + v * (cy - ay)
                    out_t[n] = t
                    n += 1
        counts[t] = n
    return n


def _polygons(mesh: DetourMesh):
    """(detail triangles [T, 3, 3], global polygon id per triangle, boundary segments [B, 2, 3])."""
    tris, owner, bound, base = [], [], [], 0
    for tile in mesh.tiles:
        t, o = tile.triangles()
        tris.append(t)
        owner.append(o + base)
        base += len(tile.polys)
        for poly in tile.polys:
            if poly["areaAndtype"] >> 6 == POLYTYPE_OFFMESH:
                continue
            nv = int(poly["vertCount"])
            for j in range(nv):
                if poly["neis"][j] == 0:  # no neighbour polygon and no portal: a wall or a drop
                    a, b = poly["verts"][j], poly["verts"][(j + 1) % nv]
                    bound.append(tile.verts[[a, b]].astype(np.float64))
    cat = lambda xs, shape: np.concatenate(xs) if xs else np.zeros(shape)
    return (cat(tris, (0, 3, 3)), cat(owner, (0,)).astype(np.int64),
            np.array(bound).reshape(-1, 2, 3) if bound else np.zeros((0, 2, 3)))


def _boundary_distance(seg: np.ndarray, pts: np.ndarray, cs: float, cap: float) -> np.ndarray:
    """Horizontal distance from points [N, 3] to the nearest boundary segment at their height."""
    if len(seg) == 0 or len(pts) == 0:
        return np.full(len(pts), cap)
    length = np.linalg.norm(seg[:, 1, [0, 2]] - seg[:, 0, [0, 2]], axis=1)
    per = np.maximum(np.ceil(length / (0.5 * cs)).astype(np.int64), 1) + 1
    sid = np.repeat(np.arange(len(seg)), per)
    t = np.concatenate([np.linspace(0.0, 1.0, k) for k in per])
    samples = seg[sid, 0] + t[:, None] * (seg[sid, 1] - seg[sid, 0])
    scale = np.array([1.0, Y_WEIGHT, 1.0])
    k = min(8, len(samples))
    _, idx = cKDTree(samples * scale).query(pts * scale, k=k, distance_upper_bound=cap + cs)
    idx = idx.reshape(len(pts), k)
    best = np.full(len(pts), cap)
    for c in range(k):
        ok = idx[:, c] < len(samples)
        s = seg[sid[idx[ok, c]]]
        a, b, p = s[:, 0, [0, 2]], s[:, 1, [0, 2]], pts[ok][:, [0, 2]]
        ab = b - a
        u = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18), 0, 1)
        d = np.linalg.norm(a + u[:, None] * ab - p, axis=1)
        best[ok] = np.minimum(best[ok], d)
    return best


def navmesh_from_detour(mesh: DetourMesh, settings: NavMeshSettings, scene_id: str):
    """The `NavMesh` of a parsed navmesh file (ValueError naming the file when it has no
    walkable polygon or no island of at least `min_island_area`)."""
    from rvn_data.navmesh.navmesh import NavMesh

    cs, r, climb = settings.cell_size, settings.agent_radius, settings.max_climb
    tris, owner, seg = _polygons(mesh)
    flat = tris[:, :, [0, 2]]
    area = 0.5 * np.abs((flat[:, 1, 0] - flat[:, 0, 0]) * (flat[:, 2, 1] - flat[:, 0, 1])
                        - (flat[:, 2, 0] - flat[:, 0, 0]) * (flat[:, 1, 1] - flat[:, 0, 1]))
    if not (area > 0).any():
        raise ValueError(f"navmesh file {mesh.path!r} has no walkable polygon")
    lo = tris.reshape(-1, 3).min(0)
    hi = tris.reshape(-1, 3).max(0)
    x0, z0 = lo[0] - _MARGIN * cs, lo[2] - _MARGIN * cs
    rows = int(math.ceil((hi[2] - z0) / cs)) + _MARGIN
    cols = int(math.ceil((hi[0] - x0) / cs)) + _MARGIN
    cell, h, t, rc = _surface_samples(mesh, tris, flat, x0, z0, cs, cols)
    rank = np.arange(len(cell)) - np.searchsorted(cell, cell)
    nlayers = int(rank.max()) + 1
    # per layer: own cells (sample index), heights
    sample_at = np.full((nlayers, rows, cols), -1, np.int64)
    sample_at[rank, rc[:, 0], rc[:, 1]] = np.arange(len(cell))
    pairs = _neighbour_pairs(sample_at, h, climb)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(cell), len(cell)))
    comp = connected_components(g, directed=False)[1]
    island, areas = _islands(mesh, settings, owner, owner[t], comp, area)
    layers, where = _layers(sample_at, h, island, seg, x0, z0, cs, r, climb)
    cross = pairs[(rank[pairs[:, 0]] != rank[pairs[:, 1]]) & (island[pairs[:, 0]] >= 0)]
    lay = np.full(nlayers, -1, np.int64)
    lay[list(where)] = list(where.values())
    origin = np.array([(g.r0, g.c0) for g in layers], np.int64)
    a, b = cross[:, 0], cross[:, 1]
    links = np.concatenate([lay[rank[a]][:, None], rc[a] - origin[lay[rank[a]]],
                            lay[rank[b]][:, None], rc[b] - origin[lay[rank[b]]]], 1).reshape(-1, 6)
    nm = NavMesh(scene_id, settings, layers, areas, (x0, z0, rows, cols), links)
    nm.source_file = mesh.path
    return nm


def _surface_samples(mesh: DetourMesh, tris, flat, x0: float, z0: float, cs: float, cols: int):
    """The detail triangles rasterised at the cell centres, one sample per surface and cell
    (samples of a cell closer than `SAME_SURFACE` in height merged), sorted by cell, then
    height: (scene-grid cell index, height, triangle, (row, col)) per sample."""
    box = (np.ceil((flat.max(1) - flat.min(1)) / cs) + 1).prod(1).astype(np.int64)
    cap_n = int(box.sum())
    rc, h, t = np.zeros((cap_n, 2), np.int64), np.zeros(cap_n), np.zeros(cap_n, np.int64)
    n = _rasterise(np.ascontiguousarray(tris), x0, z0, cs, np.zeros(len(tris), np.int64), rc, h, t)
    rc, h, t = rc[:n], h[:n], t[:n]
    if n == 0:
        raise ValueError(f"navmesh file {mesh.path!r}: no polygon covers a cell centre at "
                         f"navmesh.cell_size={cs}; lower the cell size")
    # one sample per surface and cell; rank = position among a cell's surfaces, bottom up
    cell = rc[:, 0] * cols + rc[:, 1]
    order = np.lexsort((h, cell))
    cell, h, t, rc = cell[order], h[order], t[order], rc[order]
    new_cell = np.r_[True, cell[1:] != cell[:-1]]
    keep = new_cell.copy()
    last_h = h.copy()
    for i in np.flatnonzero(~new_cell):  # cells with several samples are rare
        keep[i] = h[i] - last_h[i - 1] > SAME_SURFACE
        last_h[i] = h[i] if keep[i] else last_h[i - 1]
    return cell[keep], h[keep], t[keep], rc[keep]


def _neighbour_pairs(sample_at: np.ndarray, h: np.ndarray, climb: float) -> np.ndarray:
    """[P, 2] samples of 4-neighbour cells (in any two layers) within ``climb`` of each other."""
    nlayers, rows, cols = sample_at.shape
    pairs = []
    for di, dj in ((0, 1), (1, 0)):
        a = sample_at[:, :rows - di, :cols - dj].reshape(nlayers, -1)
        b = sample_at[:, di:, dj:].reshape(nlayers, -1)
        for la in range(nlayers):
            for lb in range(nlayers):
                ok = (a[la] >= 0) & (b[lb] >= 0)
                sa, sb = a[la][ok], b[lb][ok]
                near = np.abs(h[sa] - h[sb]) <= climb + 1e-9
                pairs.append(np.stack([sa[near], sb[near]], 1))
    return np.concatenate(pairs)


def _islands(mesh: DetourMesh, settings: NavMeshSettings, owner, poly, comp, area):
    """(island id per sample, -1 where dropped; island areas, largest first). An island's area
    is the horizontal area of its polygons, each polygon in its cells' main component; those
    under ``min_island_area`` are dropped (ValueError naming the file when none is left)."""
    npoly = int(owner.max()) + 1
    pc = np.zeros((npoly,), np.int64)
    votes = coo_matrix((np.ones(len(poly)), (poly, comp)), shape=(npoly, comp.max() + 1)).tocsr()
    has = np.asarray(votes.sum(1)).ravel() > 0
    pc[has] = np.asarray(votes[has].argmax(1)).ravel()
    poly_area = np.bincount(owner, weights=area, minlength=npoly)
    comp_area = np.bincount(pc[has], weights=poly_area[has], minlength=comp.max() + 1)
    kept = np.flatnonzero(comp_area >= settings.min_island_area)
    if len(kept) == 0:
        raise ValueError(f"navmesh file {mesh.path!r}: no island of at least navmesh.min_island_area="
                         f"{settings.min_island_area} m² (largest {comp_area.max():.2f} m²)")
    kept = kept[np.argsort(-comp_area[kept], kind="stable")]
    new_id = np.full(len(comp_area), -1, np.int64)
    new_id[kept] = np.arange(len(kept))
    return new_id[comp], [float(a) for a in comp_area[kept]]


def _layers(sample_at, h, island, seg, x0, z0, cs, r, climb):
    """NavGrid per layer holding a kept island, and {rank: layer index}."""
    nlayers, rows, cols = sample_at.shape
    reach = int(math.ceil(r / cs)) + 2
    any_h = [np.where(sample_at[k] >= 0, h[np.maximum(sample_at[k], 0)], np.nan) for k in range(nlayers)]
    layers, where = [], {}
    for k in range(nlayers):
        own = sample_at[k] >= 0
        if not (island[sample_at[k][own]] >= 0).any():
            continue
        rr, cc = np.nonzero(own)
        r0, c0 = max(rr.min() - reach, 0), max(cc.min() - reach, 0)
        r1, c1 = min(rr.max() + reach, rows - 1), min(cc.max() + reach, cols - 1)
        win = (slice(r0, r1 + 1), slice(c0, c1 + 1))
        own_w, hk = own[win], any_h[k][win]
        _, (ii, jj) = ndimage.distance_transform_edt(~own_w, return_indices=True)
        href = hk[ii, jj]
        # cells of other layers next to this one at a joinable height count as inside (seams)
        covered = own_w.copy()
        ring = ndimage.binary_dilation(own_w, np.ones((3, 3), bool)) & ~own_w
        for m in range(nlayers):
            if m != k:
                hm = any_h[m][win]
                covered |= ring & ~np.isnan(hm) & (np.abs(np.nan_to_num(hm) - href) <= climb + 1e-9)
        zc, xc = np.meshgrid(z0 + (np.arange(r0, r1 + 1) + 0.5) * cs, x0 + (np.arange(c0, c1 + 1) + 0.5) * cs,
                             indexing="ij")
        pts = np.stack([xc.ravel(), href.ravel(), zc.ravel()], 1)
        d = _boundary_distance(seg, pts, cs, 1.0 + r).reshape(own_w.shape)
        clearance = np.where(covered, r + d, np.maximum(r - d, 0.0))
        lab = np.where(own_w, island[np.maximum(sample_at[k][win], 0)], -1)
        # cells the polygons only partly cover (centre outside, within half a diagonal): floor
        # without an island, so the bilinear clearance places the edge inside the cell
        free = own_w | (ring & ~covered & (d < 0.5 * math.sqrt(2.0) * cs))
        where[k] = len(layers)
        layers.append(NavGrid(x0 + c0 * cs, z0 + r0 * cs, cs, int(r0), int(c0), free,
                              np.where(free, href, np.nan).astype(np.float32), clearance.astype(np.float32),
                              lab.astype(np.int32)))
    return layers, where

"""Write a `NavMesh` as a Habitat/Recast `.navmesh` file (the layout in detour_format.py).

The polygons are runs of navigable cells (detour_polys.py): vertices on cell corners, each
corner's height the mean floor height of the layer's navigable cells around it. Within a
tile, polygons are linked through `neis`; across tiles through portal edges on the tile
border, which Detour connects when it adds the tiles. The scene grid is cut into square
tiles of `tile_cells` cells. Detail meshes are fans of each polygon; there is no BV tree
(Detour then tests every polygon of a tile). The set header is version 2 with
habitat-sim's NavMeshSettings block filled from the RVN settings.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rvn_data.atomic import write_bytes_atomic
from rvn_data.navmesh.detour_format import (BV_NODE, EXT_LINK, HABITAT_SETTINGS, LINK, MESH_HEADER, OFFMESH,
                                            POLY, POLY_DETAIL, SET_HEADER, SET_MAGIC, TILE_HEADER, TILE_MAGIC,
                                            TILE_VERSION, align4)
from rvn_data.navmesh.detour_polys import SIDES, polygons

NULL_LINK = 0xFFFFFFFF
POLYFLAGS_WALK = 0x01  # habitat-sim's query filter includes polygons with this flag


def _next_pow2(n: int) -> int:
    return 1 << max(int(n) - 1, 0).bit_length()


def _corner_heights(nm, k: int) -> np.ndarray:
    """Mean navigable floor height around every cell corner of layer k [rows + 1, cols + 1]."""
    g = nm.layers[k]
    nav = g.island >= 0
    h = np.where(nav, g.height.astype(np.float64), 0.0)
    s, c = np.zeros((g.shape[0] + 1, g.shape[1] + 1)), np.zeros((g.shape[0] + 1, g.shape[1] + 1))
    for di in (0, 1):
        for dj in (0, 1):
            s[di:di + g.shape[0], dj:dj + g.shape[1]] += h
            c[di:di + g.shape[0], dj:dj + g.shape[1]] += nav
    return s / np.maximum(c, 1)


def _detail(n: int, xz: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Fan triangles of a convex polygon from vertex 0, without the degenerate ones, with
    Detour's detail edge flags (boundary bit per edge)."""
    tris = []
    for i in range(1, n - 1):
        a, b, c = xz[0], xz[i], xz[i + 1]
        if abs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])) < 1e-12:
            continue
        flags = (1 if i == 1 else 0) | 1 << 2 | (1 << 4 if i + 1 == n - 1 else 0)
        tris.append((0, i, i + 1, flags))
    return tris


def _tile(nm, polys, members, tile_index, local, corner_h, tx, ty, tile_cells):
    st, cs = nm.settings, nm.settings.cell_size
    verts, vid = [], {}
    recs = np.zeros(len(members), POLY)
    detail = np.zeros(len(members), POLY_DETAIL)
    tris = []
    links = portals = 0
    for p, i in enumerate(members):
        poly = polys[i]
        for j, (k, r, c) in enumerate(poly.verts):
            if (k, r, c) not in vid:
                g = nm.layers[k]
                vid[(k, r, c)] = len(verts)
                verts.append((nm.x0 + c * cs, corner_h[k][r - g.r0, c - g.c0], nm.z0 + r * cs))
            recs[p]["verts"][j] = vid[(k, r, c)]
        for j, (q, d) in enumerate(zip(poly.nbrs, poly.dirs)):
            if q < 0:
                continue
            links += 1
            if tile_index[q] == tile_index[i]:
                recs[p]["neis"][j] = local[q] + 1
            else:
                recs[p]["neis"][j] = EXT_LINK | SIDES[d]
                portals += 1
        xz = np.array([(c, r) for _, r, c in poly.verts], float)
        own = _detail(len(poly.verts), xz)
        detail[p] = (0, len(tris), 0, len(own))
        tris += own
        recs[p]["vertCount"] = len(poly.verts)
    if len(verts) > 0xFFFF:
        raise ValueError(f"tile {tx},{ty} has {len(verts)} vertices (Detour allows 65535); "
                         "use a smaller tile size")
    recs["firstLink"] = NULL_LINK
    recs["flags"] = POLYFLAGS_WALK
    verts = np.asarray(verts, np.float32).reshape(-1, 3)
    tris = np.asarray(tris, np.uint8).reshape(-1, 4)
    nlinks = max(links + 4 * portals, 1)  # Detour links a portal edge to up to 4 polygons
    w = tile_cells * cs
    bmin = (nm.x0 + tx * w, float(verts[:, 1].min()), nm.z0 + ty * w)
    bmax = (nm.x0 + (tx + 1) * w, float(verts[:, 1].max()), nm.z0 + (ty + 1) * w)
    header = MESH_HEADER.pack(TILE_MAGIC, TILE_VERSION, tx, ty, 0, 0, len(members), len(verts), nlinks,
                              len(members), 0, len(tris), 0, 0, len(members), st.agent_height, st.agent_radius,
                              st.max_climb, *bmin, *bmax, 1.0 / cs)

    def pad(b: bytes) -> bytes:
        return b + bytes(align4(len(b)) - len(b))

    return b"".join([pad(header), pad(verts.tobytes()), pad(recs.tobytes()), pad(np.zeros(nlinks, LINK).tobytes()),
                     pad(detail.tobytes()), pad(tris.tobytes()), pad(np.zeros(0, BV_NODE).tobytes()),
                     pad(np.zeros(0, OFFMESH).tobytes())])


def navmesh_file_bytes(nm, tile_cells: int = 64) -> bytes:
    """The `.navmesh` file contents of a NavMesh (ValueError when it cannot be encoded)."""
    if tile_cells < 1:
        raise ValueError(f"tile size {tile_cells} cells must be positive")
    polys = polygons(nm, tile_cells, nm.settings.cell_height)
    if not polys:
        raise ValueError(f"navmesh of {nm.scene_id!r} has no navigable cell to write")
    tiles: dict[tuple[int, int], list[int]] = {}
    for i, poly in enumerate(polys):
        tiles.setdefault(poly.tile, []).append(i)
    keys = sorted(tiles, key=lambda t: (t[1], t[0]))
    tile_index = np.zeros(len(polys), np.int64)
    local = np.zeros(len(polys), np.int64)
    for t, key in enumerate(keys):
        tile_index[tiles[key]] = t
        local[tiles[key]] = np.arange(len(tiles[key]))
    tile_bits = _next_pow2(len(keys)).bit_length() - 1
    poly_bits = _next_pow2(max(len(v) for v in tiles.values())).bit_length() - 1
    if 32 - tile_bits - poly_bits < 10:
        raise ValueError(f"navmesh of {nm.scene_id!r} needs {tile_bits} tile and {poly_bits} polygon bits; "
                         "Detour's 32-bit references allow 22 in all: use a smaller tile size")
    corner_h = [_corner_heights(nm, k) for k in range(len(nm.layers))]
    st, cs = nm.settings, nm.settings.cell_size
    out = [SET_HEADER.pack(SET_MAGIC, 2, len(keys), nm.x0, 0.0, nm.z0, tile_cells * cs, tile_cells * cs,
                           1 << tile_bits, 1 << poly_bits),
           HABITAT_SETTINGS.pack(cs, st.cell_height, st.agent_height, st.agent_radius, st.max_climb,
                                 st.max_slope_deg, 20, 20, 12.0, 1.3, 6.0, 6.0, 1.0, True, True, True, False)]
    for t, (tx, ty) in enumerate(keys):
        data = _tile(nm, polys, tiles[(tx, ty)], tile_index, local, corner_h, tx, ty, tile_cells)
        ref = 1 << (poly_bits + tile_bits) | t << poly_bits  # salt 1, tile index t, polygon 0
        out += [TILE_HEADER.pack(ref, len(data)), data]
    return b"".join(out)


def write_navmesh_file(nm, path: str | Path, tile_cells: int = 64) -> Path:
    """Write `nm` as a Habitat/Recast `.navmesh` file (atomically); returns the path."""
    path = Path(path)
    write_bytes_atomic(path, navmesh_file_bytes(nm, tile_cells))
    return path


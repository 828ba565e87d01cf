"""Write a `NavMesh` as a Habitat/Recast `.navmesh` file (the layout in detour_format.py).

Every navigable cell becomes one square Detour polygon (vertices on the cell corners, each
corner's height the mean floor height of the layer's navigable cells around it), so
neighbouring polygons share whole edges: within a tile they are linked through `neis`,
across tiles through portal edges on the tile border, which Detour connects when it adds
the tiles. The scene grid is cut into square tiles of `tile_cells` cells. Detail meshes
are the two triangles of each square; there is no BV tree (Detour then tests every
polygon of a tile). The set header is version 2 with habitat-sim's NavMeshSettings block
filled from the RVN settings.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rvn_data.atomic import write_bytes_atomic
from rvn_data.navmesh.detour_format import (BV_NODE, EXT_LINK, HABITAT_SETTINGS, LINK, MESH_HEADER, OFFMESH,
                                            POLY, POLY_DETAIL, SET_HEADER, SET_MAGIC, TILE_HEADER, TILE_MAGIC,
                                            TILE_VERSION, align4)

NULL_LINK = 0xFFFFFFFF
POLYFLAGS_WALK = 0x01  # habitat-sim's query filter includes polygons with this flag
# edge k of a square (corners (x0,z0) (x0,z1) (x1,z1) (x1,z0)): neighbour offset (drow, dcol), Detour side
_EDGES = (((0, -1), 4), ((1, 0), 2), ((0, 1), 0), ((-1, 0), 6))
_CORNERS = ((0, 0), (1, 0), (1, 1), (0, 1))  # (drow, dcol) of the four vertices, in polygon order
_TRI_FLAGS = (0x01 | 0x01 << 2, 0x01 << 2 | 0x01 << 4)  # boundary bits of the detail edges


def _next_pow2(n: int) -> int:
    return 1 << max(int(n) - 1, 0).bit_length()


def _cells(nm):
    """Navigable cells of all layers: (layer, scene row, scene col, height), neighbour table."""
    cells = []
    for k, g in enumerate(nm.layers):
        rr, cc = np.nonzero(g.island >= 0)
        cells += [(k, g.r0 + i, g.c0 + j, float(g.height[i, j])) for i, j in zip(rr.tolist(), cc.tolist())]
    index = {(k, r, c): n for n, (k, r, c, _) in enumerate(cells)}
    nbr = np.full((len(cells), 4), -1, np.int64)
    climb = nm.settings.max_climb + 1e-6
    for n, (k, r, c, h) in enumerate(cells):
        for e, ((dr, dc), _) in enumerate(_EDGES):
            m = index.get((k, r + dr, c + dc))
            if m is not None and abs(cells[m][3] - h) <= climb:
                nbr[n, e] = m
    for la, ra, ca, lb, rb, cb in nm.links.tolist():  # seams between layers
        a = index.get((la, nm.layers[la].r0 + ra, nm.layers[la].c0 + ca))
        b = index.get((lb, nm.layers[lb].r0 + rb, nm.layers[lb].c0 + cb))
        if a is None or b is None:
            continue
        d = (cells[b][1] - cells[a][1], cells[b][2] - cells[a][2])
        for e, (off, _) in enumerate(_EDGES):
            if off == d:
                nbr[a, e], nbr[b, (e + 2) % 4] = b, a
    return cells, nbr


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


def _tile(nm, members, cells, nbr, tile_of, local, corner_h, tx, ty, tile_cells):
    st, cs = nm.settings, nm.settings.cell_size
    verts, vid = [], {}
    polys = np.zeros(len(members), POLY)
    links = portals = 0
    for p, n in enumerate(members):
        k, r, c, _ = cells[n]
        g = nm.layers[k]
        for v, (dr, dc) in enumerate(_CORNERS):
            key = (k, r + dr, c + dc)
            if key not in vid:
                vid[key] = len(verts)
                verts.append((nm.x0 + (c + dc) * cs, corner_h[k][r + dr - g.r0, c + dc - g.c0], nm.z0 + (r + dr) * cs))
            polys[p]["verts"][v] = vid[key]
        for e, (_, side) in enumerate(_EDGES):
            m = nbr[n, e]
            if m < 0:
                continue
            links += 1
            if tile_of[m] == tile_of[n]:
                polys[p]["neis"][e] = local[m] + 1
            else:
                polys[p]["neis"][e] = EXT_LINK | side
                portals += 1
    if len(verts) > 0xFFFF:
        raise ValueError(f"tile {tx},{ty} has {len(verts)} vertices (Detour allows 65535); "
                         "use a smaller tile size")
    polys["firstLink"] = NULL_LINK
    polys["flags"] = POLYFLAGS_WALK
    polys["vertCount"] = 4
    verts = np.asarray(verts, np.float32).reshape(-1, 3)
    detail = np.zeros(len(members), POLY_DETAIL)
    detail["triBase"] = 2 * np.arange(len(members))
    detail["triCount"] = 2
    tris = np.tile(np.array([[0, 1, 2, _TRI_FLAGS[0]], [0, 2, 3, _TRI_FLAGS[1]]], np.uint8), (len(members), 1))
    nlinks = max(links + 2 * portals, 1)
    w = tile_cells * cs
    bmin = (nm.x0 + tx * w, float(verts[:, 1].min()), nm.z0 + ty * w)
    bmax = (nm.x0 + (tx + 1) * w, float(verts[:, 1].max()), nm.z0 + (ty + 1) * w)
    header = MESH_HEADER.pack(TILE_MAGIC, TILE_VERSION, tx, ty, 0, 0, len(members), len(verts), nlinks,
                              len(members), 0, len(tris), 0, 0, len(members), st.agent_height, st.agent_radius,
                              st.max_climb, *bmin, *bmax, 1.0 / cs)

    def pad(b: bytes) -> bytes:
        return b + bytes(align4(len(b)) - len(b))

    return b"".join([pad(header), pad(verts.tobytes()), pad(polys.tobytes()), pad(np.zeros(nlinks, LINK).tobytes()),
                     pad(detail.tobytes()), pad(tris.tobytes()), pad(np.zeros(0, BV_NODE).tobytes()),
                     pad(np.zeros(0, OFFMESH).tobytes())])


def navmesh_file_bytes(nm, tile_cells: int = 64) -> bytes:
    """The `.navmesh` file contents of a NavMesh (ValueError when it cannot be encoded)."""
    if tile_cells < 1:
        raise ValueError(f"tile size {tile_cells} cells must be positive")
    cells, nbr = _cells(nm)
    if not cells:
        raise ValueError(f"navmesh of {nm.scene_id!r} has no navigable cell to write")
    tiles: dict[tuple[int, int], list[int]] = {}
    for n, (_, r, c, _) in enumerate(cells):
        tiles.setdefault((c // tile_cells, r // tile_cells), []).append(n)
    keys = sorted(tiles, key=lambda t: (t[1], t[0]))
    tile_of = np.zeros(len(cells), np.int64)
    local = np.zeros(len(cells), np.int64)
    for t, key in enumerate(keys):
        tile_of[tiles[key]] = t
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
        data = _tile(nm, tiles[(tx, ty)], cells, nbr, tile_of, local, corner_h, tx, ty, tile_cells)
        ref = 1 << (poly_bits + tile_bits) | t << poly_bits  # salt 1, tile index t, polygon 0
        out += [TILE_HEADER.pack(ref, len(data)), data]
    return b"".join(out)


def write_navmesh_file(nm, path: str | Path, tile_cells: int = 64) -> Path:
    """Write `nm` as a Habitat/Recast `.navmesh` file (atomically); returns the path."""
    path = Path(path)
    write_bytes_atomic(path, navmesh_file_bytes(nm, tile_cells))
    return path


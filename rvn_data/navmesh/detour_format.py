"""Habitat/Recast `.navmesh` files: the byte layout and a reader (`read_navmesh_file`).

A file is the Recast sample's "MSET" tile set as habitat-sim's `PathFinder::saveNavMesh`
writes it, little-endian: a set header (int32 magic 'MSET', int32 version 1 or 2, int32
tile count, `dtNavMeshParams`), for version 2 habitat's `NavMeshSettings` block, then per
tile a uint32 tile reference, an int32 data size and the Detour tile data. Tile data is a
`dtMeshHeader` followed by its arrays, each padded to 4 bytes: vertices, polygons, links,
detail meshes, detail vertices, detail triangles, BV-tree nodes, off-mesh connections
(the order `dtNavMesh::addTile` reads them in).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SET_MAGIC = ord("M") << 24 | ord("S") << 16 | ord("E") << 8 | ord("T")
TILE_MAGIC = ord("D") << 24 | ord("N") << 16 | ord("A") << 8 | ord("V")
TILE_VERSION = 7
VERTS_PER_POLYGON = 6
EXT_LINK = 0x8000  # neis[j] flag: the edge is a portal to the tile on side neis[j] & 0xff
POLYTYPE_OFFMESH = 1

SET_HEADER = struct.Struct("<iii3f2f2i")  # magic, version, numTiles, dtNavMeshParams
TILE_HEADER = struct.Struct("<Ii")        # tile ref, data size
MESH_HEADER = struct.Struct("<15i3f3f3ff")  # dtMeshHeader (100 bytes)
HABITAT_SETTINGS = struct.Struct("<13f4?")  # habitat-sim NavMeshSettings (56 bytes)
HABITAT_SETTING_NAMES = ("cellSize", "cellHeight", "agentHeight", "agentRadius", "agentMaxClimb",
                         "agentMaxSlope", "regionMinSize", "regionMergeSize", "edgeMaxLen", "edgeMaxError",
                         "vertsPerPoly", "detailSampleDist", "detailSampleMaxError", "filterLowHangingObstacles",
                         "filterLedgeSpans", "filterWalkableLowHeightSpans", "includeStaticObjects")
MESH_HEADER_NAMES = ("magic", "version", "x", "y", "layer", "userId", "polyCount", "vertCount", "maxLinkCount",
                     "detailMeshCount", "detailVertCount", "detailTriCount", "bvNodeCount", "offMeshConCount",
                     "offMeshBase")
POLY = np.dtype([("firstLink", "<u4"), ("verts", "<u2", VERTS_PER_POLYGON), ("neis", "<u2", VERTS_PER_POLYGON),
                 ("flags", "<u2"), ("vertCount", "u1"), ("areaAndtype", "u1")])               # 32 bytes
LINK = np.dtype([("ref", "<u4"), ("next", "<u4"), ("edge", "u1"), ("side", "u1"), ("bmin", "u1"),
                 ("bmax", "u1")])                                                              # 12 bytes
POLY_DETAIL = np.dtype({"names": ["vertBase", "triBase", "vertCount", "triCount"],
                        "formats": ["<u4", "<u4", "u1", "u1"], "offsets": [0, 4, 8, 9], "itemsize": 12})
BV_NODE = np.dtype([("bmin", "<u2", 3), ("bmax", "<u2", 3), ("i", "<i4")])                   # 16 bytes
OFFMESH = np.dtype([("pos", "<f4", 6), ("rad", "<f4"), ("poly", "<u2"), ("flags", "u1"), ("side", "u1"),
                    ("userId", "<u4")])                                                        # 36 bytes


def align4(n: int) -> int:
    return (n + 3) & ~3


@dataclass
class DetourTile:
    """One tile: header fields (dict), verts float32 [V, 3], polys (POLY records), detail
    meshes (POLY_DETAIL), detail verts float32 [D, 3], detail tris uint8 [T, 4], links,
    BV nodes and off-mesh connections."""

    ref: int
    header: dict
    verts: np.ndarray
    polys: np.ndarray
    links: np.ndarray
    detail_meshes: np.ndarray
    detail_verts: np.ndarray
    detail_tris: np.ndarray
    bv_nodes: np.ndarray
    offmesh: np.ndarray

    def triangles(self) -> np.ndarray:
        """Detail triangles of the ground polygons, world coordinates float64 [T, 3, 3], and
        the tile-local polygon index of each (int64 [T]) as a tuple."""
        tris, owner = [], []
        for p in range(len(self.polys)):
            poly = self.polys[p]
            if poly["areaAndtype"] >> 6 == POLYTYPE_OFFMESH:
                continue
            nv = int(poly["vertCount"])
            d = self.detail_meshes[p] if p < len(self.detail_meshes) else None
            pv = self.verts[poly["verts"][:nv]].astype(np.float64)
            if d is None or d["triCount"] == 0:  # no detail mesh: fan of the polygon
                tris += [np.stack([pv[0], pv[j], pv[j + 1]]) for j in range(1, nv - 1)]
                owner += [p] * (nv - 2)
                continue
            dv = self.detail_verts[int(d["vertBase"]):int(d["vertBase"]) + int(d["vertCount"])].astype(np.float64)
            allv = np.concatenate([pv, dv])
            idx = self.detail_tris[int(d["triBase"]):int(d["triBase"]) + int(d["triCount"]), :3].astype(np.int64)
            if idx.size and idx.max() >= len(allv):
                raise ValueError(f"tile {self.header['x']},{self.header['y']}: detail triangle index out of range")
            tris.append(allv[idx])
            owner += [p] * len(idx)
        if not tris:
            return np.zeros((0, 3, 3)), np.zeros(0, np.int64)
        return (np.concatenate([t.reshape(-1, 3, 3) for t in tris]), np.asarray(owner, np.int64))


@dataclass
class DetourMesh:
    """A navmesh file's contents: set `version`, `params` (dtNavMeshParams as a dict),
    habitat `settings` (dict, empty for version 1) and the tiles."""

    path: str
    version: int
    params: dict
    settings: dict = field(default_factory=dict)
    tiles: list[DetourTile] = field(default_factory=list)


class _Reader:
    def __init__(self, data: bytes, name: str):
        self.data, self.pos, self.name = data, 0, name

    def take(self, n: int, what: str) -> bytes:
        if n < 0 or self.pos + n > len(self.data):
            raise ValueError(f"navmesh file {self.name}: truncated in {what} (needs {n} bytes at offset "
                             f"{self.pos}, file has {len(self.data)}); re-export it")
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out

    def array(self, dtype: np.dtype, count: int, what: str) -> np.ndarray:
        raw = self.take(align4(dtype.itemsize * count), what)
        return np.frombuffer(raw[:dtype.itemsize * count], dtype=dtype).copy()


def _tile(data: bytes, ref: int, name: str) -> DetourTile:
    r = _Reader(data, name)
    values = MESH_HEADER.unpack(r.take(align4(MESH_HEADER.size), "a tile header"))
    h = dict(zip(MESH_HEADER_NAMES, values[:15]))
    h.update(walkableHeight=values[15], walkableRadius=values[16], walkableClimb=values[17],
             bmin=values[18:21], bmax=values[21:24], bvQuantFactor=values[24])
    if h["magic"] != TILE_MAGIC:
        raise ValueError(f"navmesh file {name}: a tile does not start with Detour's 'DNAV' magic; "
                         "not a Recast/Detour navmesh")
    if h["version"] != TILE_VERSION:
        raise ValueError(f"navmesh file {name}: Detour tile version {h['version']}, expected {TILE_VERSION}")
    for key in ("polyCount", "vertCount", "maxLinkCount", "detailMeshCount", "detailVertCount", "detailTriCount",
                "bvNodeCount", "offMeshConCount"):
        if h[key] < 0:
            raise ValueError(f"navmesh file {name}: negative {key} in a tile header; the file is corrupt")
    verts = r.array(np.dtype("<f4"), 3 * h["vertCount"], "tile vertices").reshape(-1, 3)
    polys = r.array(POLY, h["polyCount"], "tile polygons")
    links = r.array(LINK, h["maxLinkCount"], "tile links")
    detail = r.array(POLY_DETAIL, h["detailMeshCount"], "detail meshes")
    dverts = r.array(np.dtype("<f4"), 3 * h["detailVertCount"], "detail vertices").reshape(-1, 3)
    dtris = r.array(np.dtype("u1"), 4 * h["detailTriCount"], "detail triangles").reshape(-1, 4)
    bv = r.array(BV_NODE, h["bvNodeCount"], "BV-tree nodes")
    offmesh = r.array(OFFMESH, h["offMeshConCount"], "off-mesh connections")
    nv = polys["vertCount"].astype(np.int64)
    if len(polys) and (nv.max() > VERTS_PER_POLYGON or
                       any(int(polys["verts"][i, :nv[i]].max(initial=0)) >= len(verts) for i in range(len(polys)))):
        raise ValueError(f"navmesh file {name}: a polygon's vertex index is out of range; the file is corrupt")
    return DetourTile(ref, h, verts, polys, links, detail, dverts, dtris, bv, offmesh)


def read_navmesh_file(path: str | Path) -> DetourMesh:
    """Parse a `.navmesh` file; ValueError naming the file when it is truncated or foreign."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"navmesh file {str(path)!r} cannot be read: {exc.strerror or exc}") from None
    name = repr(str(path))
    r = _Reader(data, name)
    if len(data) < 4 or struct.unpack("<i", data[:4])[0] != SET_MAGIC:
        raise ValueError(f"navmesh file {name} is not a Habitat/Recast navmesh (no 'MSET' magic at the start)")
    magic, version, num_tiles, *p = SET_HEADER.unpack(r.take(SET_HEADER.size, "the file header"))
    if version not in (1, 2):
        raise ValueError(f"navmesh file {name}: navmesh set version {version}, expected 1 or 2")
    if num_tiles < 0:
        raise ValueError(f"navmesh file {name}: negative tile count {num_tiles}; the file is corrupt")
    params = dict(orig=tuple(p[:3]), tileWidth=p[3], tileHeight=p[4], maxTiles=p[5], maxPolys=p[6])
    settings = {}
    if version >= 2:
        settings = dict(zip(HABITAT_SETTING_NAMES, HABITAT_SETTINGS.unpack(
            r.take(HABITAT_SETTINGS.size, "habitat's NavMeshSettings block"))))
    mesh = DetourMesh(str(path), version, params, settings)
    for _ in range(num_tiles):
        ref, size = TILE_HEADER.unpack(r.take(TILE_HEADER.size, "a tile header"))
        if ref == 0 or size == 0:  # habitat's loader stops here too
            break
        mesh.tiles.append(_tile(r.take(size, "tile data"), ref, name))
    return mesh

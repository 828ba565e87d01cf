"""Habitat/Recast `.navmesh` files: the reader on a file written field by field from Detour's
struct layout and on files baked by real Recast, the writer (`rvn-scene navmesh`) read back,
`navmesh.source`, bad files."""
from __future__ import annotations

import json
import math
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
import trimesh

from conftest import box_scene, room_boxes
from rvn_data.cli.scene import main
from rvn_data.navmesh import NavMesh, NavMeshSettings
from rvn_data.navmesh.detour_format import read_navmesh_file
from rvn_data.navmesh.source import load_navmesh_file, open_navmesh

DNAV = ord("D") << 24 | ord("N") << 16 | ord("A") << 8 | ord("V")
MSET = ord("M") << 24 | ord("S") << 16 | ord("E") << 8 | ord("T")
DATA = Path(__file__).parent / "data"
OX, OY, OZ = 10.0, 0.5, -3.0  # world offset of the hand-built polygons

# an L (pentagon + square sharing the edge (0,1)-(1,1)), a 1.2 m square island and a 0.5 m one
VERTS = [(0, 0), (0, 1), (1, 1), (2, 1), (2, 0), (0, 2), (1, 2),
         (4, 0), (4, 1.2), (5.2, 1.2), (5.2, 0), (7, 0), (7, 0.5), (7.5, 0.5), (7.5, 0)]
POLYS = [([0, 1, 2, 3, 4], [0, 2, 0, 0, 0]), ([1, 5, 6, 2], [0, 0, 0, 1]),
         ([7, 8, 9, 10], [0, 0, 0, 0]), ([11, 12, 13, 14], [0, 0, 0, 0])]


def _pad(b: bytes) -> bytes:
    return b + bytes(-len(b) % 4)


def hand_built(version: int = 2) -> bytes:
    """One Detour tile written field by field (dtMeshHeader, verts, dtPoly, dtLink,
    dtPolyDetail, detail tris as polygon fans) inside habitat's MSET set."""
    verts = [(OX + x, OY, OZ + z) for x, z in VERTS]
    polys, details, tris = b"", b"", b""
    for p, (vi, ne) in enumerate(POLYS):
        polys += struct.pack("<I6H6HHBB", 0xFFFFFFFF, *vi, *[0] * (6 - len(vi)), *ne, *[0] * (6 - len(ne)),
                             1, len(vi), 0)
        details += struct.pack("<IIBB2x", 0, len(tris) // 4, 0, len(vi) - 2)
        tris += b"".join(struct.pack("4B", 0, j, j + 1, 0) for j in range(1, len(vi) - 1))
    xs, zs = [v[0] for v in verts], [v[2] for v in verts]
    header = struct.pack("<15i3f3f3ff", DNAV, 7, 0, 0, 0, 0, len(POLYS), len(verts), 4, len(POLYS), 0,
                         len(tris) // 4, 0, 0, len(POLYS), 1.5, 0.18, 0.2, min(xs), OY, min(zs), max(xs), OY,
                         max(zs), 20.0)
    data = b"".join([_pad(header), _pad(struct.pack(f"<{3 * len(verts)}f", *sum(verts, ()))), polys,
                     bytes(4 * 12), details, tris])
    out = struct.pack("<iii3f2f2i", MSET, version, 1, OX, OY, OZ, 8.0, 8.0, 1, 8)
    if version == 2:
        out += struct.pack("<13f4?", 0.05, 0.2, 1.5, 0.18, 0.2, 45, 20, 20, 12, 1.3, 6, 6, 1, True, True, True, False)
    return out + struct.pack("<Ii", 1 << 3, len(data)) + data


def _shoelace(vi) -> float:
    x, z = np.array([VERTS[i] for i in vi], float).T
    return 0.5 * abs(np.dot(x, np.roll(z, -1)) - np.dot(z, np.roll(x, -1)))


def _w(x, z):
    return np.array([OX + x, OY, OZ + z])


@pytest.mark.parametrize("version", [1, 2])
def test_hand_built_tile(tmp_path, version):
    path = tmp_path / "hand.navmesh"
    path.write_bytes(hand_built(version))
    nm = load_navmesh_file(path, NavMeshSettings())
    l_area = _shoelace(POLYS[0][0]) + _shoelace(POLYS[1][0])
    assert nm.island_areas == pytest.approx([l_area, _shoelace(POLYS[2][0])], abs=1e-4)  # 0.25 m² dropped
    assert l_area == pytest.approx(3.0)
    assert nm.is_navigable(_w(0.5, 1.5)) and not nm.is_navigable(_w(1.5, 1.5))  # inside the L, in its notch
    assert not nm.is_navigable(_w(7.2, 0.2)) and nm.island_of(_w(4.6, 0.6)) == 1
    assert nm.floor_height(_w(0.3, 0.3)) == pytest.approx(OY, abs=1e-5)
    assert nm.geodesic_distance(_w(0.2, 0.5), _w(1.8, 0.5)) == pytest.approx(1.6, rel=0.01)
    corner = math.dist((1.8, 0.5), (1, 1)) + math.dist((1, 1), (0.5, 1.8))  # around the L's inner corner
    assert nm.geodesic_distance(_w(1.8, 0.5), _w(0.5, 1.8)) == pytest.approx(corner, rel=0.02)
    assert math.isinf(nm.geodesic_distance(_w(0.5, 0.5), _w(4.6, 0.6)))
    rng = np.random.default_rng(0)
    pts = np.array([nm.sample(rng) for _ in range(200)])
    inside = lambda p: (0 <= p[0] - OX <= 2 and 0 <= p[2] - OZ <= 1) or (0 <= p[0] - OX <= 1 and 1 <= p[2] - OZ <= 2)
    assert all(inside(p) for p in pts)
    mesh = read_navmesh_file(path)
    assert mesh.version == version and (mesh.settings.get("agentRadius") == pytest.approx(0.18) or version == 1)


def test_bad_files_one_line_errors(tmp_path, capsys):
    good = hand_built()
    for name, data, what in (("cut.navmesh", good[:-7], "truncated"), ("head.navmesh", good[:30], "truncated"),
                             ("zip.navmesh", b"PK\x03\x04" + bytes(60), "not a Habitat/Recast navmesh"),
                             ("v9.navmesh", struct.pack("<ii", MSET, 9) + good[8:], "version 9"),
                             ("empty.navmesh", struct.pack("<iii3f2f2i", MSET, 1, 0, 0, 0, 0, 1, 1, 1, 1), "no polygon")):
        (tmp_path / name).write_bytes(data)
        with pytest.raises(ValueError, match=what) as err:
            load_navmesh_file(tmp_path / name, NavMeshSettings())
        assert name in str(err.value) and "\n" not in str(err.value)
    tile = bytearray(good)
    tile[40 + 56 + 8] ^= 0xFF  # first byte of the Detour tile magic
    (tmp_path / "tile.navmesh").write_bytes(bytes(tile))
    with pytest.raises(ValueError, match="DNAV"):
        read_navmesh_file(tmp_path / "tile.navmesh")
    with pytest.raises(ValueError, match="source"):
        NavMeshSettings(source="habitat")


@pytest.mark.parametrize("name", ["recast_room_solo.navmesh", "recast_room_tiled.navmesh"])
def test_real_recast_files(name):
    """Files baked by real Recast (tests/data/make_recast_navmesh.mjs): one and nine tiles,
    detail meshes, BV trees, a second storey; against Detour's own area and paths."""
    ref = json.loads((DATA / "recast_room.json").read_text())
    want = ref["files"][name]
    mesh = read_navmesh_file(DATA / name)
    assert mesh.version == 1 and len(mesh.tiles) == (1 if "solo" in name else 9)
    assert all(len(t.bv_nodes) and len(t.detail_meshes) == len(t.polys) for t in mesh.tiles)
    nm = load_navmesh_file(DATA / name, NavMeshSettings())
    assert sum(nm.island_areas) == pytest.approx(want["area"], abs=1e-3) and nm.num_islands == 2
    assert len(nm.layers) == 2  # the slab over the floor
    for (a, b), length in zip(ref["pairs"], want["lengths"]):
        ours = nm.geodesic_distance(np.array(a, float), np.array(b, float))
        if length is None:
            assert math.isinf(ours)
        else:  # Detour's paths follow the polygon corners exactly; ours up to the grid's precision
            assert ours == pytest.approx(length, rel=0.015)
    assert nm.floor_height(np.array([1.0, 2.4, 1.0])) == pytest.approx(2.4, abs=0.15)


def test_source_setting_and_checks(wall_glb, tmp_path):
    from rvn_data.navmesh.source import open_scene

    assert "source" not in NavMeshSettings().to_dict()  # defaults are not recorded: old records match
    assert NavMeshSettings.from_config({"source": "file", "file": "x.navmesh"}).to_dict()["file"] == "x.navmesh"
    path = tmp_path / "wall.navmesh"
    assert main(["navmesh", str(wall_glb), "-o", str(path)]) == 0
    scene, nm = open_scene(str(wall_glb), {}, NavMeshSettings(source="file", file=str(path)))
    assert nm.source_file == str(path)
    assert open_scene(str(wall_glb), {}, NavMeshSettings())[1].source_file is None  # default: build
    with pytest.raises(ValueError, match="navmesh.source=build ignores it"):
        NavMeshSettings(source="build", file=str(path))
    with pytest.raises(ValueError, match="no navmesh.file is set and there is no .navmesh beside"):
        open_navmesh(scene, NavMeshSettings(source="file"))
    (tmp_path / "hand.navmesh").write_bytes(hand_built())
    with pytest.raises(ValueError, match="does not lie within scene .*up_axis"):
        open_navmesh(scene, NavMeshSettings(source="auto", file=str(tmp_path / "hand.navmesh")))
    with pytest.warns(UserWarning, match="agent radius of 0.180 m, the settings say 0.25"):
        load_navmesh_file(path, NavMeshSettings(source="file", agent_radius=0.25))
    # a scan levelled on load (scenes.level) leaves the .navmesh beside it in the file's frame: built under auto,
    # refused under file (a tilt within the bounds check's slack was read, its floor beside the scene's)
    tilted = tmp_path / "tilted" / "wall.glb"
    tilted.parent.mkdir()
    mesh = trimesh.load(wall_glb, force="mesh")
    mesh.apply_transform(trimesh.transformations.rotation_matrix(math.radians(4), [1, 0, 0], point=[2, 0, 2]))
    mesh.export(tilted)
    assert main(["navmesh", str(tilted), "-o", str(tilted.with_suffix(".navmesh"))]) == 0
    with pytest.warns(UserWarning, match="its floor is tilted 4.0 deg"):
        _, beside = open_scene(str(tilted), {}, NavMeshSettings(source="auto"))
    assert beside.source_file == str(tilted.with_suffix(".navmesh"))
    scene, nm = open_scene(str(tilted), {"level": True}, NavMeshSettings(source="auto"))
    assert scene.levelled and nm.source_file is None
    with pytest.raises(ValueError, match="navmesh.source=file: scenes.level=true rotated scene 'wall'"):
        open_scene(str(tilted), {"level": True}, NavMeshSettings(source="file"))


@pytest.fixture(scope="module")
def wall_glb(tmp_path_factory):
    """A 4 x 4 m room split by a wall with a 1 m door at its far end."""
    v, f = box_scene(room_boxes() + [((1.9, 0.0, 0.0), (2.1, 2.5, 3.0))]).triangles()
    path = tmp_path_factory.mktemp("scenes") / "wall.glb"
    trimesh.Trimesh(v, f, process=False).export(path)
    return path


def test_cli_write_then_read_back(wall_glb, tmp_path, capsys):
    out = tmp_path / "wall.navmesh"
    assert main(["navmesh", str(wall_glb), "-o", str(out), "--tile-cells", "32"]) == 0
    capsys.readouterr()
    mesh = read_navmesh_file(out)
    area = 0.0  # the file's polygon areas
    for t in mesh.tiles:
        for poly in t.polys:
            x, z = t.verts[poly["verts"][:poly["vertCount"]]][:, [0, 2]].astype(np.float64).T
            area += 0.5 * abs(np.dot(x, np.roll(z, -1)) - np.dot(z, np.roll(x, -1)))
    assert main(["info", str(wall_glb), "--navmesh", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["navmesh_source"] == "file" and info["navmesh_file"] == str(out)
    assert info["navigable_area_m2"] == pytest.approx(area, abs=1e-3)
    assert main(["info", str(wall_glb), "--json"]) == 0
    built = json.loads(capsys.readouterr().out)
    assert built["navmesh_source"] == "build" and built["navmesh_file"] is None
    assert info["navigable_area_m2"] == pytest.approx(built["navigable_area_m2"], rel=0.05)
    # auto: a .navmesh beside the scene file is used
    shutil.copy(out, wall_glb.with_suffix(".navmesh"))
    try:
        assert main(["info", str(wall_glb), "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["navmesh_file"] == str(wall_glb.with_suffix(".navmesh"))
        assert main(["info", str(wall_glb), "--navmesh-source", "build", "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["navmesh_source"] == "build"
    finally:
        wall_glb.with_suffix(".navmesh").unlink()
    (tmp_path / "bad.navmesh").write_bytes(out.read_bytes()[:500])
    assert main(["info", str(wall_glb), "--navmesh", str(tmp_path / "bad.navmesh")]) == 2
    err = capsys.readouterr().err.strip()
    assert "bad.navmesh" in err and "truncated" in err and len(err.splitlines()) == 1


def test_written_file_matches_navmesh_and_detour_rules(wall_glb, tmp_path):
    from rvn_data.scenes import load_scene

    scene = load_scene(str(wall_glb))
    built = NavMesh.build(scene, NavMeshSettings())
    path = tmp_path / "wall.navmesh"
    assert main(["navmesh", str(wall_glb), "-o", str(path), "--tile-cells", "32"]) == 0
    nm = open_navmesh(scene, NavMeshSettings(source="file", file=str(path)))
    assert nm.source_file == str(path) and nm.num_islands == built.num_islands == 1
    for a, b in (((0.5, 0.5), (3.5, 0.5)), ((0.4, 3.6), (3.6, 3.6)), ((1.0, 1.0), (1.0, 3.2))):
        pa, pb = np.array([a[0], 0.0, a[1]]), np.array([b[0], 0.0, b[1]])
        assert nm.geodesic_distance(pa, pb) == pytest.approx(built.geodesic_distance(pa, pb), rel=0.02)
    # what habitat-sim's loader and dtNavMesh::init/addTile need
    mesh = read_navmesh_file(path)
    p = mesh.params
    tile_bits, poly_bits = p["maxTiles"].bit_length() - 1, p["maxPolys"].bit_length() - 1
    assert 1 << tile_bits == p["maxTiles"] >= len(mesh.tiles) and 32 - tile_bits - poly_bits >= 10
    assert sorted((t.ref >> poly_bits) & (p["maxTiles"] - 1) for t in mesh.tiles) == list(range(len(mesh.tiles)))
    assert all(t.ref >> (tile_bits + poly_bits) == 1 and t.ref & (p["maxPolys"] - 1) == 0 for t in mesh.tiles)
    assert mesh.settings["agentRadius"] == pytest.approx(0.18) and mesh.settings["cellSize"] == pytest.approx(0.05)
    for t in mesh.tiles:
        h = t.header
        assert len(t.polys) <= p["maxPolys"] and h["maxLinkCount"] >= 1 and h["offMeshBase"] == h["polyCount"]
        x0 = p["orig"][0] + h["x"] * p["tileWidth"]
        z0 = p["orig"][2] + h["y"] * p["tileHeight"]
        for i, poly in enumerate(t.polys):
            nv = int(poly["vertCount"])
            assert 3 <= nv <= 6
            idx = poly["verts"][:nv]
            v = t.verts[idx]
            assert np.all((v[:, 0] >= x0 - 1e-4) & (v[:, 0] <= x0 + p["tileWidth"] + 1e-4))
            assert np.all((v[:, 2] >= z0 - 1e-4) & (v[:, 2] <= z0 + p["tileHeight"] + 1e-4))
            x, z = v[:, 0], v[:, 2]
            assert np.dot(x, np.roll(z, -1)) - np.dot(z, np.roll(x, -1)) < 0  # Recast's winding
            for e, n in enumerate(poly["neis"][:nv]):
                a, b = idx[e], idx[(e + 1) % nv]
                if 0 < n < 0x8000:  # internal link: the neighbour has the same edge, reversed, linked back
                    other = t.polys[n - 1]
                    m = int(other["vertCount"])
                    edges = {(other["verts"][j], other["verts"][(j + 1) % m]): other["neis"][j] for j in range(m)}
                    assert edges.get((b, a)) == i + 1
                elif n & 0x8000:  # portal: the edge lies on the tile border of its side
                    coord = {0: (0, x0 + p["tileWidth"]), 4: (0, x0), 2: (2, z0 + p["tileHeight"]), 6: (2, z0)}
                    axis, at = coord[n & 0xFF]
                    assert t.verts[a][axis] == pytest.approx(at, abs=1e-4) and t.verts[b][axis] == pytest.approx(at, abs=1e-4)
    assert sum(len(t.polys) for t in mesh.tiles) < 0.1 * sum(int((g.island >= 0).sum()) for g in built.layers)


def test_two_storeys_round_trip(tmp_path):
    scene = box_scene(room_boxes(height=2.5) + [((0.5, 2.9, 0.5), (3.5, 3.0, 3.5))], "two-storey")
    built = NavMesh.build(scene, NavMeshSettings())
    from rvn_data.navmesh.detour_write import write_navmesh_file

    nm = load_navmesh_file(write_navmesh_file(built, tmp_path / "two.navmesh"), NavMeshSettings(), scene)
    down, up = np.array([2.0, 0.0, 2.0]), np.array([2.0, 3.0, 2.0])
    assert nm.num_islands == 2 and len(nm.layers) == 2
    assert nm.island_of(down) != nm.island_of(up)
    assert nm.floor_height(up) == pytest.approx(3.0, abs=0.011) and nm.floor_height(down) == pytest.approx(0.0, abs=0.011)
    assert sorted(nm.island_areas) == pytest.approx(sorted(built.island_areas), rel=0.06)

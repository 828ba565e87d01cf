"""Mesh files (GLB/OBJ/PLY), up-axis / unit / levelling options, scene lists, HM3D layout."""
from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest
import trimesh
from PIL import Image

from conftest import box_scene, room_boxes
from rvn_data.navmesh import NavMesh
from rvn_data.scenes import NEUTRAL_GREY, SceneError, load_mesh_file, load_scene, scene_specs
from rvn_data.scenes import mesh_file
from rvn_data.scenes.basis_textures import join_glb, split_glb
from rvn_data.scenes.sets import shared_splits


def _room_mesh() -> trimesh.Trimesh:
    v, f = box_scene(room_boxes(3.0, 3.0)).triangles()
    return trimesh.Trimesh(v.astype(np.float64), f, process=False)


def test_dream_apartment_materials(dream_path):
    scene = load_scene(dream_path)
    assert scene.scene_id == "dream_apartment" and scene.num_triangles == 177_934
    assert len(scene.parts) == 67 and all(p.texture is None for p in scene.parts)
    assert len({p.base_color for p in scene.parts}) > 10
    lo, hi = scene.bounds
    assert hi[1] - lo[1] == pytest.approx(2.78, abs=0.02)


def test_z_up_millimetres_round_trip(tmp_path):
    mesh = _room_mesh()
    zup = mesh.copy()
    zup.vertices = np.stack([mesh.vertices[:, 0], -mesh.vertices[:, 2], mesh.vertices[:, 1]], 1) * 1000.0
    zup.export(tmp_path / "room_zup_mm.glb")
    scene = load_mesh_file(tmp_path / "room_zup_mm.glb", up_axis="z", unit_scale=0.001)
    v, f = scene.triangles()
    assert np.allclose(v, mesh.vertices, atol=1e-4)
    assert np.array_equal(f, mesh.faces)  # a proper rotation keeps the winding
    nm = NavMesh.build(scene)
    assert nm.navigable_area == pytest.approx((3 - 0.36) ** 2, rel=0.02)


def test_level_rotates_tilted_floor(tmp_path):
    mesh = _room_mesh()
    mesh.apply_transform(trimesh.transformations.rotation_matrix(math.radians(8), [1, 0, 0]))
    mesh.export(tmp_path / "tilted.ply")
    scene = load_mesh_file(tmp_path / "tilted.ply", level=True)
    v, _ = scene.triangles()
    floor = v[v[:, 1] < v[:, 1].min() + 0.2]
    assert np.ptp(floor[:, 1]) < 0.11  # the floor box is 0.1 m thick: flat again
    assert NavMesh.build(scene).navigable_area == pytest.approx((3 - 0.36) ** 2, rel=0.03)


def test_texture_uv_and_grey_default(tmp_path):
    tex = np.zeros((8, 4, 3), np.uint8)
    tex[:4] = (255, 0, 0)  # top half red
    plane = trimesh.creation.box(extents=[1, 0.1, 1])
    uv = np.tile([[0.5, 0.9]], (len(plane.vertices), 1))
    mat = trimesh.visual.material.PBRMaterial(name="painted", baseColorTexture=Image.fromarray(tex),
                                              baseColorFactor=[255, 255, 255, 255])
    plane.visual = trimesh.visual.TextureVisuals(uv=uv, material=mat)
    bare = trimesh.creation.box(extents=[1, 1, 1])
    bare.apply_translation([3, 0, 0])
    trimesh.Scene([plane, bare]).export(tmp_path / "tex.glb")
    scene = load_mesh_file(tmp_path / "tex.glb")
    by_name = {p.name: p for p in scene.parts}
    painted = by_name["painted"]
    assert painted.texture.shape == (8, 4, 3) and painted.texture.dtype == np.uint8
    assert tuple(painted.texture[0, 0]) == (255, 0, 0)  # row 0 is the image top
    assert np.allclose(painted.uv, [0.5, 0.9], atol=1e-6)  # v = 0.9 samples the top half
    others = [p for p in scene.parts if p is not painted]
    assert len(others) == 1 and others[0].texture is None
    assert others[0].base_color == pytest.approx(NEUTRAL_GREY, abs=0.01) or others[0].colors is not None


def test_a_texture_larger_than_pils_bomb_limit_is_kept(tmp_path, monkeypatch):
    """PIL refuses images over twice MAX_IMAGE_PIXELS (179 megapixels; Gibson ships a 16k x 16k texture) and trimesh
    then dropped the texture without a word: a scan's textures load whatever their size, PIL's limit kept after."""
    import PIL.Image

    monkeypatch.setattr(PIL.Image, "MAX_IMAGE_PIXELS", 100)  # the 16 x 16 texture below is 2.56 times it
    tex = np.full((16, 16, 3), (10, 200, 30), np.uint8)
    room = _room_mesh()
    room.visual = trimesh.visual.TextureVisuals(uv=np.full((len(room.vertices), 2), 0.5), material=
                                                trimesh.visual.material.PBRMaterial(baseColorTexture=Image.fromarray(tex)))
    room.export(tmp_path / "big_texture.glb")
    scene = load_mesh_file(tmp_path / "big_texture.glb")
    assert np.array_equal(scene.parts[0].texture, tex)
    assert PIL.Image.MAX_IMAGE_PIXELS == 100


@pytest.mark.parametrize("kind", ["obj", "gltf"])
def test_a_texture_file_missing_beside_the_scan_is_said(tmp_path, kind, capsys):
    """trimesh reads a texture image it cannot open (here missing beside the OBJ's MTL or the glTF) as none, saying
    so only in a debug record: the loader warns, naming the file, and the material renders in its base colour."""
    room = _room_mesh()
    room.visual = trimesh.visual.TextureVisuals(uv=np.full((len(room.vertices), 2), 0.5), material=
                                                trimesh.visual.material.SimpleMaterial(
                                                    name="wall", image=Image.fromarray(np.zeros((4, 4, 3), np.uint8))))
    if kind == "obj":
        room.export(tmp_path / "room.obj")
        image = next(tmp_path.glob("*.png"))
        image.unlink()
    else:  # the GLB as a .gltf whose image is a file beside it, not there
        doc, binary = split_glb(trimesh.Scene([room]).export(file_type="glb"), tmp_path / "room.glb")
        image = tmp_path / "albedo.png"
        doc["images"][0] = {"uri": image.name}
        doc["buffers"][0]["uri"] = "room.bin"
        (tmp_path / "room.bin").write_bytes(binary)
        (tmp_path / "room.gltf").write_text(json.dumps(doc))
    with pytest.warns(UserWarning, match=rf"room\.{kind}.*1 texture image\(s\) cannot be read.*{image.name}.*base colours"):
        scene = load_mesh_file(tmp_path / f"room.{kind}")
    assert all(p.texture is None for p in scene.parts)
    from rvn_data.cli.scene import main, material_summary  # what rvn-scene info shows of it

    assert main(["info", str(tmp_path / f"room.{kind}")]) == 0  # the warning in one line, named by the command
    said = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(said) == 1 and said[0].startswith(f"rvn-scene info: warning: mesh file '{tmp_path / f'room.{kind}'}': 1 "
                                                 f"texture image(s) cannot be read"), said

    assert material_summary(scene) | {"texture_megapixels": 0} == {
        "textured": 0, "vertex_colored": 0, "base_color": 1, "texture_megapixels": 0, "textured_area_share": 0.0}


@pytest.mark.parametrize("required, said", [
    (["EXT_meshopt_compression"], r"requires the glTF extension\(s\) EXT_meshopt_compression.*save the scene without"),
    (["KHR_draco_mesh_compression"], r"KHR_draco_mesh_compression.*pip install DracoPy"),
    (["KHR_mesh_quantization", "KHR_draco_mesh_compression"], r"KHR_draco_mesh_compression, KHR_mesh_quantization.*"
                                                                r"without them.*DracoPy decodes the Draco one"),
    (["KHR_materials_pbrSpecularGlossiness"], None)])
def test_a_gltf_requiring_an_extension_trimesh_does_not_decode_is_refused(tmp_path, monkeypatch, required, said):
    """trimesh reads a compressed or quantised glTF's geometry as placeholder zeros (a log line at most): refused,
    naming the extension; one it reads loads."""
    monkeypatch.setitem(sys.modules, "DracoPy", None)  # not installed, here as on CI
    doc, binary = split_glb(_room_mesh().export(file_type="glb"), tmp_path / "room.glb")
    doc["extensionsUsed"] = doc["extensionsRequired"] = required
    (tmp_path / "room.glb").write_bytes(join_glb(doc, binary))
    if said is None:
        assert load_mesh_file(tmp_path / "room.glb").num_triangles == len(_room_mesh().faces)
        return
    with pytest.raises(SceneError, match=r"room\.glb.*" + said):
        load_mesh_file(tmp_path / "room.glb")


def test_geometry_read_as_zeros_is_not_blamed_on_units(tmp_path):
    """A position accessor without data (a compressed file's placeholder, extension not declared required) reads as
    zeros: the error says the geometry was not read, not which scenes.unit_scale would make a point a room."""
    doc, binary = split_glb(_room_mesh().export(file_type="glb"), tmp_path / "room.glb")
    doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]].pop("bufferView")
    (tmp_path / "zeros.glb").write_bytes(join_glb(doc, binary))
    with pytest.raises(SceneError, match=r"zeros\.glb': every vertex lies at one point, so its geometry was not read") as err:
        load_mesh_file(tmp_path / "zeros.glb")
    assert "unit_scale" not in str(err.value)


def test_undecodable_texture_warns_and_falls_back():
    class Broken:
        def convert(self, mode):
            raise OSError("truncated PNG")

    with pytest.warns(UserWarning, match="'marble'.*base colour"):
        assert mesh_file._texture(Broken(), "marble") is None


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(SceneError, match="nope.glb.*not found"):
        load_scene(tmp_path / "nope.glb")
    bad = tmp_path / "garbage.glb"
    bad.write_bytes(b"this is not a glb file")
    with pytest.raises(SceneError, match="garbage.glb"):
        load_scene(bad)
    with pytest.raises(SceneError, match="procedural:<split>/<index>"):
        load_scene("procedural:train")


def test_a_mesh_folder_of_habitat_downloads_lists_each_scan_once(tmp_path):
    """HM3D's folders hold <id>.glb and/or <id>.basis.glb (the same scan; the latter alone in its Habitat download)
    and <id>.semantic.glb (object ids as colours); MP3D's <id>_semantic.ply: a scene each, its semantic mesh none."""
    names = ["A.glb", "A.basis.glb", "A.semantic.glb", "B.basis.glb", "B.semantic.glb", "C.glb", "C_semantic.ply",
             "D.ply", "E.semantic.glb"]
    for name in names:
        (tmp_path / name).write_bytes(b"")
    listed = [p.split("/")[-1] for p in scene_specs("mesh_dir", "val", root=tmp_path)]
    assert listed == ["A.glb", "B.basis.glb", "C.glb", "D.ply", "E.semantic.glb"]  # E: no scan beside it, kept
    # a folder a scan (MP3D: <id>/<id>.glb; HM3D's Habitat download: <split>/<NNNNN-id>/<id>.basis.glb)
    for folder, files in (("mp3d/17DRP5sb8fy", ["17DRP5sb8fy.glb", "17DRP5sb8fy_semantic.ply", "17DRP5sb8fy.navmesh"]),
                          ("mp3d/1LXtFkjw3qL", ["1LXtFkjw3qL.glb"]),
                          ("hm3d/val/00800-TEEsavR23oF", ["TEEsavR23oF.basis.glb", "TEEsavR23oF.semantic.glb"])):
        (tmp_path / folder).mkdir(parents=True)
        for name in files:
            (tmp_path / folder / name).write_bytes(b"")
    assert [p.split("/")[-1] for p in scene_specs("mesh_dir", "val", root=tmp_path / "mp3d")] == [
        "17DRP5sb8fy.glb", "1LXtFkjw3qL.glb"]
    assert [p.split("/")[-1] for p in scene_specs("mesh_dir", "val", root=tmp_path / "hm3d")] == ["TEEsavR23oF.basis.glb"]
    for room in ("room_0", "room_1"):  # Replica: <room>/mesh.ply, one scene name for both
        (tmp_path / "replica" / room).mkdir(parents=True)
        (tmp_path / "replica" / room / "mesh.ply").write_bytes(b"")
    with pytest.raises(SceneError, match=r"replica.*room_0/mesh.ply' and .*room_1/mesh.ply' would both be scene 'mesh'"):
        scene_specs("mesh_dir", "val", root=tmp_path / "replica")
    (tmp_path / "empty" / "sub").mkdir(parents=True)
    with pytest.raises(SceneError, match="no mesh files.*empty.*or in its folders"):
        scene_specs("mesh_dir", "val", root=tmp_path / "empty")


def test_scene_specs(tmp_path):
    assert len(scene_specs("procedural", "train")) == 800
    assert scene_specs("procedural", "test", num_scenes=2, first_scene=48) == ["procedural:test/48", "procedural:test/49"]
    assert len(scene_specs("procedural", "val")) == 50
    (tmp_path / "meshes" / "val").mkdir(parents=True)
    for name in ("b.glb", "a.obj", "notes.txt"):
        (tmp_path / "meshes" / "val" / name).write_text("x")
    assert [s.split("/")[-1] for s in scene_specs("mesh_dir", "val", root=tmp_path / "meshes")] == ["a.obj", "b.glb"]
    # a split without its folder takes every mesh directly in the root, as each other split without one: named
    assert shared_splits("mesh_dir", "val", tmp_path / "meshes") == []
    assert shared_splits("mesh_dir", "train", tmp_path / "meshes") == ["test"]
    (tmp_path / "meshes" / "test").mkdir()
    assert shared_splits("mesh_dir", "train", tmp_path / "meshes") == []  # its meshes are no other split's
    (tmp_path / "flat").mkdir()
    assert shared_splits("mesh_dir", "train", tmp_path / "flat") == ["val", "test"]
    assert shared_splits("mesh_dir", "val", tmp_path / "meshes" / "val" / "b.glb") == []  # one mesh: a choice
    assert shared_splits("procedural", "val", None) == [] == shared_splits("mesh_dir", "val", None)
    listing = tmp_path / "list.txt"
    (tmp_path / "abs").mkdir()
    (tmp_path / "abs" / "c.ply").write_text("x")
    listing.write_text(f"# scenes\nmeshes/val/b.glb\n\n{tmp_path}/abs/c.ply\n")
    assert scene_specs("mesh_dir", "train", root=listing) == [str(tmp_path / "meshes/val/b.glb"), f"{tmp_path}/abs/c.ply"]
    assert scene_specs("list_file", "train", root=listing)[1] == f"{tmp_path}/abs/c.ply"
    # one mesh file is a set of one scene; a listed file that does not exist, or a binary file, is named
    assert scene_specs("mesh_dir", "val", root=tmp_path / "meshes" / "val" / "b.glb") == [str(tmp_path / "meshes/val/b.glb")]
    listing.write_text("meshes/val/b.glb\nmeshes/val/gone.glb\n")
    with pytest.raises(SceneError, match="1 mesh file.*do not exist.*gone.glb"):
        scene_specs("list_file", "val", root=listing)
    (tmp_path / "blob.bin").write_bytes(b"glTF\xdf\xff\x00")
    with pytest.raises(SceneError, match="neither a text file listing meshes nor a mesh file"):
        scene_specs("mesh_dir", "val", root=tmp_path / "blob.bin")
    for sid, files in (("00800-TEEsavR23oF", ["TEEsavR23oF.basis.glb", "TEEsavR23oF.glb"]),
                       ("00801-HaxA7YrQdEC", ["HaxA7YrQdEC.basis.glb", "HaxA7YrQdEC.basis.navmesh"])):
        d = tmp_path / "hm3d" / "val" / sid
        d.mkdir(parents=True)
        for f in files:
            (d / f).write_text("x")
    specs = scene_specs("hm3d", "val", root=tmp_path / "hm3d")
    assert [s.split("/")[-1] for s in specs] == ["TEEsavR23oF.glb", "HaxA7YrQdEC.basis.glb"]
    with pytest.raises(SceneError, match="train"):
        scene_specs("hm3d", "train", root=tmp_path / "hm3d")
    with pytest.raises(ValueError, match="needs a root"):
        scene_specs("mesh_dir", "train")


@pytest.mark.parametrize("kind", ["float_rgb", "float_rgba", "uint16_rgba", "uint16_other", "uint8_rgba"])
def test_gltf_vertex_colours_of_every_stored_kind_beside_a_texture(tmp_path, kind):
    """glTF's COLOR_0 may be float (0-1), normalised 16- or 8-bit, RGB or RGBA. Beside a material trimesh keeps it as
    stored: cast to uint8 as it was, float 0.8 became 0 (the textured quad rendered black), and RGB rows were regrouped
    by four."""
    import base64
    import io

    verts = np.array([[0, 0, 0], [4, 0, 0], [4, 0, 4], [0, 0, 4]], np.float32)
    faces, uv = np.array([[0, 2, 1], [0, 3, 2]], np.uint16), np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    width = 3 if kind == "float_rgb" else 4
    colors, component = {"float_rgb": (np.full((4, 3), 0.8, np.float32), 5126),
                         "float_rgba": (np.full((4, 4), 0.8, np.float32), 5126),
                         "uint16_rgba": (np.full((4, 4), 52428, np.uint16), 5123),  # 0.8: 0xCCCC
                         "uint16_other": (np.full((4, 4), 50000, np.uint16), 5123),  # 195 (its low byte 80)
                         "uint8_rgba": (np.full((4, 4), 204, np.uint8), 5121)}[kind]
    png = io.BytesIO()
    Image.new("RGB", (8, 8), (200, 100, 50)).save(png, "PNG")
    data, views = b"", []
    for blob in (verts.tobytes(), faces.tobytes(), uv.tobytes(), colors.tobytes()):
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(blob)})
        data += blob + b"\0" * (-len(blob) % 4)
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 2, "COLOR_0": 3}, "indices": 1,
                                       "material": 0}]}],
           "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}], "textures": [{"source": 0}],
           "images": [{"uri": "data:image/png;base64," + base64.b64encode(png.getvalue()).decode()}],
           "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
           "bufferViews": views,
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": verts.min(0).tolist(), "max": verts.max(0).tolist()},
                         {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
                         {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
                         {"bufferView": 3, "componentType": component, "count": 4, "type": f"VEC{width}",
                          "normalized": component != 5126}]}
    (tmp_path / "quad.gltf").write_text(json.dumps(doc))
    (part,) = load_mesh_file(tmp_path / "quad.gltf").parts
    assert part.texture is not None and part.colors.shape == (4, 4)
    value = 195 if kind == "uint16_other" else 204
    np.testing.assert_array_equal(part.colors, np.tile([value, value, value, value if width == 4 else 255], (4, 1)))

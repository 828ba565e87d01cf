"""Basis Universal textures (HM3D's and Habitat's .basis.glb: GOOGLE_texture_basis; glTF's KHR_texture_basisu): a
scan that stores them renders with them, through load_scene and rvn-scene, as its twin with the same pixels as PNG.

The images are real Basis Universal files from BinomialLLC/basis_universal (Apache-2.0): tests/data/basis/README.md."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import opengl_basisu
import pytest
import trimesh
from PIL import Image

from conftest import box_scene, room_boxes
from rvn_data.scenes import SceneError, load_scene
from rvn_data.scenes.basis_textures import join_glb, split_glb

DATA = Path(__file__).parent / "data" / "basis"
KINDS = {"ktx2": ("kodim23.ktx2", "image/ktx2", "KHR_texture_basisu"),
         "basis": ("kodim01_mipmapped.basis", "image/x-basis", "GOOGLE_texture_basis")}  # the latter: HM3D's


def pixels(blob: bytes) -> np.ndarray:
    """RGB of a Basis image's first level as stored (rows not turned)."""
    texture = opengl_basisu.open(blob)
    return np.asarray(texture.transcode("rgba8").data).reshape(texture.height, texture.width, 4)[..., :3]


def room_glb(texture: np.ndarray) -> bytes:
    """A 3 x 3 m room whose every face samples ``texture`` (UVs from positions), as a GLB with a PNG image."""
    v, f = box_scene(room_boxes(3.0, 3.0)).triangles()
    v = v.astype(np.float64)
    uv = np.stack([(v[:, 0] + v[:, 2]) / 6.0, v[:, 1] / 3.0], 1)
    material = trimesh.visual.material.PBRMaterial(name="scan", baseColorTexture=Image.fromarray(texture),
                                                   baseColorFactor=[255, 255, 255, 255])
    mesh = trimesh.Trimesh(v, f, process=False, visual=trimesh.visual.TextureVisuals(uv=uv, material=material))
    return trimesh.Scene([mesh]).export(file_type="glb")


def as_basis(glb: bytes, blob: bytes, mime: str, extension: str) -> bytes:
    """``glb`` with its image replaced by the Basis image ``blob``, referenced as ``extension`` does."""
    doc, binary = split_glb(glb, Path("room.glb"))
    binary = bytearray(binary) + b"\0" * (-len(binary) % 4)
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(blob)})
    binary += blob
    doc["buffers"][0]["byteLength"] = len(binary)
    doc["images"] = [{"bufferView": len(doc["bufferViews"]) - 1, "mimeType": mime}]
    for texture in doc["textures"]:
        texture["extensions"] = {extension: {"source": texture.pop("source")}}
    doc["extensionsUsed"] = doc["extensionsRequired"] = [extension]
    return join_glb(doc, bytes(binary))


def flagged_y_flipped(blob: bytes) -> bytes:
    """A .basis file's header with its y-flipped flag set (bit 2 of m_flags) and its CRC-16 made again."""
    def crc16(data: bytes) -> int:
        crc = 0xFFFF
        for byte in data:
            q = byte ^ (crc >> 8)
            k = (q >> 4) ^ q
            crc = ((crc << 8) ^ k ^ (k << 5) ^ (k << 12)) & 0xFFFF
        return ~crc & 0xFFFF

    out = bytearray(blob)
    out[21] |= 2
    header_size = int.from_bytes(out[4:6], "little")
    out[6:8] = crc16(bytes(out[8:header_size])).to_bytes(2, "little")
    assert opengl_basisu.open(bytes(out)).y_flipped
    return bytes(out)


@pytest.fixture(scope="module", params=sorted(KINDS))
def scans(request, tmp_path_factory):
    """(the scan with a Basis texture, its twin with the same pixels as a PNG, those pixels, the Basis image)."""
    name, mime, extension = KINDS[request.param]
    blob = (DATA / name).read_bytes()
    rgb = pixels(blob)
    folder = tmp_path_factory.mktemp(request.param)
    png = folder / "room_png.glb"
    png.write_bytes(room_glb(rgb))
    basis = folder / "room.basis.glb"
    basis.write_bytes(as_basis(room_glb(rgb), blob, mime, extension))
    return basis, png, rgb, blob


def test_a_basis_scan_loads_the_pixels_of_its_png_twin(scans):
    basis, png, rgb, _ = scans
    ours, twin = load_scene(basis), load_scene(png)
    assert len(ours.parts) == len(twin.parts) == 1
    assert np.array_equal(ours.parts[0].texture, rgb) and rgb.std() > 20  # a photograph, not a flat colour
    for a, b in ((ours.triangles(), twin.triangles()), ((ours.parts[0].uv,), (twin.parts[0].uv,))):
        assert all(np.array_equal(x, y) for x, y in zip(a, b))


def test_the_texture_is_the_picture_it_was_encoded_from(scans):
    """Independent of the transcoder's own flags: the texture read from the scan, shrunk to 96 x 64, is the Kodak
    picture its Basis file was encoded from (tests/data/basis/*_thumb.png: the original PNG shrunk the same way) to
    within the codec's loss; upside down or in BGR order it is 20-45 levels off."""
    basis = scans[0]
    picture = "kodim23" if "ktx2" in str(basis.parent.name) else "kodim01"
    thumb = np.asarray(Image.open(DATA / f"{picture}_thumb.png").convert("RGB")).astype(int)
    ours = cv2.resize(load_scene(basis).parts[0].texture, (96, 64), interpolation=cv2.INTER_AREA).astype(int)
    assert np.abs(ours - thumb).mean() < 3  # 0.9 (KTX 2) and 1.6 (.basis) levels of 255
    assert np.abs(ours[::-1] - thumb).mean() > 20 and np.abs(ours[..., ::-1] - thumb).mean() > 20


def test_a_y_flipped_basis_image_is_turned_top_row_first(tmp_path):
    blob = (DATA / KINDS["basis"][0]).read_bytes()
    rgb = pixels(blob)
    path = tmp_path / "flipped.basis.glb"
    path.write_bytes(as_basis(room_glb(rgb), flagged_y_flipped(blob), "image/x-basis", "GOOGLE_texture_basis"))
    assert np.array_equal(load_scene(path).parts[0].texture, rgb[::-1])  # stored bottom row first, as flagged


def test_a_gltf_with_its_basis_image_beside_it(scans, tmp_path):
    basis, png, rgb, blob = scans
    doc, binary = split_glb(basis.read_bytes(), basis)
    image = doc["images"][0]
    view = doc["bufferViews"][image.pop("bufferView")]
    suffix = ".ktx2" if image["mimeType"] == "image/ktx2" else ".basis"
    (tmp_path / f"albedo{suffix}").write_bytes(binary[view["byteOffset"]:view["byteOffset"] + view["byteLength"]])
    image["uri"] = f"albedo{suffix}"
    (tmp_path / "room.bin").write_bytes(binary)
    doc["buffers"][0]["uri"] = "room.bin"
    (tmp_path / "room.gltf").write_text(json.dumps(doc))
    assert np.array_equal(load_scene(tmp_path / "room.gltf").parts[0].texture, rgb)
    (tmp_path / "external.glb").write_bytes(join_glb(doc, b""))  # a GLB whose buffer is that file: no BIN chunk
    assert np.array_equal(load_scene(tmp_path / "external.glb").parts[0].texture, rgb)


def test_rvn_scene_views_of_a_basis_scan_are_its_png_twins(scans, tmp_path):
    basis, png, _, _ = scans
    frames = {}
    for name, path in (("basis", basis), ("png", png)):
        r = subprocess.run([sys.executable, "-m", "rvn_data.cli.scene", "views", str(path), "-o", str(tmp_path / name),
                            "--n", "2", "--backend", "raycast"], capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
        frames[name] = sorted((tmp_path / name).glob("*.png"))
    assert len(frames["basis"]) == len(frames["png"]) >= 2
    for a, b in zip(frames["basis"], frames["png"]):
        view = cv2.imread(str(a))
        assert np.array_equal(view, cv2.imread(str(b))) and view.std() > 10, a.name


def test_without_the_transcoder_a_basis_scan_is_refused_naming_the_install(scans, monkeypatch):
    monkeypatch.setitem(sys.modules, "opengl_basisu", None)  # as if not installed: importlib finds no spec
    with pytest.raises(SceneError, match=r"room\.basis\.glb.*1 texture.*Basis Universal.*pip install 'rvn\[basis\]'"):
        load_scene(scans[0])


def test_a_corrupt_basis_image_names_the_file_and_image(tmp_path):
    rgb = np.zeros((4, 4, 3), np.uint8)
    path = tmp_path / "broken.basis.glb"
    path.write_bytes(as_basis(room_glb(rgb), b"sB" + bytes(200), "image/x-basis", "GOOGLE_texture_basis"))
    with pytest.raises(SceneError, match=r"broken\.basis\.glb.*image 0.*cannot be decoded"):
        load_scene(path)


def test_a_plain_glb_is_read_by_trimesh_as_before(tmp_path):
    path = tmp_path / "room.glb"
    path.write_bytes(room_glb(np.full((4, 4, 3), 200, np.uint8)))
    from rvn_data.scenes.basis_textures import decoded_gltf

    assert decoded_gltf(path) is None
    assert load_scene(path).parts[0].texture.shape == (4, 4, 3)


def test_benchmark_prints_ms_per_megapixel_and_a_scans_share(scans, monkeypatch, capsys):
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import basis_textures

    basis_textures.main(["--repeats", "1", "--scan", str(scans[0])])
    lines = capsys.readouterr().out.splitlines()
    assert [ln.split(":")[0] for ln in lines] == ["kodim23.ktx2", "kodim01_mipmapped.basis", "room.basis.glb"]
    assert all(re.search(r"768x512, [\d.]+ ms = [\d.]+ ms per megapixel", ln) for ln in lines[:2]), lines
    assert re.search(r"load_scene [\d.]+ ms, of which decoding its Basis textures [\d.]+ ms \(\d+%\)", lines[2])


def test_rvn_scene_info_counts_the_textured_materials(scans, capsys):
    """rvn-scene info says how a scan's materials are coloured: its Basis texture read, or (without the transcoder's
    decoding, as before) every material in a base colour alone."""
    from rvn_data.cli.scene import main

    assert main(["info", str(scans[0]), "--json"]) == 0
    materials = json.loads(capsys.readouterr().out)["materials"]
    assert materials == {"textured": 1, "vertex_colored": 0, "base_color": 0, "texture_megapixels": 0.393,
                         "textured_area_share": 1.0}
    assert main(["info", str(scans[0])]) == 0
    assert "materials  1 textured (0.4 megapixels), 0 vertex-coloured, 0 in a base colour alone; 100% of the " \
           "surface textured" in capsys.readouterr().out

"""Basis Universal textures in glTF files: decoded, so that scans as Habitat ships them render with their colours.

HM3D's Habitat download (``<id>.basis.glb``, the only mesh in ``hm3d-*-habitat-v0.2``), and Habitat's Gibson and
MP3D scenes, store every texture as a Basis Universal image (``image/x-basis``, referenced through the
``GOOGLE_texture_basis`` extension); glTF's standard form is a KTX 2 image (``image/ktx2``, ``KHR_texture_basisu``).
trimesh reads neither and skips them without a word, so such a scan rendered in its materials' base colour alone.

:func:`decoded_gltf` rewrites such a file in memory before trimesh reads it: each Basis image transcoded to RGB
pixels by Binomial's transcoder (``opengl_basisu``, the optional ``rvn[basis]``), turned the right way up (a
``.basis`` file flagged y-flipped stores its bottom row first, as Habitat's own loaders and the batch renderer of
Shacklett et al. read it), stored as an uncompressed PPM that PIL reads back at memory speed, and each texture
pointed at it. The geometry is untouched. Without ``opengl_basisu`` such a file is refused, naming the install,
rather than rendered grey.
"""
from __future__ import annotations

import base64
import importlib.util
import json
import struct
from pathlib import Path

import numpy as np

from rvn_data.scenes.scene import SceneError

BASIS_EXTENSIONS = ("KHR_texture_basisu", "GOOGLE_texture_basis")
BASIS_MIME_TYPES = ("image/ktx2", "image/x-basis", "image/basis")
INSTALL = "pip install 'rvn[basis]' (opengl_basisu, Binomial's Basis Universal transcoder)"
_GLB_MAGIC, _JSON, _BIN = b"glTF", b"JSON", b"BIN\0"


def split_glb(blob: bytes, path: Path) -> tuple[dict, bytes]:
    """(glTF JSON, BIN chunk or b"") of a binary glTF."""
    if len(blob) < 20 or blob[:4] != _GLB_MAGIC or blob[16:20] != _JSON:
        raise SceneError(f"cannot read mesh file {str(path)!r}: not a binary glTF (GLB) file")
    length = struct.unpack_from("<I", blob, 12)[0]
    doc = json.loads(blob[20:20 + length])
    start = 20 + length
    if len(blob) >= start + 8 and blob[start + 4:start + 8] == _BIN:
        size = struct.unpack_from("<I", blob, start)[0]
        return doc, blob[start + 8:start + 8 + size]
    return doc, b""


def join_glb(doc: dict, binary: bytes) -> bytes:
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<I4s", len(text), _JSON) + text
    if binary:  # no BIN chunk where buffer 0 is a file of its own
        body += struct.pack("<I4s", len(binary), _BIN) + binary
    return struct.pack("<4sII", _GLB_MAGIC, 2, 12 + len(body)) + body


def gltf_json(path: Path) -> dict | None:
    """The JSON of a GLB (its first chunk, the binary chunk not read) or .gltf file; None for other files and for
    what does not parse (trimesh then says why)."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".gltf":
            return json.loads(path.read_bytes())
        if suffix == ".glb":
            with open(path, "rb") as f:
                head = f.read(20)
                if len(head) < 20 or head[:4] != _GLB_MAGIC or head[16:20] != _JSON:
                    return None
                return json.loads(f.read(struct.unpack_from("<I", head, 12)[0]))
    except (ValueError, UnicodeDecodeError):
        return None
    return None


def basis_images(doc: dict) -> list[int]:
    """Indices of the glTF's images in a Basis Universal format (by MIME type, file suffix or the textures'
    Basis extensions)."""
    images = doc.get("images", [])
    found = {i for i, image in enumerate(images) if image.get("mimeType") in BASIS_MIME_TYPES
             or str(image.get("uri", "")).lower().endswith((".ktx2", ".basis"))}
    for texture in doc.get("textures", []):
        for name in BASIS_EXTENSIONS:
            source = texture.get("extensions", {}).get(name, {}).get("source")
            if isinstance(source, int) and 0 <= source < len(images):
                found.add(source)
    return sorted(found)


def transcode(data: bytes, what: str) -> np.ndarray:
    """uint8 RGB [H, W, 3] of a KTX 2 or .basis image's first level, top row first."""
    import opengl_basisu

    try:
        texture = opengl_basisu.open(bytes(data))
        rgba = np.asarray(texture.transcode("rgba8").data, np.uint8).reshape(texture.height, texture.width, 4)
    except (opengl_basisu.BasisuError, ValueError) as exc:
        raise SceneError(f"{what}: the Basis Universal image cannot be decoded ({exc})") from exc
    rgb = rgba[..., :3]
    return np.ascontiguousarray(rgb[::-1] if texture.y_flipped else rgb)


def _ppm(rgb: np.ndarray) -> bytes:
    return b"P6 %d %d 255\n" % (rgb.shape[1], rgb.shape[0]) + rgb.tobytes()


def _image_bytes(doc: dict, binary: bytes, image: dict, base: Path, what: str) -> bytes:
    if "bufferView" in image:
        view = doc["bufferViews"][image["bufferView"]]
        offset = view.get("byteOffset", 0)
        return binary[offset:offset + view["byteLength"]]
    uri = str(image.get("uri", ""))
    if uri.startswith("data:"):
        return base64.b64decode(uri.split(",", 1)[1])
    file = base / uri
    if not file.is_file():
        raise SceneError(f"{what}: its image file {str(file)!r} is missing")
    return file.read_bytes()


def decoded_gltf(path: str | Path, doc: dict | None = None) -> tuple[bytes, str] | None:
    """The GLB/glTF file at ``path`` with its Basis Universal images decoded, as (bytes, trimesh file type); None
    when it holds none (trimesh reads the file itself). ``doc``: its JSON, where the caller read it (`gltf_json`).
    SceneError without ``opengl_basisu``, naming the install."""
    path = Path(path)
    suffix = path.suffix.lower()
    if doc is None:
        doc = gltf_json(path)  # the JSON alone: a file without Basis images is not read further here
    targets = basis_images(doc) if doc is not None else []
    if not targets:
        return None
    if suffix == ".glb":
        doc, binary = split_glb(path.read_bytes(), path)
    else:
        binary = b""
    if importlib.util.find_spec("opengl_basisu") is None:
        raise SceneError(f"mesh file {str(path)!r} stores its {len(targets)} texture(s) as Basis Universal images "
                         f"(as HM3D's and Habitat's .basis.glb do), which RVN decodes with an optional package: "
                         f"{INSTALL}; or give the scene's plain .glb")
    embed = suffix == ".glb" and not (doc.get("buffers") and "uri" in doc["buffers"][0])  # GLB's own buffer 0
    extra = bytearray(binary)
    for i in targets:
        image = doc["images"][i]
        what = f"mesh file {str(path)!r}, image {i}"
        ppm = _ppm(transcode(_image_bytes(doc, binary, image, path.parent, what), what))
        if embed:
            extra += b"\0" * (-len(extra) % 4)
            doc.setdefault("bufferViews", []).append({"buffer": 0, "byteOffset": len(extra), "byteLength": len(ppm)})
            extra += ppm
            doc["images"][i] = {"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/x-portable-pixmap"}
        else:
            doc["images"][i] = {"uri": "data:image/x-portable-pixmap;base64," + base64.b64encode(ppm).decode()}
    for texture in doc.get("textures", []):
        for name in BASIS_EXTENSIONS:
            source = texture.get("extensions", {}).pop(name, {}).get("source")
            if source is not None and (texture.get("source") is None or texture["source"] in targets):
                texture["source"] = source
    for key in ("extensionsUsed", "extensionsRequired"):
        if key in doc:
            doc[key] = [e for e in doc[key] if e not in BASIS_EXTENSIONS]
    if suffix == ".gltf":
        return json.dumps(doc).encode(), "gltf"
    if not embed:
        return join_glb(doc, binary), "glb"
    if doc.get("buffers"):
        doc["buffers"][0]["byteLength"] = len(extra)
    else:
        doc["buffers"] = [{"byteLength": len(extra)}]
    return join_glb(doc, bytes(extra)), "glb"

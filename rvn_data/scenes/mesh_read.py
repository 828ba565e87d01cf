"""A mesh file read by trimesh as a scan's textures need: none dropped without a word.

trimesh reads a texture image it cannot open as none at all, and says so only in a debug log record: a texture file
missing beside an OBJ's MTL or a glTF, an image in a format PIL does not read, a Basis Universal image (HM3D's
.basis.glb), an image over PIL's decompression-bomb limit. The scan then renders in its materials' base colours, and
rvn-gen writes such frames as a dataset. :func:`read_scene` decodes Basis Universal images first
(:mod:`.basis_textures`), lifts PIL's size limit while trimesh reads (a scan's own textures are trusted input; Gibson's
scenes include a 16k x 16k one), and returns what trimesh dropped, which the loader says.
"""
from __future__ import annotations

import contextlib
import importlib.util
import io
import logging
from pathlib import Path

from rvn_data.scenes import basis_textures
from rvn_data.scenes.scene import SceneError

DROPPED_WORDS = ("fail", "unable", "unsupported")  # trimesh's debug records of an image it could not read


class _DroppedImages(logging.Handler):
    """Collects trimesh's records of the images it could not read; passes on the records its logger would have
    passed on (those at or above the level it had)."""

    def __init__(self, passed_on: int):
        super().__init__(logging.DEBUG)
        self.passed_on, self.reasons = passed_on, []

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        if "image" in text.lower() and any(word in text.lower() for word in DROPPED_WORDS):
            err = record.exc_info[1] if record.exc_info else None
            reason = f"{type(err).__name__}: {err}" if err is not None else text
            if reason not in self.reasons:
                self.reasons.append(reason)
        if record.levelno >= self.passed_on:
            logging.getLogger().handle(record)


@contextlib.contextmanager
def _dropped_images():
    log = logging.getLogger("trimesh")
    handler = _DroppedImages(log.getEffectiveLevel())
    saved = log.level, log.propagate
    log.setLevel(logging.DEBUG)
    log.propagate = False  # its debug records stay here; the others are passed on by the handler
    log.addHandler(handler)
    try:
        yield handler.reasons
    finally:
        log.removeHandler(handler)
        log.setLevel(saved[0])
        log.propagate = saved[1]


@contextlib.contextmanager
def _no_image_size_limit():
    import PIL.Image

    limit, PIL.Image.MAX_IMAGE_PIXELS = PIL.Image.MAX_IMAGE_PIXELS, None
    try:
        yield
    finally:
        PIL.Image.MAX_IMAGE_PIXELS = limit


# glTF extensions a file may require (extensionsRequired) that trimesh and RVN read: the Basis textures (decoded
# first), the materials trimesh converts or RVN's shading ignores; KHR_draco_mesh_compression where DracoPy is
# installed (trimesh's decoder). Any other required one (meshopt compression, quantised attributes, texture
# transforms) trimesh reads as placeholder zeros or ignores, with a log line at most: such a file is refused.
READ_EXTENSIONS = {"KHR_texture_basisu", "GOOGLE_texture_basis", "EXT_texture_webp", "KHR_materials_pbrSpecularGlossiness",
                   "KHR_materials_unlit", "KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_specular"}


def check_required_extensions(path: Path, doc: dict | None) -> None:
    """SceneError when the GLB/glTF file at ``path``, its JSON ``doc`` (`basis_textures.gltf_json`), requires a glTF
    extension that is not read (see :data:`READ_EXTENSIONS`)."""
    required = set(doc.get("extensionsRequired", [])) if doc else set()
    draco = {"KHR_draco_mesh_compression"} if importlib.util.find_spec("DracoPy") is not None else set()
    missing = sorted(required - READ_EXTENSIONS - draco)
    if missing:
        hint = ("pip install DracoPy (trimesh's Draco decoder)" if missing == ["KHR_draco_mesh_compression"] else
                "save the scene without them (gltf-transform, Blender)" + (
                    "; pip install DracoPy decodes the Draco one" if "KHR_draco_mesh_compression" in missing else ""))
        raise SceneError(f"mesh file {str(path)!r} requires the glTF extension(s) {', '.join(missing)}, which RVN's "
                         f"reader (trimesh) does not decode (it would read zeros or ignore them): {hint}")


def read_scene(path: Path):
    """(trimesh.Scene of ``path``, the reasons of the texture images trimesh dropped). SceneError for a glTF
    extension it requires that is not read, and from :mod:`.basis_textures`; trimesh's own errors as they are."""
    import trimesh  # here, not at module import: procedural scenes (every CLI's default) never need it (0.3 s of start-up)

    doc = basis_textures.gltf_json(path)  # read once: the JSON chunk alone (None for OBJ/PLY)
    check_required_extensions(path, doc)
    decoded = basis_textures.decoded_gltf(path, doc)  # Basis Universal textures (HM3D's .basis.glb) decoded first
    with _no_image_size_limit(), _dropped_images() as dropped:
        if decoded is None:
            loaded = trimesh.load(str(path), force="scene", process=False)
        else:
            loaded = trimesh.load(io.BytesIO(decoded[0]), file_type=decoded[1], force="scene", process=False,
                                  resolver=trimesh.resolvers.FilePathResolver(path))
    return loaded, list(dropped)

"""Load a mesh file (GLB/glTF/OBJ/PLY) into a `Scene` with trimesh.

Scene-graph transforms are applied; geometry is grouped into one `Part` per material with
its UVs, texture image (uint8 RGB; read by `mesh_read`: Basis Universal ones, as in HM3D's .basis.glb, decoded,
and one trimesh could not read said), PBR base colour and vertex colours. Options:
`up_axis="z"` rotates z-up files (HM3D/Habitat) to y-up, hab = (x, z_file, -y_file);
`unit_scale` multiplies coordinates (0.001 for millimetres); `level=True` rotates the scene
so that its dominant floor normal (area-weighted upward-facing normals) is +y. A file that, so read, spans more
than an indoor scene or less than a metre, or stands on its side, is refused, naming the setting to change, and one
whose floor is tilted, not levelled, is said (`rvn_data.scenes.plausibility`).

Colours are used as stored, without a colour-space conversion, and unlit (both renderers): texels (sRGB) come out as
they are in the texture, which is how a textured scan such as HM3D looks; glTF's base-colour factors and vertex colours
are linear by the glTF spec and are also taken as they are, so an untextured model (the dream apartment) renders darker
than a glTF PBR viewer shows it. Converting them would change every frame of such scenes: kept as is on purpose.
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from rvn_data.scenes.mesh_read import read_scene
from rvn_data.scenes.plausibility import check_scene
from rvn_data.scenes.scene import NEUTRAL_GREY, Part, Scene, SceneError

Z_UP_TO_Y_UP = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])
SUFFIXES = (".glb", ".gltf", ".obj", ".ply")


def _texture(image, material_name: str) -> np.ndarray | None:
    if image is None:
        return None
    try:
        return np.ascontiguousarray(np.asarray(image.convert("RGB"), dtype=np.uint8))
    except Exception as exc:  # PIL raises many types for corrupt or unsupported data
        warnings.warn(f"material {material_name!r}: texture cannot be decoded ({exc}); "
                      "using its base colour", stacklevel=3)
        return None


def _material(visual, name: str):
    """(key, name, base_color RGBA float, texture | None) of a geometry's material."""
    mat = getattr(visual, "material", None)
    if mat is None:
        return ("__none__", "default", NEUTRAL_GREY, None)
    mname = getattr(mat, "name", None) or name
    import trimesh

    if isinstance(mat, trimesh.visual.material.PBRMaterial):
        factor = mat.baseColorFactor
        image = mat.baseColorTexture
    else:  # SimpleMaterial (OBJ/MTL)
        factor = getattr(mat, "diffuse", None)
        image = getattr(mat, "image", None)
    base = NEUTRAL_GREY if factor is None else tuple(float(c) / 255.0 for c in np.asarray(factor).ravel()[:4])
    if len(base) == 3:
        base = base + (1.0,)
    return (id(mat), mname, base, _texture(image, mname))


def _pieces(loaded: trimesh.Scene):
    """Yield (world vertices, faces, uv | None, colors | None, material tuple) per graph node."""
    import trimesh

    for node in loaded.graph.nodes_geometry:
        transform, geom_name = loaded.graph[node]
        geom = loaded.geometry[geom_name]
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        verts = trimesh.transform_points(np.asarray(geom.vertices, np.float64), transform)
        faces = np.asarray(geom.faces, np.int64)
        if np.linalg.det(transform[:3, :3]) < 0:
            faces = faces[:, ::-1]
        visual = geom.visual
        uv = colors = None
        if isinstance(visual, trimesh.visual.TextureVisuals):
            mat = _material(visual, str(geom_name))
            if visual.uv is not None and len(visual.uv) == len(verts):
                uv = np.asarray(visual.uv, np.float32)
            vc = visual.vertex_attributes.get("color") if hasattr(visual, "vertex_attributes") else None
            if vc is not None and len(vc) == len(verts):
                colors = rgba8(vc)
        else:
            mat = ("__none__", "default", NEUTRAL_GREY, None)
            kind = getattr(visual, "kind", None)
            if kind == "vertex":
                colors = np.asarray(visual.vertex_colors, np.uint8)
            elif kind == "face":  # unshare vertices so every face keeps its colour
                colors = np.repeat(np.asarray(visual.face_colors, np.uint8), 3, axis=0)
                verts = verts[faces].reshape(-1, 3)
                faces = np.arange(len(verts)).reshape(-1, 3)
        yield verts, faces, uv, colors, mat


def rgba8(values) -> np.ndarray | None:
    """A glTF primitive's COLOR_0 as trimesh keeps it beside a material (the accessor's values as stored) -> uint8
    RGBA [N, 4]: floats in [0, 1], normalised unsigned 8- or 16-bit integers, RGB or RGBA (glTF 2.0 allows each). Cast
    as uint8 alone, float colours became 0 (a textured scan rendered black), 16-bit ones their low byte, and RGB rows
    were regrouped by four; None for another shape (the colours are left out)."""
    v = np.asarray(values)
    if v.ndim != 2 or v.shape[1] not in (3, 4):
        return None
    if v.dtype.kind == "f":
        v = np.rint(np.clip(np.nan_to_num(v), 0.0, 1.0) * 255.0)
    elif v.dtype == np.uint16:
        v = np.rint(v / 257.0)
    v = v.astype(np.uint8)
    return v if v.shape[1] == 4 else np.concatenate([v, np.full((len(v), 1), 255, np.uint8)], axis=1)


def _level_rotation(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Rotation taking the area-weighted mean of upward-facing normals to +y."""
    n = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    area2 = np.linalg.norm(n, axis=1)
    ok = area2 > 0
    unit = n[ok] / area2[ok, None]
    up = unit[:, 1] > math.cos(math.radians(45))
    if not up.any():
        return np.eye(3)
    m = (unit[up] * area2[ok][up, None]).sum(0)
    m /= np.linalg.norm(m)
    axis = np.cross(m, [0.0, 1.0, 0.0])
    s, c = np.linalg.norm(axis), m[1]
    if s < 1e-12:
        return np.eye(3)
    k = axis / s
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def load_mesh_file(path: str | Path, up_axis: str = "y", unit_scale: float = 1.0,
                   level: bool = False, scene_id: str | None = None) -> Scene:
    """Load a GLB/glTF/OBJ/PLY file as a y-up Scene in metres (SceneError if it cannot)."""
    path = Path(path)
    if up_axis not in ("y", "z"):
        raise ValueError(f"up_axis={up_axis!r} must be 'y' or 'z'")
    if not (isinstance(unit_scale, (int, float)) and math.isfinite(unit_scale) and unit_scale > 0):
        raise ValueError(f"unit_scale={unit_scale!r} must be a positive number (0.001 for millimetres)")
    if not path.is_file():
        raise SceneError(f"mesh file {str(path)!r} not found; check the path (GLB/glTF/OBJ/PLY expected)")
    try:
        loaded, dropped = read_scene(path)
    except SceneError:
        raise
    except Exception as exc:
        raise SceneError(f"cannot read mesh file {str(path)!r}: {type(exc).__name__}: {exc}; "
                         "expected a valid GLB/glTF/OBJ/PLY file") from exc
    if dropped:  # one warning a file, however many of its images
        more = f"; and {len(dropped) - 1} more" if len(dropped) > 1 else ""
        warnings.warn(f"mesh file {str(path)!r}: {len(dropped)} texture image(s) cannot be read ({dropped[0]}{more}); "
                      f"their materials render in their base colours: put each image where the file names it, in a "
                      f"format PIL reads", stacklevel=2)
    rot = (Z_UP_TO_Y_UP if up_axis == "z" else np.eye(3)) * float(unit_scale)
    groups: dict = {}
    for verts, faces, uv, colors, mat in _pieces(loaded):
        groups.setdefault(mat[0], (mat, []))[1].append((verts @ rot.T, faces, uv, colors))
    if not groups:
        raise SceneError(f"mesh file {str(path)!r} holds no triangles")
    parts = []
    for (key, name, base, tex), items in groups.values():
        has_uv = any(i[2] is not None for i in items)
        has_col = any(i[3] is not None for i in items)
        verts, faces, uvs, cols, off = [], [], [], [], 0
        for v, f, uv, col in items:
            verts.append(v)
            faces.append(f + off)
            off += len(v)
            uvs.append(uv if uv is not None else np.zeros((len(v), 2), np.float32))
            cols.append(col if col is not None else np.full((len(v), 4), 255, np.uint8))
        parts.append(Part(str(name), np.concatenate(verts), np.concatenate(faces),
                          uv=np.concatenate(uvs) if has_uv and tex is not None else None,
                          colors=np.concatenate(cols) if has_col else None,
                          base_color=base, texture=tex))
    scene = Scene(scene_id or path.name.split(".")[0], parts, source=str(path))
    v, f = scene.triangles()
    check_scene(v, f, path, up_axis, float(unit_scale), level)  # not in metres, on its side, or tilted: said
    if level:
        R = _level_rotation(v.astype(np.float64), f)
        for p in scene.parts:
            p.vertices = np.ascontiguousarray(p.vertices.astype(np.float64) @ R.T, dtype=np.float32)
        scene.levelled = bool(np.abs(R - np.eye(3)).max() > 1e-12)
    return scene

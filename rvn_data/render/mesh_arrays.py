"""The CPU side of a GL renderer's build (`rvn_data.render.gl.GLRenderer`): a scene's interleaved vertex data,
textures, uniforms' bytes and culling chunks, made with numpy and no GL context, so that a helper process can make
them (rvn-rl's scene prefetch, `rvn_data.benchmark.episodes_source.SceneSlot`) and the rendering thread only uploads
them."""
from __future__ import annotations

import struct
from typing import NamedTuple

import numpy as np

from rvn_data.render import base
from rvn_data.render.chunks import Chunks, build_chunks, order_faces
from rvn_data.scenes.scene import Scene


class MeshArrays(NamedTuple):
    """The CPU side of a `GLRenderer`'s build (`mesh_arrays`): per part None (no faces) or (vertex data, the
    interleaved vertices' bytes as a uint8 array; texture [H, W, 3] uint8 bottom row first or None; (base colour,
    texture flag) uniform bytes); the parts' faces in spatial chunks for culling (`chunks.build_chunks`)."""

    parts: list
    chunks: Chunks


def mesh_arrays(scene: Scene) -> MeshArrays:
    """A scene's vertex data, textures and chunk spans, as a `GLRenderer` uploads them: numpy work with no GL context
    (~9 ms of a procedural apartment's ~11 ms renderer build, 2-core development CPU), so rvn-rl's scene prefetch
    has it made in its helper process beside the scene (`rvn_data.benchmark.episodes_source.SceneSlot`) and the
    env's own thread only uploads it."""
    parts, spans = [], []
    for part in scene.parts:
        if len(part.faces) == 0:
            parts.append(None)
            spans.append([])
            continue
        mat = base.prepare_material(scene, part)
        faces, part_spans = order_faces(part.vertices, part.faces)
        corners = faces.reshape(-1)
        data = np.empty(len(corners), dtype=[("pos", "f4", 3), ("uv", "f4", 2), ("col", "u1", 4), ("shade", "f4")])
        data["pos"] = part.vertices[corners]
        data["uv"] = part.uv[corners] if part.uv is not None else 0.0
        data["col"] = part.colors[corners] if part.colors is not None else 255
        data["shade"] = np.repeat(base.face_shade(part.vertices, faces), 3)
        texture = None if mat.texture is None else np.ascontiguousarray(mat.texture[::-1])
        base_rgb = struct.pack("3f", *(float(c) for c in mat.base_rgb))  # the uniforms' bytes
        vertices = data.view(np.uint8)  # an array, not bytes: pickled out of band (`rvn_data.helper_process`)
        parts.append((vertices, texture, (base_rgb, struct.pack("1i", texture is not None))))
        spans.append(part_spans)
    return MeshArrays(parts, build_chunks(spans))

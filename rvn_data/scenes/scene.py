"""The `Scene`: a triangle mesh in metres, y-up, with materials, and a stable id.

A scene is a list of `Part`s. Each part is one material: its own vertices and faces,
optional UVs and texture image, optional per-vertex colours and a base colour. The
navmesh only needs `Scene.triangles()`; renderers use the parts.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

NEUTRAL_GREY = (0.7, 0.7, 0.7, 1.0)


@dataclass
class Part:
    """One material's geometry.

    vertices: float32 [N, 3] world metres (y up); faces: int32 [M, 3], counter-clockwise
    seen from outside (front face); uv: float32 [N, 2] or None, (0, 0) = the image's
    bottom-left as in OpenGL (row 0 of `texture` is the image's top);
    colors: uint8 [N, 4] vertex colours or None; base_color: RGBA in [0, 1], multiplied
    with the texture / vertex colours; texture: uint8 [H, W, 3] or None.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None = None
    colors: np.ndarray | None = None
    base_color: tuple[float, float, float, float] = NEUTRAL_GREY
    texture: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float32).reshape(-1, 3)
        self.faces = np.ascontiguousarray(self.faces, dtype=np.int32).reshape(-1, 3)
        if self.uv is not None:
            self.uv = np.ascontiguousarray(self.uv, dtype=np.float32).reshape(-1, 2)
        if self.colors is not None:
            self.colors = np.ascontiguousarray(self.colors, dtype=np.uint8).reshape(-1, 4)
        if self.texture is not None:
            self.texture = np.ascontiguousarray(self.texture, dtype=np.uint8)
        self.base_color = tuple(float(c) for c in self.base_color)


@dataclass
class Scene:
    """A navigable indoor scene. `scene_id` is stable (e.g. ``procedural:train/12``)."""

    scene_id: str
    parts: list[Part] = field(default_factory=list)
    source: str = ""  # where it came from (a path, or the generator's name)
    levelled: bool = False  # rotated on load to level its floor (scenes.level): a .navmesh beside it does not follow

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """All geometry joined: (vertices float32 [N, 3], faces int32 [M, 3])."""
        verts, faces, offset = [], [], 0
        for part in self.parts:
            verts.append(part.vertices)
            faces.append(part.faces + offset)
            offset += len(part.vertices)
        if not verts:
            return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32)
        return np.concatenate(verts), np.concatenate(faces)

    def fingerprint(self) -> str:
        """Short digest of the triangles (`triangles`): ties a file made from the scene (an episode set, a
        built navmesh) to the exact mesh."""
        v, f = self.triangles()
        h = hashlib.sha1(np.ascontiguousarray(v, np.float32).tobytes())
        h.update(np.ascontiguousarray(f, np.int32).tobytes())
        return h.hexdigest()[:16]

    @property
    def num_triangles(self) -> int:
        return int(sum(len(p.faces) for p in self.parts))

    @property
    def bounds(self) -> np.ndarray:
        """[[xmin, ymin, zmin], [xmax, ymax, zmax]]."""
        v, _ = self.triangles()
        if len(v) == 0:
            return np.zeros((2, 3))
        return np.stack([v.min(0), v.max(0)]).astype(np.float64)


class SceneError(ValueError):
    """A scene cannot be loaded or used; the message names the scene and the reason."""

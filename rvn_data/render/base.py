"""The `Renderer` interface, the shared lighting model and material preparation.

Both back-ends shade a hit with the same formula (so their images agree)::

    shade  = AMBIENT + KEY * |n . LIGHT_DIR|          (`face_shade`, one value per triangle)
    colour = base_color.rgb * vertex_colour.rgb * texture(uv).rgb * shade

with n the triangle's face normal (two-sided), textures sampled NEAREST with REPEAT wrap,
and 0 (black, depth 0) where nothing is hit. The shade is a per-face constant so that
software GL stays fast; floors, and walls of different orientations, differ in brightness.
"""
from __future__ import annotations

import abc
import logging
import math
from dataclasses import dataclass

import numpy as np

from rvn_data.render.camera import CameraConfig
from rvn_data.scenes.scene import Part, Scene, SceneError

log = logging.getLogger("rvn")

AMBIENT = 0.5
KEY = 0.5
LIGHT_DIR = np.array([0.5, 0.75, 0.3]) / np.linalg.norm([0.5, 0.75, 0.3])


class Renderer(abc.ABC):
    """Renders RGB and planar depth from the robot's camera at a floor pose."""

    backend: str = ""
    info: str = ""
    reason: str = ""  # why `make_renderer` picked this back-end

    def __init__(self, scene: Scene, camera: CameraConfig) -> None:
        self.scene = scene
        self.camera = camera

    @abc.abstractmethod
    def render(self, position, yaw: float, depth: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """(rgb uint8 [H, W, 3], depth float32 [H, W] planar metres, 0 = no hit). With
        ``depth=False`` a back-end may skip the depth (returned as None) where that is cheaper."""

    batch_views: int = 64  # views per internal pass of `render_batch` (bigger batches are split)

    def render_batch(self, poses, depth: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Many views in one call: (rgb uint8 [N, H, W, 3], depth float32 [N, H, W] or None with
        ``depth=False``) for ``poses`` [(position [3], yaw), ...], equal to `render` per pose. A
        back-end renders up to `batch_views` views per pass with one synchronisation."""
        return self._render_passes([(self, position, yaw) for position, yaw in check_poses(poses)], depth)

    def _render_passes(self, views: list, depth: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """(rgb [N, H, W, 3], depth [N, H, W] or None) of checked views [(renderer, position, yaw)] of this
        renderer's `pass_group`, drawn in passes of up to `batch_views` (`_render_pass`)."""
        cam = self.camera
        rgb = np.empty((len(views), cam.height, cam.width, 3), np.uint8)
        out = np.empty((len(views), cam.height, cam.width), np.float32) if depth else None
        step = max(1, int(self.batch_views))
        for k in range(0, len(views), step):
            self._render_pass(views[k:k + step], rgb[k:k + step], None if out is None else out[k:k + step])
        return rgb, out

    def _render_views(self, poses: list, rgb: np.ndarray, depth: np.ndarray | None) -> None:
        """Fill rgb [n, H, W, 3] (and depth [n, H, W] unless None) for n checked poses; this
        default renders them one at a time."""
        for k, (position, yaw) in enumerate(poses):
            image, d = self.render(position, yaw, depth=depth is not None)
            rgb[k] = image
            if depth is not None:
                depth[k] = d

    def pass_group(self) -> object:
        """Renderers with equal groups draw their views together in `render_views` (one pass, one
        synchronisation); by default a renderer is a group of its own."""
        return self

    def _render_pass(self, views: list, rgb: np.ndarray, depth: np.ndarray | None) -> None:
        """Fill rgb/depth for views [(renderer, position, yaw)] of renderers of this one's `pass_group`."""
        self._render_views([(position, yaw) for _, position, yaw in views], rgb, depth)

    @abc.abstractmethod
    def close(self) -> None:
        """Release the back-end's resources; the renderer is unusable afterwards."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<{type(self).__name__} backend={self.backend!r} info={self.info!r} scene={self.scene.scene_id!r}>"


def render_views(views, depth: bool = True) -> list[tuple[np.ndarray, np.ndarray | None]]:
    """Frames (rgb, depth or None) of views [(renderer, position, yaw)] of several renderers (a batch
    of environments in different scenes), each equal to its renderer's `render`. The views of one
    `Renderer.pass_group` (gl: the renderers of one EGL context and camera size) are drawn in passes
    of up to `batch_views` with one synchronisation each; other renderers batch their own views."""
    views = list(views)
    poses = check_poses([view[1:] for view in views])
    groups: dict = {}
    for k, (renderer, _, _) in enumerate(views):
        groups.setdefault(renderer.pass_group(), []).append(k)
    frames: list = [None] * len(views)
    for members in groups.values():
        lead = views[members[0]][0]
        rgb, out = lead._render_passes([(views[k][0], *poses[k]) for k in members], depth)
        for j, k in enumerate(members):
            frames[k] = (rgb[j], None if out is None else out[j])
    return frames


CALL_VIEWS = 32  # views per `render_batch` call where a caller renders many (rvn-gen, depth pairs): one GPU
# synchronisation per 32 frames with renderer=gl, and only 32 frames' arrays held at a time


def check_poses(poses) -> list[tuple[np.ndarray, float]]:
    """[(position float64 [3], yaw float), ...] from a non-empty sequence of (position, yaw) pairs;
    ValueError naming the first bad pose."""
    try:
        poses = list(poses)
    except TypeError:
        raise ValueError(f"render_batch: poses must be a list of (position [x, y, z], yaw) pairs, "
                         f"got {type(poses).__name__}") from None
    if not poses:
        raise ValueError("render_batch: no poses given (a list of (position [x, y, z], yaw) pairs)")
    out = []
    for i, pose in enumerate(poses):
        try:
            position, yaw = pose
            position = np.asarray(position, np.float64)
            yaw = float(yaw)
            ok = position.shape == (3,) and bool(np.isfinite(position).all()) and math.isfinite(yaw)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            text = repr(pose)
            raise ValueError(f"render_batch: pose {i} {text[:80]}{'...' if len(text) > 80 else ''} is not "
                             "(position [x, y, z], yaw) with finite numbers")
        out.append((position, yaw))
    return out


@dataclass
class Material:
    """A part's shading inputs, validated: base rgb, texture uint8 [H, W, 3] or None."""

    base_rgb: np.ndarray
    texture: np.ndarray | None


def prepare_material(scene: Scene, part: Part) -> Material:
    """Validate a part's material; an unusable texture is dropped with a warning naming it."""
    base = np.clip(np.asarray(part.base_color[:3], dtype=np.float32), 0.0, 1.0)
    tex = part.texture
    if tex is not None:
        problem = None
        if part.uv is None:
            problem = "it has no UV coordinates"
        elif tex.ndim == 2:
            tex = np.repeat(tex[:, :, None], 3, axis=2)
        elif tex.ndim != 3 or tex.shape[2] not in (1, 2, 3, 4):
            problem = f"its shape {tex.shape} is not [H, W, 3]"
        if problem is None and (tex.shape[0] == 0 or tex.shape[1] == 0):
            problem = f"it is empty ({tex.shape})"
        if problem is None:
            if tex.shape[2] in (1, 2):
                tex = np.repeat(tex[:, :, :1], 3, axis=2)
            tex = np.ascontiguousarray(tex[:, :, :3], dtype=np.uint8)
        else:
            log.warning("scene %s: texture of material %r ignored because %s; rendering its base colour",
                        scene.scene_id, part.name, problem)
            tex = None
    return Material(base_rgb=base, texture=tex)


def face_shade(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """float32 [M]: AMBIENT + KEY * |n . LIGHT_DIR| per triangle (AMBIENT if degenerate)."""
    tri = np.asarray(vertices, np.float64)[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    cos = np.abs(n @ LIGHT_DIR) / np.where(length > 0, length, 1.0)
    return (AMBIENT + KEY * np.where(length > 0, cos, 0.0)).astype(np.float32)


def check_scene(scene: Scene) -> None:
    """Raise SceneError when the scene has nothing to render."""
    if scene.num_triangles == 0:
        raise SceneError(f"scene {scene.scene_id!r} has no triangles to render")

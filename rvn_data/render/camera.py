"""The robot's forward camera: intrinsics, pose from (position, yaw), matrices, rays.

Image convention: column u grows to the right, row v grows downwards, pixel (u, v) has its
centre at (u + 0.5, v + 0.5); the principal point (cx, cy) is in the same pixel units.
Camera frame (OpenGL): x right, y up, looking along -z. Depth is planar z-depth: the
distance of the hit point along the optical axis, in metres.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from rvn_data.conventions import heading


def _number(name: str, value, allow_none: bool = False) -> None:
    if value is None and allow_none:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"camera setting {name}={value!r} must be a finite number")


@dataclass(frozen=True)
class CameraConfig:
    """The forward RGB(-D) camera (the ``camera`` config group; conf/camera/*.yaml hold only
    what differs). Give hfov_deg, or fx/fy (and cx/cy) in pixels: fx/fy override hfov_deg."""

    width: int = 256  # pixels
    height: int = 256  # pixels
    hfov_deg: float = 90.0  # deg, horizontal field of view (square pixels)
    fx: float | None = None  # pixels, focal lengths; null: from hfov_deg
    fy: float | None = None
    cx: float | None = None  # pixels, principal point; null: the image centre
    cy: float | None = None
    h_camera: float = 0.6  # m above the floor
    pitch_deg: float = 0.0  # deg, + looks up
    forward_offset: float = 0.0  # m ahead of the robot centre
    near: float = 0.01  # m, clipping planes of the depth range
    far: float = 50.0

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                raise ValueError(f"camera setting {name}={value!r} must be a positive integer (pixels)")
        for name in ("hfov_deg", "h_camera", "pitch_deg", "forward_offset", "near", "far"):
            _number(name, getattr(self, name))
        for name in ("fx", "fy", "cx", "cy"):
            _number(name, getattr(self, name), allow_none=True)
        if not 0.0 < self.hfov_deg < 180.0:
            raise ValueError(f"camera setting hfov_deg={self.hfov_deg!r} must be in (0, 180) degrees")
        for name in ("fx", "fy"):
            value = getattr(self, name)
            if value is not None and value <= 0:
                raise ValueError(f"camera setting {name}={value!r} must be a positive focal length in pixels")
        if not abs(self.pitch_deg) < 90.0:
            raise ValueError(f"camera setting pitch_deg={self.pitch_deg!r} must be in (-90, 90) degrees")
        if not 0.0 < self.near < self.far:
            raise ValueError(
                f"camera settings near={self.near!r}, far={self.far!r} must satisfy 0 < near < far")

    @classmethod
    def from_dict(cls, cfg) -> "CameraConfig":
        """Build from a mapping (dict or OmegaConf node); unknown keys raise ValueError."""
        data = dict(cfg.items()) if hasattr(cfg, "items") else dict(cfg)
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown camera setting(s) {unknown}; known: {sorted(known)}")
        for name in ("width", "height"):
            if isinstance(data.get(name), float) and float(data[name]).is_integer():
                data[name] = int(data[name])
        return cls(**data)

    # ---- intrinsics -------------------------------------------------------------------
    @property
    def focal(self) -> tuple[float, float]:
        """(fx, fy) in pixels: given values, else from hfov (square pixels)."""
        if self.fx is None and self.fy is None:
            f = 0.5 * self.width / math.tan(math.radians(self.hfov_deg) / 2.0)
            return f, f
        fx = self.fx if self.fx is not None else self.fy
        fy = self.fy if self.fy is not None else self.fx
        return float(fx), float(fy)

    @property
    def principal(self) -> tuple[float, float]:
        """(cx, cy) in pixels; default the image centre."""
        cx = self.width / 2.0 if self.cx is None else float(self.cx)
        cy = self.height / 2.0 if self.cy is None else float(self.cy)
        return cx, cy

    def intrinsics(self) -> np.ndarray:
        """3x3 pinhole matrix K (pixels, v down)."""
        (fx, fy), (cx, cy) = self.focal, self.principal
        return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])

    def ray_directions(self) -> np.ndarray:
        """Camera-frame ray per pixel, float32 [H, W, 3], with z = -1 (so t = planar depth)."""
        (fx, fy), (cx, cy) = self.focal, self.principal
        x = (np.arange(self.width) + 0.5 - cx) / fx
        y = -(np.arange(self.height) + 0.5 - cy) / fy
        d = np.empty((self.height, self.width, 3), np.float64)
        d[..., 0] = x[None, :]
        d[..., 1] = y[:, None]
        d[..., 2] = -1.0
        return d.astype(np.float32)

    # ---- extrinsics -------------------------------------------------------------------
    def pose(self, position, yaw: float) -> tuple[np.ndarray, np.ndarray]:
        """(eye [3], R [3,3]) with R's columns the camera's right, up and back axes in the world."""
        eye, right, up, forward = self.pose_axes(position, yaw)
        return np.array(eye), np.array([[right[0], up[0], -forward[0]], [right[1], up[1], -forward[1]],
                                        [right[2], up[2], -forward[2]]])

    def pose_axes(self, position, yaw: float) -> tuple[tuple, tuple, tuple, tuple]:
        """(eye, right, up, forward) as triples of floats in the world frame, for pitch p and
        h = heading(yaw): forward = cos(p) h + sin(p) up_world, up = -sin(p) h +
        cos(p) up_world, eye = position + h_camera up_world + forward_offset h. Each coordinate sums
        its products term by term, zero terms included, in the order numpy's element-wise array
        arithmetic used, so the floats are the same bit for bit (signed zeros too)."""
        x, y, z = np.asarray(position, dtype=np.float64).reshape(3).tolist()
        h0, h1, h2 = heading(float(yaw)).tolist()
        p = math.radians(self.pitch_deg)
        cp, sp, hc, fo = math.cos(p), math.sin(p), self.h_camera, self.forward_offset
        right = (-h2, h1, h0)  # heading x up
        forward = (cp * h0 + sp * 0.0, cp * h1 + sp * 1.0, cp * h2 + sp * 0.0)
        up = (-sp * h0 + cp * 0.0, -sp * h1 + cp * 1.0, -sp * h2 + cp * 0.0)
        eye = (x + hc * 0.0 + fo * h0, y + hc * 1.0 + fo * h1, z + hc * 0.0 + fo * h2)
        return eye, right, up, forward

    def view_matrix(self, position, yaw: float) -> np.ndarray:
        """4x4 world -> camera matrix."""
        eye, rot = self.pose(position, yaw)
        view = np.eye(4)
        view[:3, :3] = rot.T
        view[:3, 3] = -rot.T @ eye
        return view

    def projection_matrix(self, flip_y: bool = False) -> np.ndarray:
        """4x4 OpenGL projection honouring fx, fy, cx, cy, near, far.

        flip_y=True puts image row 0 (the top) at window row 0, so a framebuffer read
        returns the image top-first.
        """
        (fx, fy), (cx, cy) = self.focal, self.principal
        w, h, n, f = self.width, self.height, self.near, self.far
        proj = np.zeros((4, 4))
        proj[0, 0] = 2.0 * fx / w
        proj[0, 2] = 1.0 - 2.0 * cx / w
        proj[1, 1] = 2.0 * fy / h
        proj[1, 2] = 2.0 * cy / h - 1.0
        proj[2, 2] = -(f + n) / (f - n)
        proj[2, 3] = -2.0 * f * n / (f - n)
        proj[3, 2] = -1.0
        if flip_y:
            proj[1] *= -1.0
        return proj

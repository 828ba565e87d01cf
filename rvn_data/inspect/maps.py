"""Top-down map of a trajectory's floor, rebuilt from its scene, with planar → pixel transform.

The map is the ground-truth occupancy grid the generator planned on
(`rvn_data.planning.occupancy_grid` at the trajectory's floor, the dataset's resolution,
agent and navmesh settings from the sidecar): dark = occupied or no floor, light grey =
free but within the planner's inflation margin, white = free for the planner. Pixel row 0
is the largest planar y (planar x right, planar y up), as the dataset's ``maps/*.png``.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

OCCUPIED, MARGIN, FREE = (60, 60, 60), (215, 215, 215), (255, 255, 255)


@dataclass
class SceneMap:
    """RGB uint8 image [h, w, 3] of one floor and its transform (``origin`` = world (x0, z0)
    of the grid corner, ``resolution`` m per cell, ``scale`` pixels per cell)."""

    image: np.ndarray
    origin: tuple[float, float]
    resolution: float
    scale: int

    def to_px(self, planar: np.ndarray) -> np.ndarray:
        """Planar points [..., 2] (x, y) → pixel coordinates [..., 2] (col, row), float."""
        p = np.asarray(planar, np.float64)
        col = (p[..., 0] - self.origin[0]) / self.resolution * self.scale
        row = (-p[..., 1] - self.origin[1]) / self.resolution * self.scale
        return np.stack([col, row], -1)

    def crop(self, planar: np.ndarray, pad: float = 1.5) -> "SceneMap":
        """The part of the map around ``planar`` points [N, 2], ``pad`` metres beyond them."""
        px = self.to_px(np.asarray(planar, np.float64).reshape(-1, 2))
        pad_px = pad / self.resolution * self.scale
        h, w = self.image.shape[:2]
        c0, r0 = (np.floor(px.min(0) - pad_px)).astype(int).clip(0, [w - 1, h - 1])
        c1, r1 = (np.ceil(px.max(0) + pad_px)).astype(int).clip(1, [w, h])
        cell = self.resolution / self.scale  # metres per pixel
        return SceneMap(self.image[r0:r1, c0:c1].copy(), (self.origin[0] + c0 * cell, self.origin[1] + r0 * cell),
                        self.resolution, self.scale)


@lru_cache(maxsize=8)
def _load(spec: str, up_axis: str, unit_scale: float, level: bool):
    from rvn_data.scenes.loader import load_scene

    return load_scene(spec, up_axis=up_axis, unit_scale=unit_scale, level=level)


def scene_map(meta: dict, scale: int = 3, up_axis: str = "y", unit_scale: float = 1.0,
              level: bool = False) -> SceneMap:
    """The map of the floor of trajectory ``meta`` (an ``rvn_meta.json`` dict). Mesh scenes
    need the loader options they were generated with (e.g. ``up_axis="z"`` for HM3D) and
    their file at ``meta["spec"]``."""
    from rvn_data.conventions import AgentConfig
    from rvn_data.dataset.settings import GenSettings
    from rvn_data.navmesh.settings import NavMeshSettings
    from rvn_data.planning.occupancy import occupancy_grid

    # the settings rvn-gen recorded; a key a record lacks (made before it existed) takes today's default
    settings = meta.get("settings") or {}
    agent, navmesh = settings.get("agent") or {}, settings.get("navmesh") or {}
    resolution = float(settings.get("resolution", GenSettings.resolution))
    margin = float(settings.get("margin", agent.get("r_robot", AgentConfig.r_robot)))
    scene = _load(str(meta["spec"]), up_axis, float(unit_scale), bool(level))
    floor = round(float(meta["start"][1]) / 0.05) * 0.05  # the generator's 5 cm floor levels
    grid = occupancy_grid(scene, floor, resolution, float(agent.get("h_robot", AgentConfig.h_robot)),
                          float(navmesh.get("max_climb", NavMeshSettings.max_climb)),
                          float(navmesh.get("max_slope_deg", NavMeshSettings.max_slope_deg)))
    img = np.empty(grid.shape + (3,), np.uint8)
    img[:] = MARGIN
    img[grid.inflate(margin)] = FREE
    img[grid.occupied] = OCCUPIED
    img = np.repeat(np.repeat(img, scale, 0), scale, 1)
    return SceneMap(img, grid.origin, grid.resolution, int(scale))


# RGB colours of `draw_clip`, shared with the legends of `rvn_data.inspect.plots`
ASTAR, START, GOAL, POSES, COMMANDED, HIT, HEADING = ((150, 150, 150), (0, 170, 0), (0, 80, 200), (240, 130, 0),
                                                      (220, 0, 0), (220, 0, 0), (0, 0, 0))
LEGEND = [("thin", ASTAR, "A* path"), ("dot", START, "start"), ("square", GOAL, "goal"),
          ("line", POSES, "poses up to t_c"), ("dashed", COMMANDED, "commanded after t_c"),
          ("ring", HIT, "pose at t_c"), ("cross", HIT, "contact point"), ("arrow", HEADING, "heading (last pose)")]


def draw_clip(smap: SceneMap, meta: dict, planar: np.ndarray, upto: int | None = None,
              t_c: int | None = None, yaw: np.ndarray | None = None) -> np.ndarray:
    """RGB copy of the map with the A* path (grey), start (green) and goal (blue), the clip's
    poses 0..``upto`` (orange up to the collision), once reached the pose at t_c (red ring) and
    the contact point on the navmesh boundary (red cross), then on top of those the commanded
    motion after t_c (red dashes on a white casing) and the heading at the last pose drawn
    (black arrow). `LEGEND` lists these marks."""
    img = np.ascontiguousarray(smap.image.copy())
    upto = len(planar) - 1 if upto is None else int(upto)

    def pts(p):
        return np.round(smap.to_px(np.asarray(p, np.float64).reshape(-1, 2))).astype(np.int32)

    wps = meta.get("waypoints_planar")
    if wps:
        cv2.polylines(img, [pts(wps).reshape(-1, 1, 2)], False, ASTAR, 1, cv2.LINE_AA)
    if meta.get("start") is not None:
        s = pts([meta["start"][0], -meta["start"][2]])[0]
        cv2.circle(img, tuple(int(v) for v in s), 4, START, -1, cv2.LINE_AA)
    if meta.get("goal_planar") is not None:
        g = pts(meta["goal_planar"])[0]
        cv2.rectangle(img, (int(g[0]) - 4, int(g[1]) - 4), (int(g[0]) + 4, int(g[1]) + 4), GOAL, -1)
    p = pts(planar[: upto + 1])
    cut = upto + 1 if t_c is None else min(upto, t_c) + 1
    cv2.polylines(img, [p[:cut].reshape(-1, 1, 2)], False, POSES, 2, cv2.LINE_AA)
    if t_c is not None and upto >= t_c:  # the collision marks, under the commanded motion
        c = pts(planar[t_c])[0]
        cv2.circle(img, (int(c[0]), int(c[1])), 6, HIT, 2, cv2.LINE_AA)
        if meta.get("contact") is not None:
            c = pts([meta["contact"][0], -meta["contact"][2]])[0]
        cv2.drawMarker(img, (int(c[0]), int(c[1])), HIT, cv2.MARKER_TILTED_CROSS, 14, 2)
    dashes = [(tuple(int(v) for v in a), tuple(int(v) for v in (a + b) // 2))
              for a, b in zip(p[max(cut - 1, 0):-1], p[cut:])]  # after t_c: every other half-step
    for width, colour in ((4, (255, 255, 255)), (2, COMMANDED)):  # a white casing keeps them visible on the cross
        for a, b in dashes:
            cv2.line(img, a, b, colour, width, cv2.LINE_AA)
    if yaw is not None and len(p):
        tip = pts(planar[upto] + 0.4 * np.array([np.cos(yaw[upto]), np.sin(yaw[upto])]))[0]
        cv2.arrowedLine(img, tuple(int(v) for v in p[-1]), tuple(int(v) for v in tip), HEADING, 2,
                        cv2.LINE_AA, tipLength=0.4)
    return img


__all__ = ["LEGEND", "SceneMap", "draw_clip", "scene_map"]

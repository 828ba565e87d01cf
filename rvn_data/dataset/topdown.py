"""Top-down PNG of one scene's trajectories (looking at a dataset before training on it).

Background: dark = occupied or no floor (occupancy grid), mid grey = not on the navmesh's
main island, light grey = navigable but within the planner's inflation margin, white =
navigable and free for the planner.
Each trajectory is a coloured polyline (planar poses), its start a green dot, its goal a
blue square; collision points are red crosses.
"""
from __future__ import annotations

import colorsys

import cv2
import numpy as np

from rvn_data.conventions import from_planar
from rvn_data.planning.occupancy import OccupancyGrid

SCALE = 2  # output pixels per grid cell


def _colour(i: int) -> tuple[int, int, int]:
    r, g, b = colorsys.hsv_to_rgb((i * 0.618034) % 1.0, 0.85, 0.8)
    return int(b * 255), int(g * 255), int(r * 255)  # BGR


def render_map(grid: OccupancyGrid, free: np.ndarray, navigable: np.ndarray, trajectories: list[dict]) -> bytes:
    """PNG bytes. `free`: planner's free cells; `navigable`: main-island cells (both on
    `grid`). Each trajectory dict: ``planar`` [T, 2], ``start``/``goal`` world [3],
    optional ``collision`` world [3]."""
    img = np.full(grid.shape + (3,), 170, np.uint8)
    img[navigable] = (215, 215, 215)
    img[navigable & free] = (255, 255, 255)
    img[grid.occupied] = (60, 60, 60)
    img = cv2.resize(img, (grid.shape[1] * SCALE, grid.shape[0] * SCALE), interpolation=cv2.INTER_NEAREST)

    def px(world: np.ndarray) -> np.ndarray:
        w = np.asarray(world, np.float64).reshape(-1, 3)
        col = (w[:, 0] - grid.origin[0]) / grid.resolution * SCALE
        row = (w[:, 2] - grid.origin[1]) / grid.resolution * SCALE
        return np.round(np.stack([col, row], -1)).astype(np.int32)

    for i, t in enumerate(trajectories):
        colour = _colour(i)
        pts = px(from_planar(np.asarray(t["planar"], np.float64)))
        cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, colour, 1, cv2.LINE_AA)
        s, g = px(t["start"])[0], px(t["goal"])[0]
        cv2.circle(img, (int(s[0]), int(s[1])), 4, (0, 170, 0), -1, cv2.LINE_AA)
        cv2.rectangle(img, (int(g[0]) - 3, int(g[1]) - 3), (int(g[0]) + 3, int(g[1]) + 3), (200, 80, 0), -1)
    for t in trajectories:
        if t.get("collision") is not None:
            c = px(t["collision"])[0]
            cv2.drawMarker(img, (int(c[0]), int(c[1])), (0, 0, 230), cv2.MARKER_TILTED_CROSS, 10, 2)
    # row 0 is the smallest z, i.e. the largest planar y: planar x points right, planar y up
    ok, buf = cv2.imencode(".png", img)
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()

"""Top-down PNG of one scene's trajectories (looking at a dataset before training on it).

Background: dark = occupied or no floor (occupancy grid), mid grey = not on the navmesh's
sampled islands (the main island unless navmesh.islands=all), light grey = navigable but within
the planner's inflation margin, white = navigable and free for the planner. A scene whose
trajectories lie on several floors (a multi-storey scan with navmesh.islands=all, or stairs) gets
a panel a floor (`rvn_data.dataset.floors`), side by side, each captioned with its floor height (`render_panels`).
Each trajectory is a coloured polyline (planar poses), its start a green dot, its goal a
blue square; collision points are red crosses. A legend strip under the map says so
(`legend_strip`, also used by the clip animations of `rvn_data.inspect`).
"""
from __future__ import annotations

import colorsys

import cv2
import numpy as np

from rvn_data.conventions import from_planar
from rvn_data.planning.occupancy import OccupancyGrid

SCALE = 2  # output pixels per grid cell
START, GOAL, COLLISION = (0, 170, 0), (200, 80, 0), (0, 0, 230)  # BGR
OCCUPIED, OFF_ISLAND, MARGIN, FREE = (60, 60, 60), (170, 170, 170), (215, 215, 215), (255, 255, 255)
_FONT, _FONT_SCALE, _ROW = cv2.FONT_HERSHEY_SIMPLEX, 0.35, 15


def _icon(img: np.ndarray, kind: str, colour: tuple, x: int, y: int) -> None:
    """Draw a legend icon 14 px wide centred on row y, starting at column x."""
    c = (x + 7, y)
    if kind == "dot":
        cv2.circle(img, c, 4, colour, -1, cv2.LINE_AA)
    elif kind == "square":
        cv2.rectangle(img, (c[0] - 3, y - 3), (c[0] + 3, y + 3), colour, -1)
    elif kind == "cross":
        cv2.drawMarker(img, c, colour, cv2.MARKER_TILTED_CROSS, 9, 2)
    elif kind == "hollow":
        cv2.rectangle(img, (c[0] - 4, y - 4), (c[0] + 4, y + 4), colour, 1)
    elif kind == "ring":
        cv2.circle(img, c, 5, colour, 2, cv2.LINE_AA)
    elif kind == "line":
        cv2.line(img, (x, y), (x + 14, y), colour, 2, cv2.LINE_AA)
    elif kind == "thin":
        cv2.line(img, (x, y), (x + 14, y), colour, 1, cv2.LINE_AA)
    elif kind == "dashed":
        for a in (x, x + 9):
            cv2.line(img, (a, y), (a + 4, y), colour, 2, cv2.LINE_AA)
    elif kind == "arrow":
        cv2.arrowedLine(img, (x, y), (x + 14, y), colour, 2, cv2.LINE_AA, tipLength=0.4)
    elif kind == "swatch":
        cv2.rectangle(img, (x + 1, y - 5), (x + 13, y + 5), colour, -1)
        cv2.rectangle(img, (x + 1, y - 5), (x + 13, y + 5), (120, 120, 120), 1)
    else:
        raise ValueError(f"legend icon {kind!r}")


def legend_strip(width: int, entries: list[tuple[str, tuple, str]]) -> np.ndarray:
    """White uint8 image [h, width, 3] with the legend ``entries`` = (icon, colour, text), the
    icons "dot", "square", "hollow" (square), "cross", "ring", "line", "thin", "dashed", "arrow" or "swatch", in
    the colour order of the image it goes under; entries wrap onto as many rows as needed."""
    rows, row, used = [], [], 4
    for icon, colour, text in entries:
        w = 14 + 4 + cv2.getTextSize(text, _FONT, _FONT_SCALE, 1)[0][0] + 10
        if row and used + w > width:
            rows.append(row)
            row, used = [], 4
        row.append((icon, colour, text, used))
        used += w
    if row:
        rows.append(row)
    img = np.full((len(rows) * _ROW + 6, int(width), 3), 255, np.uint8)
    for r, items in enumerate(rows):
        y = 3 + r * _ROW + _ROW // 2
        for icon, colour, text, x in items:
            _icon(img, icon, colour, x, y)
            cv2.putText(img, text, (x + 18, y + 4), _FONT, _FONT_SCALE, (0, 0, 0), 1, cv2.LINE_AA)
    return img


def map_legend(width: int, off_island: str = "off main island") -> np.ndarray:
    """The legend strip of a dataset map (BGR); ``off_island``: what the mid grey says."""
    return legend_strip(width, [("dot", START, "start"), ("square", GOAL, "goal"),
                                ("line", path_colour(0), "path (one colour each)"), ("cross", COLLISION, "collision"),
                                ("swatch", FREE, "free"), ("swatch", MARGIN, "within margin"),
                                ("swatch", OFF_ISLAND, off_island), ("swatch", OCCUPIED, "occupied / no floor")])


def path_colour(i: int) -> tuple[int, int, int]:
    r, g, b = colorsys.hsv_to_rgb((i * 0.618034) % 1.0, 0.85, 0.8)
    return int(b * 255), int(g * 255), int(r * 255)  # BGR


def render_panels(panels: list[tuple], off_island: str = "off main island") -> bytes:
    """PNG bytes of maps side by side (top aligned) over one legend. A panel: (grid, free, navigable, trajectories,
    caption or None); `free`: the planner's free cells, `navigable`: the sampled islands' cells (both on `grid`);
    each trajectory a dict: ``planar`` [T, 2], ``start``/``goal`` world [3], optional ``collision`` world [3].
    Trajectory colours run on across panels."""
    images, captions, first = [], [], 0
    for grid, free, navigable, trajectories, caption in panels:
        images.append(_panel(grid, free, navigable, trajectories, first))
        captions.append(caption)
        first += len(trajectories)
    img = side_by_side(images, captions)
    return encode_png(np.concatenate([img, map_legend(img.shape[1], off_island)], 0))  # under the map: it never hides a path


def encode_png(img: np.ndarray) -> bytes:
    """PNG bytes of a BGR image."""
    ok, buf = cv2.imencode(".png", img)
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()


def side_by_side(images: list[np.ndarray], captions: list[str | None]) -> np.ndarray:
    """BGR images left to right, top aligned on white, 8 px apart, each under its caption (None: none)."""
    out = []
    for img, caption in zip(images, captions):
        if caption is not None:
            lines = _wrapped(caption, img.shape[1] - 8)
            head = np.full((_ROW * len(lines) + 4, img.shape[1], 3), 255, np.uint8)
            for i, line in enumerate(lines):
                cv2.putText(head, line, (4, _ROW * (i + 1) - 2), _FONT, _FONT_SCALE, (0, 0, 0), 1, cv2.LINE_AA)
            img = np.concatenate([head, img], 0)
        out.append(img)
    if len(out) == 1:
        return out[0]
    height = max(i.shape[0] for i in out)
    padded = [np.concatenate([i, np.full((height - i.shape[0], i.shape[1], 3), 255, np.uint8)], 0) for i in out]
    gap = np.full((height, 8, 3), 255, np.uint8)
    return np.concatenate([x for i in padded for x in (i, gap)][:-1], 1)


def _wrapped(text: str, width: int) -> list[str]:
    """``text`` broken between words into lines at most ``width`` px wide (a word wider stays whole)."""
    lines = [""]
    for word in text.split():
        trial = f"{lines[-1]} {word}".strip()
        if lines[-1] and cv2.getTextSize(trial, _FONT, _FONT_SCALE, 1)[0][0] > width:
            lines.append(word)
        else:
            lines[-1] = trial
    return lines


def _panel(grid: OccupancyGrid, free: np.ndarray, navigable: np.ndarray, trajectories: list[dict],
           first: int) -> np.ndarray:
    """One map's image (BGR, no legend); trajectory i drawn in colour ``first + i``."""
    img = np.full(grid.shape + (3,), OFF_ISLAND, np.uint8)
    img[navigable] = MARGIN
    img[navigable & free] = FREE
    img[grid.occupied] = OCCUPIED
    img = cv2.resize(img, (grid.shape[1] * SCALE, grid.shape[0] * SCALE), interpolation=cv2.INTER_NEAREST)

    def px(world: np.ndarray) -> np.ndarray:
        w = np.asarray(world, np.float64).reshape(-1, 3)
        col = (w[:, 0] - grid.origin[0]) / grid.resolution * SCALE
        row = (w[:, 2] - grid.origin[1]) / grid.resolution * SCALE
        return np.round(np.stack([col, row], -1)).astype(np.int32)

    for i, t in enumerate(trajectories):
        colour = path_colour(first + i)
        pts = px(from_planar(np.asarray(t["planar"], np.float64)))
        cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, colour, 1, cv2.LINE_AA)
        s, g = px(t["start"])[0], px(t["goal"])[0]
        cv2.circle(img, (int(s[0]), int(s[1])), 4, START, -1, cv2.LINE_AA)
        cv2.rectangle(img, (int(g[0]) - 3, int(g[1]) - 3), (int(g[0]) + 3, int(g[1]) + 3), GOAL, -1)
    for t in trajectories:
        if t.get("collision") is not None:
            c = px(t["collision"])[0]
            cv2.drawMarker(img, (int(c[0]), int(c[1])), COLLISION, cv2.MARKER_TILTED_CROSS, 10, 2)
    # row 0 is the smallest z, i.e. the largest planar y: planar x points right, planar y up
    return img

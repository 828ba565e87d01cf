"""The shell of a procedural apartment as coloured boxes (metres, plan coordinates: the
apartment is centred later): wall runs with skirting boards, windows on outside walls and
framed pictures, doorways' lintels and frames. Boxes go into ``boxes[material]`` as
``((x0, y0, z0, x1, y1, z1), rgb)``; ``pal`` is the scene's `Palette`."""
from __future__ import annotations

from rvn_data.scenes.floorplan import DM, Plan
from rvn_data.scenes.furnish import HALF_WALL
from rvn_data.scenes.palette import Palette

DOOR_HEIGHT = (2.0, 2.1)


def room_at(plan: Plan, x: float, z: float) -> int:
    """Room containing plan point (x, z) in dm, -1 outside."""
    for r, k in zip(plan.rects, plan.rect_room):
        if r.x0 <= x <= r.x1 and r.z0 <= z <= r.z1:
            return k
    return -1


def strip(axis, c, side, t0, t1, y0, y1, proud0, proud1):
    """Box on the `side` face of wall line c (metres) between depths proud0..proud1 from the line."""
    a0, a1 = sorted((c + side * proud0, c + side * proud1))
    return (a0, y0, t0, a1, y1, t1) if axis == "x" else (t0, y0, a0, t1, y1, a1)


def add_walls(rng, plan: Plan, pal: Palette, boxes: dict, colour) -> None:
    """Wall runs in their room's paint (``colour(room)``), with skirting boards, windows and pictures."""
    h, e = pal.height, HALF_WALL - 0.001
    for w in plan.walls:
        c, t0, t1 = w.c * DM, w.t0 * DM, w.t1 * DM
        boxes["walls"].append((strip(w.axis, c, w.side, t0 - e * w.ext0, t1 + e * w.ext1, 0, h, 0, HALF_WALL),
                               colour(w.owner)))
        if w.owner >= 0:
            s0, s1 = t0 + HALF_WALL * w.ext0, t1 - HALF_WALL * w.ext1
            boxes["painted"].append((strip(w.axis, c, w.side, s0, s1, 0, 0.08, HALF_WALL, HALF_WALL + 0.012),
                                     pal.trim))
            if not _window(rng, plan, w, boxes, h):
                _picture(rng, w, boxes, pal)


def add_doorways(rng, plan: Plan, pal: Palette, boxes: dict, colour) -> None:
    """Doorways: lintel halves in each room's paint (``colour(room)``), frames in the trim colour."""
    h = pal.height
    for d in plan.doors:
        dh = float(rng.uniform(*DOOR_HEIGHT))
        c, t0, t1 = d.c * DM, d.t0 * DM, d.t1 * DM
        mid = (d.t0 + d.t1) / 2
        for side in (1, -1):
            room = room_at(plan, d.c + side * 0.5, mid) if d.axis == "x" else room_at(plan, mid, d.c + side * 0.5)
            boxes["walls"].append((strip(d.axis, c, side, t0, t1, dh, h, 0, HALF_WALL), colour(room)))
            for a, b, y0, y1 in ((t0 - 0.06, t0, 0, dh + 0.06), (t1, t1 + 0.06, 0, dh + 0.06),
                                 (t0, t1, dh, dh + 0.06)):
                boxes["painted"].append((strip(d.axis, c, side, a, b, y0, y1, HALF_WALL, HALF_WALL + 0.015),
                                         pal.trim))


def _window(rng, plan: Plan, w, boxes, h) -> bool:
    """Maybe a window on an outside-facing wall run: bright glass panel with a trim frame."""
    length = (w.t1 - w.t0) * DM
    if length < 1.6 or rng.random() > 0.6:
        return False
    ww = float(rng.uniform(0.8, min(1.8, length - 0.6)))
    t0 = float(rng.uniform(w.t0 * DM + 0.3, w.t1 * DM - 0.3 - ww))
    outside = any(o.axis == w.axis and o.c == w.c and o.side == -w.side and o.owner == -1
                  and o.t0 * DM <= t0 and t0 + ww <= o.t1 * DM for o in plan.walls)
    if not outside:
        return False
    c, y0, y1 = w.c * DM, 0.9, min(2.1, h - 0.25)
    boxes["painted"].append((strip(w.axis, c, w.side, t0, t0 + ww, y0, y1, HALF_WALL, HALF_WALL + 0.008),
                             (205, 228, 246)))
    for a, b, ya, yb in ((t0 - 0.05, t0, y0 - 0.05, y1 + 0.05), (t0 + ww, t0 + ww + 0.05, y0 - 0.05, y1 + 0.05),
                         (t0, t0 + ww, y0 - 0.05, y0), (t0, t0 + ww, y1, y1 + 0.05),
                         (t0 + ww / 2 - 0.02, t0 + ww / 2 + 0.02, y0, y1)):
        boxes["painted"].append((strip(w.axis, c, w.side, a, b, ya, yb, HALF_WALL, HALF_WALL + 0.02),
                                 (240, 240, 236)))
    return True


def _picture(rng, w, boxes, pal: Palette) -> None:
    """Maybe a framed picture (blocks of colour) hung on a room's wall run, above the robot."""
    length = (w.t1 - w.t0) * DM
    if length < 1.0 or rng.random() > 0.4:
        return
    pw = float(rng.uniform(0.4, min(1.2, length - 0.4)))
    ph = float(rng.uniform(0.35, 0.8))
    t0 = float(rng.uniform(w.t0 * DM + 0.2, w.t1 * DM - 0.2 - pw))
    y0, c = float(rng.uniform(1.25, 1.5)), w.c * DM
    frame = pal.wood(rng) if rng.random() < 0.5 else pal.metal
    boxes["painted"].append((strip(w.axis, c, w.side, t0, t0 + pw, y0, y0 + ph, HALF_WALL, HALF_WALL + 0.02),
                             frame))
    n = int(rng.integers(1, 4))
    for i in range(n):  # canvas split into n vertical colour blocks
        a, b = t0 + 0.03 + i * (pw - 0.06) / n, t0 + 0.03 + (i + 1) * (pw - 0.06) / n
        boxes["painted"].append((strip(w.axis, c, w.side, a, b, y0 + 0.03, y0 + ph - 0.03, HALF_WALL + 0.02,
                                        HALF_WALL + 0.025), pal.accent(rng)))

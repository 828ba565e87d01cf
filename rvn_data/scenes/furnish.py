"""Furnishing a floor plan: furniture against walls and in open floor, rooms kept connected.

Every placement is checked on a 0.1 m occupancy grid of the plan: the free space
eroded by `CLEAR_R` (a clear path about 0.7-0.8 m wide) must keep every doorway in one
component and must not lose more than `MAX_LOST` of its area to pockets. Doorways keep
a furniture-free zone `DOOR_ZONE` deep on both sides. Coordinates are plan metres
(origin at the footprint's corner, x and z as in the world).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from rvn_data.scenes import furniture as F
from rvn_data.scenes.floorplan import DM, Plan

CELL = DM
CLEAR_R = 0.35
DOOR_ZONE = 0.7
MAX_LOST = 0.03
HALF_WALL = 0.05
MAX_PIECES = 40
CENTER_MARGIN = 0.45  # free-standing groups keep this distance from the room's walls


@dataclass
class Furnished:
    """Placed pieces (plan metres) and the room of each."""

    pieces: list[F.Piece] = field(default_factory=list)
    rooms: list[int] = field(default_factory=list)


class Occupancy:
    """Walls, outside and furniture on the plan's 0.1 m grid, with the connectivity test."""

    def __init__(self, plan: Plan):
        occ = np.ones((plan.width, plan.depth), bool)
        for r in plan.rects:
            occ[r.x0:r.x1, r.z0:r.z1] = False
        for w in plan.walls:
            a0, a1 = max(w.c - 1, 0), w.c + 1
            t0, t1 = w.t0 - w.ext0, w.t1 + w.ext1
            if w.axis == "x":
                occ[a0:a1, max(t0, 0):t1] = True
            else:
                occ[max(t0, 0):t1, a0:a1] = True
        # cells farther than CLEAR_R (centre to centre) from every blocked cell
        self.clear = ndimage.distance_transform_edt(~occ) * CELL > CLEAR_R
        self.zone = np.zeros_like(occ)
        self.door_cells, self.keepout = [], []
        n = int(round(DOOR_ZONE / CELL))
        for d in plan.doors:
            lo, hi = max(d.c - n, 0), d.c + n
            if d.axis == "x":
                self.zone[lo:hi, d.t0 - 1:d.t1 + 1] = True
                self.door_cells.append((d.c, (d.t0 + d.t1) // 2))
            else:
                self.zone[d.t0 - 1:d.t1 + 1, lo:hi] = True
                self.door_cells.append(((d.t0 + d.t1) // 2, d.c))
            along = ((d.t0 - 1.5) * DM, (d.t1 + 1.5) * DM)
            across = (d.c * DM - DOOR_ZONE, d.c * DM + DOOR_ZONE)
            self.keepout.append((along[0], across[0], along[1], across[1]) if d.axis == "z"
                                else (across[0], along[0], across[1], along[1]))
        self.base_lost = self._lost(self.clear)

    def _cells(self, ext) -> tuple[slice, slice]:
        x0, z0, x1, z1 = ext
        return (slice(max(int(np.floor(x0 / CELL + 1e-6)), 0), int(np.ceil(x1 / CELL - 1e-6))),
                slice(max(int(np.floor(z0 / CELL + 1e-6)), 0), int(np.ceil(z1 / CELL - 1e-6))))

    def _lost(self, clear: np.ndarray) -> float:
        """Fraction of the clear network outside the doorways' component (inf if doors split)."""
        clear = clear | self.zone
        lab, _ = ndimage.label(clear)
        ids = {int(lab[c]) for c in self.door_cells}
        if len(ids) != 1 or 0 in ids:
            return float("inf")
        total = clear.sum()
        return float(total - (lab == ids.pop()).sum()) / max(total, 1)

    def try_add(self, ext) -> bool:
        """Block `ext` ([x0, z0, x1, z1], metres); keep it only if the network stays connected.

        Blocking a rectangle of cells removes from `clear` every cell within CLEAR_R of it,
        exactly what a new distance transform would give, computed on a small window.
        """
        (i0, i1), (j0, j1) = ((s.start, s.stop) for s in self._cells(ext))
        r = CLEAR_R / CELL
        m = int(np.floor(r))
        a0, a1 = max(i0 - m, 0), min(i1 + m, self.clear.shape[0])
        b0, b1 = max(j0 - m, 0), min(j1 + m, self.clear.shape[1])
        di = np.maximum(np.maximum(i0 - np.arange(a0, a1), np.arange(a0, a1) - (i1 - 1)), 0)
        dj = np.maximum(np.maximum(j0 - np.arange(b0, b1), np.arange(b0, b1) - (j1 - 1)), 0)
        near = di[:, None] ** 2 + dj[None, :] ** 2 <= r * r
        clear = self.clear.copy()
        clear[a0:a1, b0:b1] &= ~near
        if self._lost(clear) <= self.base_lost + MAX_LOST:
            self.clear = clear
            return True
        return False


def _overlaps(a, b, pad=0.0) -> bool:
    return a[0] < b[2] + pad and b[0] < a[2] + pad and a[1] < b[3] + pad and b[1] < a[3] + pad


def _inside(ext, rect, margin) -> bool:
    return (ext[0] >= rect.x0 * DM + margin and ext[2] <= rect.x1 * DM - margin
            and ext[1] >= rect.z0 * DM + margin and ext[3] <= rect.z1 * DM - margin)


# Group builders: lists of pieces in one local frame (back at z = 0, facing +z).
def dining_set(rng, pal):
    t = F.table(rng, pal, "dining_table")
    e = t.extent()
    w, d = e[2] - e[0], e[3]
    out, col = [t], pal.wood(rng)
    per_side = 2 if w > 1.25 else 1
    for side in range(2):
        for i in range(per_side):
            if rng.random() < 0.15:
                continue
            x = (i + 0.5) * w / per_side - w / 2
            c = F.chair(rng, pal, col)
            out.append(c.moved(0, x, -0.32) if side == 0 else c.moved(2, x, d + 0.32))
    return out


def desk_set(rng, pal):
    d = rng.uniform(0.6, 0.7)
    desk = F.table(rng, pal, "desk", w=rng.uniform(1.0, 1.4), d=d)
    return [desk, F.chair(rng, pal).moved(2, rng.uniform(-0.2, 0.2), d + 0.3)]


def bed_set(rng, pal):
    b = F.bed(rng, pal)
    w = b.extent()[2] - b.extent()[0]
    out = [b]
    for sx in (-1, 1):
        if rng.random() < 0.7:
            ns = F.cabinet(rng, pal, "nightstand", w=0.45, d=0.4, h=0.5)
            out.append(ns.moved(0, sx * (w / 2 + 0.28), 0.0))
    return out


def coffee_table(rng, pal):
    return [F.table(rng, pal, "coffee_table", w=rng.uniform(0.8, 1.2), d=rng.uniform(0.5, 0.7),
                    h=rng.uniform(0.4, 0.46))]


def _one(builder, **kw):
    return lambda rng, pal: [builder(rng, pal, **kw)]


WALL, CENTER = "wall", "center"
_ARMCHAIR = _one(F.sofa, w=0.85)
WISHLIST = {
    "living": [(_one(F.sofa), WALL, 1.0), (coffee_table, CENTER, 0.9), (_one(F.tv_stand), WALL, 0.8),
               (_ARMCHAIR, WALL, 0.6), (_one(F.bookshelf), WALL, 0.7), (_one(F.floor_plant), WALL, 0.7),
               (_one(F.floor_lamp), WALL, 0.6), (_one(F.pillar), CENTER, 0.3), (_one(F.plant_stand), WALL, 0.4)],
    "kitchen": [(_one(F.counter), WALL, 1.0), (_one(F.fridge), WALL, 0.8), (dining_set, CENTER, 0.9),
                (_one(F.cabinet), WALL, 0.4), (_one(F.plant_stand), WALL, 0.4), (_one(F.stool), WALL, 0.3)],
    "bedroom": [(bed_set, WALL, 1.0), (_one(F.cabinet, kind="wardrobe", w=None, d=0.6, h=2.0), WALL, 0.9),
                (desk_set, WALL, 0.5), (_one(F.cabinet, kind="dresser", h=0.85), WALL, 0.5),
                (_one(F.floor_plant), WALL, 0.4), (_one(F.floor_lamp), WALL, 0.3)],
    "office": [(desk_set, WALL, 1.0), (_one(F.bookshelf), WALL, 0.9), (_one(F.bookshelf), WALL, 0.5),
               (_ARMCHAIR, WALL, 0.4), (_one(F.floor_plant), WALL, 0.5), (_one(F.floor_lamp), WALL, 0.5)],
    "bath": [(_one(F.cabinet), WALL, 0.9), (_one(F.washer), WALL, 0.6), (_one(F.bookshelf), WALL, 0.3),
             (_one(F.plant_stand), WALL, 0.4)],
    "corridor": [(_one(F.cabinet, kind="console", d=0.32, h=0.8), WALL, 0.6), (_one(F.coat_rack), WALL, 0.6),
                 (_one(F.plant_stand), WALL, 0.6), (_one(F.floor_lamp), WALL, 0.3)],
}
FILLERS = [(_one(F.plant_stand), WALL), (_one(F.floor_lamp), WALL), (_one(F.floor_plant), WALL),
           (_one(F.stool), CENTER), (_one(F.pillar), CENTER), (_one(F.cabinet, kind="side_table", w=0.45,
                                                                     d=0.45, h=0.55), WALL)]


def _candidate(rng, plan: Plan, room: int, group, mode):
    """A random pose for `group` in `room`: (moved pieces, bounding extent) or None."""
    local = np.array([p.extent() for p in group])
    lx0, lx1 = local[:, 0].min(), local[:, 2].max()
    if mode == WALL:
        runs = [w for w in plan.walls if w.owner == room and (w.t1 - w.t0) * DM > lx1 - lx0 + 0.12]
        if not runs:
            return None
        lens = np.array([w.t1 - w.t0 for w in runs], np.float64)
        w = runs[int(rng.choice(len(runs), p=lens / lens.sum()))]
        hw = max(-lx0, lx1)
        lo, hi = w.t0 * DM + HALF_WALL + hw + 0.01, w.t1 * DM - HALF_WALL - hw - 0.01
        if hi < lo:
            return None
        t, face = rng.uniform(lo, hi), w.c * DM + w.side * (HALF_WALL + 0.01)
        k = {("z", 1): 0, ("z", -1): 2, ("x", 1): 1, ("x", -1): 3}[(w.axis, w.side)]
        moved = [p.moved(k, t, face) if w.axis == "z" else p.moved(k, face, t) for p in group]
        margin = HALF_WALL
    else:
        rects = plan.room_rects(room)
        areas = np.array([r.area for r in rects], np.float64)
        r = rects[int(rng.choice(len(rects), p=areas / areas.sum()))]
        margin = CENTER_MARGIN
        k = int(rng.integers(4))
        e0 = np.array([p.moved(k, 0.0, 0.0).extent() for p in group])
        lo = (r.x0 * DM + margin - e0[:, 0].min(), r.z0 * DM + margin - e0[:, 1].min())
        hi = (r.x1 * DM - margin - e0[:, 2].max(), r.z1 * DM - margin - e0[:, 3].max())
        if hi[0] < lo[0] or hi[1] < lo[1]:
            return None
        x, z = rng.uniform(lo[0], hi[0]), rng.uniform(lo[1], hi[1])
        moved = [p.moved(k, x, z) for p in group]
    ext = np.array([p.extent() for p in moved])
    ext = (ext[:, 0].min(), ext[:, 1].min(), ext[:, 2].max(), ext[:, 3].max())
    if not any(_inside(ext, r, margin - 0.005) for r in plan.room_rects(room)):
        return None
    return moved, ext


def furnish(rng: np.random.Generator, plan: Plan, pal, min_pieces: int = 10, attempts: int = 12) -> Furnished:
    """Place each room's wish list, then fillers until `min_pieces` (capped at 40 pieces)."""
    occ, out, taken = Occupancy(plan), Furnished(), []

    def place(room, builder, mode, tries=attempts) -> bool:
        for attempt in range(tries):
            if attempt % 4 == 0:  # a fresh draw of sizes every few poses
                group = builder(rng, pal)
                if len(out.pieces) + len(group) > MAX_PIECES:
                    return False
            cand = _candidate(rng, plan, room, group, mode)
            if cand is None:
                continue
            moved, ext = cand
            if any(_overlaps(ext, t, 0.05) for t in taken) or any(_overlaps(ext, k) for k in occ.keepout):
                continue
            if not occ.try_add(_blocking(moved)):
                continue
            taken.append(ext)
            out.pieces.extend(moved)
            out.rooms.extend([room] * len(moved))
            return True
        return False

    for room, kind in enumerate(plan.room_kinds):
        for builder, mode, prob in WISHLIST[kind]:
            if rng.random() < prob:
                place(room, builder, mode, attempts if prob < 1.0 else 2 * attempts)
    for _ in range(80):
        if len(out.pieces) >= min_pieces:
            break
        builder, mode = FILLERS[int(rng.integers(len(FILLERS)))]
        place(int(rng.integers(plan.num_rooms)), builder, mode)
    return out


def _blocking(pieces) -> tuple[float, float, float, float]:
    e = np.array([p.extent(blocking_only=True) for p in pieces])
    return e[:, 0].min(), e[:, 1].min(), e[:, 2].max(), e[:, 3].max()

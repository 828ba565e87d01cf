"""Floor plans of procedural apartments: rooms, doors and wall runs on a decimetre grid.

A footprint is cut by recursive partition into rectangles (optionally with a corridor
strip first); a few neighbouring rectangles merge into L-shaped rooms and a corner may be
removed (L-shaped apartment). A random spanning tree of the room adjacency graph, plus
some extra edges, gets doorways, so the apartment is one connected floor. All plan
coordinates are integers in decimetres (exact comparisons); `Plan` exposes metres.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rvn_data.scenes.walls import Door, Rect, WallRun, wall_runs

DM = 0.1  # metres per plan unit
MIN_SIDE = 24  # smallest room side (dm)
DOOR_MIN, DOOR_MAX = 8, 10  # doorway clear width (dm)
DOOR_MARGIN = 3  # doorway distance from the ends of a shared wall (dm)
MIN_SHARED = DOOR_MAX + 2 * DOOR_MARGIN


@dataclass
class Plan:
    """A floor plan: rectangles grouped into rooms, doors between rooms and wall runs."""

    width: int
    depth: int
    rects: list[Rect]
    rect_room: list[int]
    room_kinds: list[str]
    doors: list[Door] = field(default_factory=list)
    walls: list[WallRun] = field(default_factory=list)

    @property
    def num_rooms(self) -> int:
        return len(self.room_kinds)

    def room_rects(self, room: int) -> list[Rect]:
        return [r for r, k in zip(self.rects, self.rect_room) if k == room]

    def room_area_m2(self, room: int) -> float:
        return sum(r.area for r in self.room_rects(room)) * DM * DM

    @property
    def area_m2(self) -> float:
        return sum(r.area for r in self.rects) * DM * DM


def _shared(a: Rect, b: Rect):
    """Common wall of two touching rectangles: (axis, c, t0, t1, side of a) or None."""
    for axis, (a0, a1, b0, b1), (s0, s1) in (
        ("x", (a.x0, a.x1, b.x0, b.x1), (max(a.z0, b.z0), min(a.z1, b.z1))),
        ("z", (a.z0, a.z1, b.z0, b.z1), (max(a.x0, b.x0), min(a.x1, b.x1))),
    ):
        if s1 - s0 <= 0:
            continue
        if a1 == b0:
            return axis, a1, s0, s1, -1
        if b1 == a0:
            return axis, a0, s0, s1, +1
    return None


def _split_rects(rng: np.random.Generator, rects: list[Rect], frozen: set[int], target: int) -> None:
    """Recursive partition: split the largest splittable rectangles until `target` of them."""
    while len(rects) < target:
        cand = [i for i, r in enumerate(rects) if i not in frozen
                and max(r.x1 - r.x0, r.z1 - r.z0) >= 2 * MIN_SIDE]
        if not cand:
            return
        w = np.array([rects[i].area for i in cand], np.float64) ** 2
        i = cand[int(rng.choice(len(cand), p=w / w.sum()))]
        r = rects[i]
        wx, wz = r.x1 - r.x0, r.z1 - r.z0
        along_x = wx >= 2 * MIN_SIDE and (wz < 2 * MIN_SIDE or rng.random() < wx / (wx + wz))
        if along_x:
            s = int(rng.integers(r.x0 + MIN_SIDE, r.x1 - MIN_SIDE + 1))
            rects[i], new = Rect(r.x0, r.z0, s, r.z1), Rect(s, r.z0, r.x1, r.z1)
        else:
            s = int(rng.integers(r.z0 + MIN_SIDE, r.z1 - MIN_SIDE + 1))
            rects[i], new = Rect(r.x0, r.z0, r.x1, s), Rect(r.x0, s, r.x1, r.z1)
        rects.append(new)


def _root(parent: list[int], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def try_plan(rng: np.random.Generator, split_code: int) -> Plan | None:
    """One attempt at a plan; None when the draw gives no connected layout."""
    area, width, depth = _footprint(rng, split_code)
    rects, frozen, corridor = _corridor(rng, area, width, depth)
    target = int(np.clip(round(area / rng.uniform(10.0, 17.0)), 3, 9)) + (corridor >= 0)
    _split_rects(rng, rects, frozen, target)
    n = len(rects)
    adj = {(i, j): s for i in range(n) for j in range(i + 1, n) if (s := _shared(rects[i], rects[j]))}
    parent, merged = _merge_rooms(rng, rects, adj, corridor)
    keep = _drop_corner(rng, rects, parent, merged, corridor, width, depth)
    rooms_of = {}
    rect_room = []
    for i in keep:
        rect_room.append(rooms_of.setdefault(_root(parent, i), len(rooms_of)))
    kept = [rects[i] for i in keep]
    idx = {old: new for new, old in enumerate(keep)}
    num_rooms = len(rooms_of)
    if not 3 <= num_rooms <= 8:
        return None
    corridor_room = rect_room[idx[corridor]] if corridor >= 0 else -1
    edges = _door_walls(adj, idx, rect_room)
    chosen = _door_edges(rng, edges, num_rooms, corridor_room)
    if chosen is None:
        return None
    doors = [_place_door(rng, edges[(a, b)], (a, b)) for a, b in sorted(chosen)]
    kinds = _room_kinds(rng, kept, rect_room, num_rooms, corridor_room)
    return Plan(width, depth, kept, rect_room, kinds, doors, wall_runs(kept, rect_room, doors))


def _footprint(rng: np.random.Generator, split_code: int) -> tuple[float, int, int]:
    """(area m², width dm, depth dm) of the apartment's outline; width mod 3 is the split's code."""
    area = rng.uniform(48.0, 112.0)
    aspect = rng.uniform(1.0, 1.7)
    width = int(round(np.sqrt(area * aspect) / DM))
    depth = int(round(area / (width * DM) / DM))
    if rng.random() < 0.5:
        width, depth = depth, width
    width += (split_code - width) % 3  # x size mod 3 == split code: splits never share a layout
    return area, width, depth


def _corridor(rng: np.random.Generator, area: float, width: int, depth: int) -> tuple[list[Rect], set[int], int]:
    """The first rectangles (rects, the frozen ones, the corridor's index or -1): the whole
    footprint, or in large apartments sometimes three strips with a corridor in the middle."""
    rects = [Rect(0, 0, width, depth)]
    short = min(width, depth)
    if area > 62 and short >= 2 * MIN_SIDE + 16 and rng.random() < 0.55:
        cw = int(rng.integers(12, 16))
        c = int(rng.integers(MIN_SIDE, short - MIN_SIDE - cw + 1))
        if width >= depth:
            rects = [Rect(0, 0, width, c), Rect(0, c, width, c + cw), Rect(0, c + cw, width, depth)]
        else:
            rects = [Rect(0, 0, c, depth), Rect(c, 0, c + cw, depth), Rect(c + cw, 0, width, depth)]
        return rects, {1}, 1
    return rects, set(), -1


def _merge_rooms(rng: np.random.Generator, rects: list[Rect], adj: dict, corridor: int) -> tuple[list[int], set[int]]:
    """L-shaped rooms: merge a few neighbour pairs whose common wall is not a full edge.
    Returns (union-find parents of the rectangles, the merged rectangles)."""
    n = len(rects)
    parent = list(range(n))
    merged: set[int] = set()
    for _ in range(int(rng.integers(0, 3))):
        pairs = []
        for (i, j), (axis, c, s0, s1, _side) in adj.items():
            if i in merged or j in merged or corridor in (i, j):
                continue
            ei = (rects[i].z0, rects[i].z1) if axis == "x" else (rects[i].x0, rects[i].x1)
            ej = (rects[j].z0, rects[j].z1) if axis == "x" else (rects[j].x0, rects[j].x1)
            if not ei == ej == (s0, s1) and s1 - s0 >= MIN_SHARED \
                    and rects[i].area + rects[j].area <= 4200 \
                    and len(set(_root(parent, k) for k in range(n))) > 4:
                pairs.append((i, j))
        if not pairs:
            break
        i, j = pairs[int(rng.integers(len(pairs)))]
        parent[_root(parent, j)] = _root(parent, i)
        merged |= {i, j}
    return parent, merged


def _drop_corner(rng, rects: list[Rect], parent: list[int], merged: set[int], corridor: int,
                 width: int, depth: int) -> list[int]:
    """Indices of the rectangles kept: optionally without one corner rectangle (L-shaped apartment)."""
    n = len(rects)
    keep = list(range(n))
    if rng.random() < 0.3:
        corners = [i for i, r in enumerate(rects) if i not in merged and i != corridor
                   and (r.x0 == 0) != (r.x1 == width) and (r.z0 == 0) != (r.z1 == depth)]
        total = sum(r.area for r in rects)
        corners = [i for i in corners if (total - rects[i].area) * DM * DM >= 42.0]
        if corners and len(set(_root(parent, k) for k in range(n))) >= 5:
            keep.remove(corners[int(rng.integers(len(corners)))])
    return keep


def _door_walls(adj: dict, idx: dict, rect_room: list[int]) -> dict:
    """{(room a, room b): the shared walls of kept rectangles long enough for a doorway}."""
    edges = {}
    for (i, j), s in adj.items():
        if i in idx and j in idx and s[3] - s[2] >= MIN_SHARED:
            a, b = rect_room[idx[i]], rect_room[idx[j]]
            if a != b:
                edges.setdefault((min(a, b), max(a, b)), []).append(s)
    return edges


def _door_edges(rng, edges: dict, num_rooms: int, corridor_room: int) -> list[tuple[int, int]] | None:
    """Room pairs that get a door: a random spanning tree of the room graph plus extra loops
    (likelier next to the corridor); None when the rooms are not all connected."""
    keys = sorted(edges)
    order = rng.permutation(len(keys))
    uf = list(range(num_rooms))
    chosen = []
    for k in order:
        a, b = keys[k]
        ra, rb = _root(uf, a), _root(uf, b)
        extra_p = 0.75 if corridor_room in (a, b) else 0.2
        if ra != rb:
            uf[ra] = rb
            chosen.append(keys[k])
        elif rng.random() < extra_p:
            chosen.append(keys[k])
    if len({_root(uf, r) for r in range(num_rooms)}) != 1:
        return None
    return chosen


def _place_door(rng, walls: list, rooms: tuple[int, int]) -> Door:
    """A doorway on one of the rooms' shared ``walls``, more often near a corner than mid-wall."""
    axis, c, s0, s1, _side = walls[int(rng.integers(len(walls)))]
    w = int(rng.integers(DOOR_MIN, DOOR_MAX + 1))
    lo, hi = s0 + DOOR_MARGIN, s1 - DOOR_MARGIN - w
    u = rng.random()  # doorways sit near a corner more often than mid-wall (room for furniture)
    t0 = lo if u < 0.3 else hi if u < 0.6 else int(rng.integers(lo, hi + 1))
    return Door(axis, c, t0, t0 + w, rooms)


def _room_kinds(rng, rects, rect_room, num_rooms, corridor_room) -> list[str]:
    """Room kinds: corridor, living (largest), kitchen, bedrooms/office, small bath/storage."""
    areas = np.zeros(num_rooms)
    for r, k in zip(rects, rect_room):
        areas[k] += r.area * DM * DM
    kinds = [""] * num_rooms
    if corridor_room >= 0:
        kinds[corridor_room] = "corridor"
    order = [k for k in np.argsort(-areas, kind="stable") if k != corridor_room]
    rest = ["living", "kitchen"]
    for k in order:
        if rest:
            kinds[k] = rest.pop(0)
        elif areas[k] < 7.5:
            kinds[k] = "bath"
        else:
            kinds[k] = ("bedroom", "bedroom", "office")[int(rng.integers(3))]
    return kinds


def make_plan(rng: np.random.Generator, split_code: int, attempts: int = 64) -> Plan:
    """A connected plan with 3-8 rooms (retries with further draws from `rng`)."""
    for _ in range(attempts):
        plan = try_plan(rng, split_code)
        if plan is not None:
            return plan
    raise RuntimeError("no connected floor plan found")  # pragma: no cover - never observed

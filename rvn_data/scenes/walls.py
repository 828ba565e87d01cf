"""The parts of a floor plan's walls: the rooms' rectangles, doorways on wall lines, and wall runs, every rectangle
edge line split into half-thickness strips between different rooms (or a room and the outside), with the doorways cut
out. Plan coordinates are integers in decimetres (`rvn_data.scenes.floorplan` makes the plans)."""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle [x0, x1] x [z0, z1] in dm."""

    x0: int
    z0: int
    x1: int
    z1: int

    @property
    def area(self) -> int:
        return (self.x1 - self.x0) * (self.z1 - self.z0)


@dataclass(frozen=True)
class Door:
    """Doorway on the wall line `axis`=`c`: 'x' = line x=c (the wall runs along z), 'z' = line z=c.

    The gap is [t0, t1] along the wall; it joins rooms `rooms`.
    """

    axis: str
    c: int
    t0: int
    t1: int
    rooms: tuple[int, int]


@dataclass(frozen=True)
class WallRun:
    """Half-thickness wall strip on line `axis`=`c`, on `side` (+1/-1) of it, over [t0, t1].

    `owner` is the room on that side (-1 = outside). `ext0`/`ext1`: whether the ends
    reach into a junction (extend by half a wall) rather than end at a door jamb.
    """

    axis: str
    c: int
    side: int
    t0: int
    t1: int
    owner: int
    ext0: bool
    ext1: bool


def wall_runs(rects: Sequence[Rect], rect_room: Sequence[int], doors: Sequence[Door]) -> list[WallRun]:
    """Split every edge line of the rectangles ``rects`` (of rooms ``rect_room``) into runs between different rooms,
    the ``doors`` cut out."""
    lines: dict[tuple[str, int], list[tuple[int, int, int, int]]] = {}
    for r, room in zip(rects, rect_room):
        lines.setdefault(("x", r.x0), []).append((r.z0, r.z1, +1, room))
        lines.setdefault(("x", r.x1), []).append((r.z0, r.z1, -1, room))
        lines.setdefault(("z", r.z0), []).append((r.x0, r.x1, +1, room))
        lines.setdefault(("z", r.z1), []).append((r.x0, r.x1, -1, room))
    runs: list[WallRun] = []
    for (axis, c), edges in sorted(lines.items()):
        cuts = sorted({t for e in edges for t in e[:2]})
        gaps = [(d.t0, d.t1) for d in doors if d.axis == axis and d.c == c]
        for side in (+1, -1):
            segs: list[list[int]] = []  # [t0, t1, owner]
            for u, v in zip(cuts[:-1], cuts[1:]):
                own = {s: -1 for s in (+1, -1)}
                for t0, t1, s, room in edges:
                    if t0 <= u and v <= t1:
                        own[s] = room
                if own[+1] == own[-1]:
                    continue
                if segs and segs[-1][1] == u and segs[-1][2] == own[side]:
                    segs[-1][1] = v
                else:
                    segs.append([u, v, own[side]])
            for u, v, owner in segs:
                pieces = [(u, v, True, True)]
                for d0, d1 in gaps:
                    nxt = []
                    for p0, p1, e0, e1 in pieces:
                        if d1 <= p0 or d0 >= p1:
                            nxt.append((p0, p1, e0, e1))
                            continue
                        if d0 > p0:
                            nxt.append((p0, d0, e0, False))
                        if d1 < p1:
                            nxt.append((d1, p1, False, e1))
                    pieces = nxt
                runs.extend(WallRun(axis, c, side, p0, p1, owner, e0, e1) for p0, p1, e0, e1 in pieces)
    return runs

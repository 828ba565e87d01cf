"""Procedural apartments, the embedded default scene set (`procedural:<split>/<index>`).

`make_apartment(split, index)` deterministically builds a furnished multi-room apartment
(floor plan in `floorplan`, furniture in `furnish`/`furniture`, textures in `textures`):
the same (split, index) gives byte-identical arrays. Splits: train (800), val (50),
test (50); each split has its own seed stream and the footprint width in decimetres
is congruent to the split's code mod 3, so two splits can never share a layout.
"""
from __future__ import annotations

import colorsys
from dataclasses import dataclass

import numpy as np

from rvn_data.scenes import meshing, textures
from rvn_data.scenes.floorplan import DM, Plan, make_plan
from rvn_data.scenes.furnish import HALF_WALL, Furnished, furnish
from rvn_data.scenes.scene import Part, Scene, SceneError

SPLITS = {"train": (0, 800), "val": (1, 50), "test": (2, 50)}
SEED_BASE = 0x52564E00  # "RVN"; seed = [SEED_BASE + split code, index]
DOOR_HEIGHT = (2.0, 2.1)
FLOOR_OF_KIND = {"living": ("floor_wood", "floor_tile"), "kitchen": ("floor_tile",),
                 "bedroom": ("floor_carpet", "floor_wood"), "office": ("floor_wood", "floor_carpet"),
                 "bath": ("floor_tile",), "corridor": ("floor_wood", "floor_tile")}


@dataclass(frozen=True)
class ApartmentInfo:
    """Layout metadata of one apartment (what `describe_apartment` returns)."""

    scene_id: str
    area_m2: float
    room_kinds: tuple[str, ...]
    room_areas_m2: tuple[float, ...]
    num_doors: int
    furniture: tuple[str, ...]
    wall_height: float
    footprint_m: tuple[float, float]  # (x size, z size) of the plan between outer wall centre lines
    door_widths_m: tuple[float, ...]
    furniture_extents: tuple[tuple[float, float, float, float], ...]  # world [x0, z0, x1, z1] blocking floor

    @property
    def num_rooms(self) -> int:
        return len(self.room_kinds)

    @property
    def num_furniture(self) -> int:
        return len(self.furniture)


def _hsv(h, s, v) -> tuple[int, int, int]:
    return tuple(int(round(255 * c)) for c in colorsys.hsv_to_rgb(h % 1.0, s, v))


class Palette:
    """Per-scene colours: a few wood tints, fabrics, paints and fixed accents."""

    def __init__(self, rng: np.random.Generator, height: float):
        self.height = height
        self.woods = [_hsv(rng.uniform(0.05, 0.11), rng.uniform(0.35, 0.7), rng.uniform(0.35, 0.95))
                      for _ in range(3)]
        self.fabrics = [_hsv(rng.random(), rng.uniform(0.2, 0.7), rng.uniform(0.35, 0.85)) for _ in range(3)]
        self.metal = _hsv(0, 0, rng.uniform(0.15, 0.75))
        self.kitchen = _hsv(rng.random(), rng.uniform(0.0, 0.4), rng.uniform(0.6, 0.95))
        self.stone = _hsv(rng.uniform(0.05, 0.15), rng.uniform(0.0, 0.2), rng.uniform(0.2, 0.9))
        self.appliance = _hsv(0, 0, rng.choice([0.85, 0.7, 0.3]))
        self.pot = _hsv(rng.uniform(0.0, 0.1), rng.uniform(0.3, 0.7), rng.uniform(0.4, 0.8))
        self.column = _hsv(rng.random(), rng.uniform(0.0, 0.15), rng.uniform(0.75, 0.95))
        self.trim = _hsv(rng.random(), rng.uniform(0.0, 0.1), rng.uniform(0.85, 1.0))

    def wood(self, rng) -> tuple[int, int, int]:
        return self.woods[int(rng.integers(len(self.woods)))]

    def fabric(self, rng, light: bool = False) -> tuple[int, int, int]:
        if light:
            return _hsv(rng.random(), rng.uniform(0.0, 0.2), rng.uniform(0.85, 1.0))
        return self.fabrics[int(rng.integers(len(self.fabrics)))]

    def accent(self, rng) -> tuple[int, int, int]:
        return _hsv(rng.random(), rng.uniform(0.3, 0.8), rng.uniform(0.3, 0.9))


def _check(split: str, index: int) -> tuple[int, int]:
    if split not in SPLITS:
        raise SceneError(f"procedural scene {split!r}/{index!r}: unknown split {split!r}; "
                         f"valid splits are {', '.join(SPLITS)}")
    code, count = SPLITS[split]
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < count:
        raise SceneError(f"procedural scene {split}/{index!r}: index out of range; "
                         f"valid indices for split {split!r} are 0..{count - 1}")
    return code, int(index)


def parse_scene_id(spec: str) -> tuple[str, int]:
    """``procedural:<split>/<index>`` → (split, index); SceneError if malformed or out of range."""
    body = spec[len("procedural:"):] if spec.startswith("procedural:") else None
    split, _, idx = (body or "").partition("/")
    if body is None or not idx.isdigit():
        raise SceneError(f"scene spec {spec!r}: expected 'procedural:<split>/<index>', "
                         f"e.g. 'procedural:train/0' (splits {', '.join(SPLITS)})")
    _check(split, int(idx))
    return split, int(idx)


def _layout(split: str, index: int):
    code, index = _check(split, index)
    rng = np.random.default_rng([SEED_BASE + code, index])
    plan = make_plan(rng, code)
    height = float(np.round(rng.uniform(2.5, 2.8), 2))
    pal = Palette(rng, height)
    min_pieces = int(np.clip(round(plan.area_m2 * rng.uniform(0.16, 0.24)), 10, 30))
    items = furnish(rng, plan, pal, min_pieces=min_pieces)
    return rng, plan, pal, items


def describe_apartment(split: str, index: int) -> ApartmentInfo:
    """Layout metadata (rooms, doors, furniture) of `procedural:<split>/<index>`, without meshing."""
    _, plan, pal, items = _layout(split, index)
    return _info(split, index, plan, pal, items)


def _info(split, index, plan: Plan, pal: Palette, items: Furnished) -> ApartmentInfo:
    off = np.array([plan.width * DM / 2, plan.depth * DM / 2] * 2)
    return ApartmentInfo(
        scene_id=f"procedural:{split}/{index}", area_m2=round(plan.area_m2, 2),
        room_kinds=tuple(plan.room_kinds),
        room_areas_m2=tuple(round(plan.room_area_m2(r), 2) for r in range(plan.num_rooms)),
        num_doors=len(plan.doors), furniture=tuple(p.kind for p in items.pieces), wall_height=pal.height,
        footprint_m=(round(plan.width * DM, 1), round(plan.depth * DM, 1)),
        door_widths_m=tuple(round((d.t1 - d.t0) * DM, 1) for d in plan.doors),
        furniture_extents=tuple(tuple(float(v) for v in p.extent(blocking_only=True) - off)
                                for p in items.pieces))


def make_apartment(split: str, index: int) -> Scene:
    """The furnished apartment `procedural:<split>/<index>` as a Scene (metres, y up, floor y=0)."""
    rng, plan, pal, items = _layout(split, index)
    parts = _build_parts(rng, plan, pal, items)
    return Scene(f"procedural:{split}/{index}", parts, source="rvn_data.scenes.procedural")


def _room_at(plan: Plan, x: float, z: float) -> int:
    """Room containing plan point (x, z) in dm, -1 outside."""
    for r, k in zip(plan.rects, plan.rect_room):
        if r.x0 <= x <= r.x1 and r.z0 <= z <= r.z1:
            return k
    return -1


def _strip(axis, c, side, t0, t1, y0, y1, proud0, proud1):
    """Box on the `side` face of wall line c (metres) between depths proud0..proud1 from the line."""
    a0, a1 = sorted((c + side * proud0, c + side * proud1))
    return (a0, y0, t0, a1, y1, t1) if axis == "x" else (t0, y0, a0, t1, y1, a1)


def _build_parts(rng, plan: Plan, pal: Palette, items: Furnished) -> list[Part]:
    """Meshes grouped by material: floors, walls, ceiling, trim/furniture materials."""
    h = pal.height
    tile_size = float(rng.choice([0.6, 0.8, 1.2]))
    floor_col = _hsv(rng.uniform(0.04, 0.12), rng.uniform(0.3, 0.65), rng.uniform(0.45, 0.9))
    tile_col = _hsv(rng.random(), rng.uniform(0.0, 0.25), rng.uniform(0.6, 0.95))
    tile_col2 = _hsv(rng.random(), rng.uniform(0.0, 0.4), rng.uniform(0.2, 0.6)) if rng.random() < 0.3 else None
    mats = {  # name: (texture, tile metres)
        "floor_wood": (textures.wood_planks(rng, floor_col), 1.2),
        "floor_tile": (textures.floor_tiles(rng, tile_col, tile_col2), tile_size),
        "floor_carpet": (textures.carpet(rng, (235, 235, 235)), 1.0),
        "walls": (textures.paint(rng), 2.0),
        "ceiling": (textures.paint(rng), 2.0),
        "wood": (textures.wood_grain(rng), 0.6),
        "fabric": (textures.fabric(rng), 0.5),
        "plant": (textures.foliage(rng), 0.4),
        "painted": (None, 1.0),
    }
    boxes = {m: [] for m in mats}
    cyls = {m: [] for m in mats}
    quads = {m: [] for m in mats}
    # floors and ceiling, per room
    for room, kind in enumerate(plan.room_kinds):
        opts = FLOOR_OF_KIND[kind]
        mat = opts[int(rng.integers(len(opts)))]
        tint = (_hsv(rng.random(), rng.uniform(0.2, 0.6), rng.uniform(0.5, 0.9)) if mat == "floor_carpet"
                else _hsv(rng.random(), rng.uniform(0.0, 0.08), rng.uniform(0.88, 1.0)))
        for r in plan.room_rects(room):
            rect = (r.x0 * DM, r.z0 * DM, r.x1 * DM, r.z1 * DM)
            quads[mat].append((rect, 0.0, True, tint))
            quads["ceiling"].append((rect, h, False, (245, 245, 240)))
    # walls with skirting boards, per-room paint
    paint = [_hsv(rng.random(), rng.uniform(0.03, 0.3), rng.uniform(0.75, 0.97)) for _ in plan.room_kinds]
    colour = lambda room: paint[room] if room >= 0 else (205, 205, 200)  # noqa: E731
    e = HALF_WALL - 0.001
    for w in plan.walls:
        c, t0, t1 = w.c * DM, w.t0 * DM, w.t1 * DM
        boxes["walls"].append((_strip(w.axis, c, w.side, t0 - e * w.ext0, t1 + e * w.ext1, 0, h, 0, HALF_WALL),
                               colour(w.owner)))
        if w.owner >= 0:
            s0, s1 = t0 + HALF_WALL * w.ext0, t1 - HALF_WALL * w.ext1
            boxes["painted"].append((_strip(w.axis, c, w.side, s0, s1, 0, 0.08, HALF_WALL, HALF_WALL + 0.012),
                                     pal.trim))
            if not _window(rng, plan, w, boxes, h):
                _picture(rng, w, boxes, pal)
    # doorways: lintel halves in each room's paint, frames in trim colour
    for d in plan.doors:
        dh = float(rng.uniform(*DOOR_HEIGHT))
        c, t0, t1 = d.c * DM, d.t0 * DM, d.t1 * DM
        mid = (d.t0 + d.t1) / 2
        for side in (1, -1):
            room = _room_at(plan, d.c + side * 0.5, mid) if d.axis == "x" else _room_at(plan, mid, d.c + side * 0.5)
            boxes["walls"].append((_strip(d.axis, c, side, t0, t1, dh, h, 0, HALF_WALL), colour(room)))
            for a, b, y0, y1 in ((t0 - 0.06, t0, 0, dh + 0.06), (t1, t1 + 0.06, 0, dh + 0.06),
                                 (t0, t1, dh, dh + 0.06)):
                boxes["painted"].append((_strip(d.axis, c, side, a, b, y0, y1, HALF_WALL, HALF_WALL + 0.015),
                                         pal.trim))
    for piece in items.pieces:
        for mat, b, rgb in piece.boxes:
            boxes[mat].append((b, rgb))
        for mat, cy, rgb in piece.cyls:
            cyls[mat].append((cy, rgb))
    off = np.array([plan.width * DM / 2, 0.0, plan.depth * DM / 2])
    parts = []
    for name, (tex, tile) in mats.items():
        chunks = []
        if boxes[name]:
            chunks.append(meshing.boxes([b for b, _ in boxes[name]], [c for _, c in boxes[name]], tile))
        if cyls[name]:
            chunks.append(meshing.cylinders([b for b, _ in cyls[name]], [c for _, c in cyls[name]], tile))
        for rect, y, up, rgb in quads[name]:
            chunks.append(meshing.hquads([rect], y, up, [rgb], tile))
        if not chunks:
            continue
        verts, faces, uv, rgb, n = [], [], [], [], 0
        for v, f, t, col in chunks:
            verts.append(v)
            faces.append(f + n)
            uv.append(t)
            rgb.append(col)
            n += len(v)
        rgb = np.concatenate(rgb)
        colors = np.concatenate([rgb, np.full((len(rgb), 1), 255)], 1)
        parts.append(Part(name, np.concatenate(verts) - off, np.concatenate(faces), np.concatenate(uv),
                          colors, (1.0, 1.0, 1.0, 1.0), tex))
    return parts


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
    boxes["painted"].append((_strip(w.axis, c, w.side, t0, t0 + ww, y0, y1, HALF_WALL, HALF_WALL + 0.008),
                             (205, 228, 246)))
    for a, b, ya, yb in ((t0 - 0.05, t0, y0 - 0.05, y1 + 0.05), (t0 + ww, t0 + ww + 0.05, y0 - 0.05, y1 + 0.05),
                         (t0, t0 + ww, y0 - 0.05, y0), (t0, t0 + ww, y1, y1 + 0.05),
                         (t0 + ww / 2 - 0.02, t0 + ww / 2 + 0.02, y0, y1)):
        boxes["painted"].append((_strip(w.axis, c, w.side, a, b, ya, yb, HALF_WALL, HALF_WALL + 0.02),
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
    boxes["painted"].append((_strip(w.axis, c, w.side, t0, t0 + pw, y0, y0 + ph, HALF_WALL, HALF_WALL + 0.02),
                             frame))
    n = int(rng.integers(1, 4))
    for i in range(n):  # canvas split into n vertical colour blocks
        a, b = t0 + 0.03 + i * (pw - 0.06) / n, t0 + 0.03 + (i + 1) * (pw - 0.06) / n
        boxes["painted"].append((_strip(w.axis, c, w.side, a, b, y0 + 0.03, y0 + ph - 0.03, HALF_WALL + 0.02,
                                        HALF_WALL + 0.025), pal.accent(rng)))

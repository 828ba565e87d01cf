"""Procedural apartments, the embedded default scene set (`procedural:<split>/<index>`).

`make_apartment(split, index)` deterministically builds a furnished multi-room apartment
(floor plan in `floorplan`, walls, doorways, windows and pictures in `shell`, furniture in
`furnish`/`furniture`, textures in `textures`):
the same (split, index) gives byte-identical arrays. Splits: train (800), val (50),
test (50); each split has its own seed stream and the footprint width in decimetres
is congruent to the split's code mod 3, so two splits can never share a layout.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rvn_data.scenes import meshing, shell, textures
from rvn_data.scenes.floorplan import DM, Plan, make_plan
from rvn_data.scenes.furnish import Furnished, furnish
from rvn_data.scenes.palette import Palette, hsv
from rvn_data.scenes.scene import Part, Scene, SceneError

SPLITS = {"train": (0, 800), "val": (1, 50), "test": (2, 50)}
SEED_BASE = 0x52564E00  # "RVN"; seed = [SEED_BASE + split code, index]
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


def _build_parts(rng, plan: Plan, pal: Palette, items: Furnished) -> list[Part]:
    """Meshes grouped by material: floors, walls, ceiling, trim/furniture materials."""
    mats = _materials(rng)
    boxes = {m: [] for m in mats}
    cyls = {m: [] for m in mats}
    quads = {m: [] for m in mats}
    _floors(rng, plan, pal.height, quads)
    paint = [hsv(rng.random(), rng.uniform(0.03, 0.3), rng.uniform(0.75, 0.97)) for _ in plan.room_kinds]
    colour = lambda room: paint[room] if room >= 0 else (205, 205, 200)  # noqa: E731
    shell.add_walls(rng, plan, pal, boxes, colour)
    shell.add_doorways(rng, plan, pal, boxes, colour)
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
        if chunks:
            parts.append(_part(name, tex, chunks, off))
    return parts


def _materials(rng) -> dict:
    """The scene's materials: {name: (texture or None, tile size in metres)}."""
    tile_size = float(rng.choice([0.6, 0.8, 1.2]))
    floor_col = hsv(rng.uniform(0.04, 0.12), rng.uniform(0.3, 0.65), rng.uniform(0.45, 0.9))
    tile_col = hsv(rng.random(), rng.uniform(0.0, 0.25), rng.uniform(0.6, 0.95))
    tile_col2 = hsv(rng.random(), rng.uniform(0.0, 0.4), rng.uniform(0.2, 0.6)) if rng.random() < 0.3 else None
    return {  # name: (texture, tile metres)
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


def _floors(rng, plan: Plan, h: float, quads: dict) -> None:
    """Each room's floor (a material of its kind, tinted) and the ceiling above it."""
    for room, kind in enumerate(plan.room_kinds):
        opts = FLOOR_OF_KIND[kind]
        mat = opts[int(rng.integers(len(opts)))]
        tint = (hsv(rng.random(), rng.uniform(0.2, 0.6), rng.uniform(0.5, 0.9)) if mat == "floor_carpet"
                else hsv(rng.random(), rng.uniform(0.0, 0.08), rng.uniform(0.88, 1.0)))
        for r in plan.room_rects(room):
            rect = (r.x0 * DM, r.z0 * DM, r.x1 * DM, r.z1 * DM)
            quads[mat].append((rect, 0.0, True, tint))
            quads["ceiling"].append((rect, h, False, (245, 245, 240)))


def _part(name: str, texture, chunks: list, off: np.ndarray) -> Part:
    """One material's mesh chunks (vertices, faces, uv, colours) joined into a Part, centred by ``off``."""
    verts, faces, uv, rgb, n = [], [], [], [], 0
    for v, f, t, col in chunks:
        verts.append(v)
        faces.append(f + n)
        uv.append(t)
        rgb.append(col)
        n += len(v)
    rgb = np.concatenate(rgb)
    colors = np.concatenate([rgb, np.full((len(rgb), 1), 255)], 1)
    return Part(name, np.concatenate(verts) - off, np.concatenate(faces), np.concatenate(uv),
                colors, (1.0, 1.0, 1.0, 1.0), texture)

"""Furniture catalogue for procedural apartments: pieces made of boxes and vertical cylinders.

A `Piece` is built in a local frame: width along x centred on 0, back at z = 0, front
towards +z, floor at y = 0. Materials: "wood" and "fabric" (tinted textures), "painted"
(vertex colour only), "plant" (foliage texture). Anything whose bottom is below the
robot's height blocks the floor under it, so tables and chairs are tops + legs that a
1.0 m robot cannot pass under.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

BLOCK_H = 1.0  # prims starting below this height block the floor


@dataclass
class Piece:
    """One piece of furniture: `boxes` (mat, [x0,y0,z0,x1,y1,z1], rgb) and `cyls` (mat, [cx,cz,r,y0,y1], rgb)."""

    kind: str
    boxes: list = field(default_factory=list)
    cyls: list = field(default_factory=list)

    def box(self, mat, x0, y0, z0, x1, y1, z1, rgb) -> None:
        self.boxes.append((mat, (x0, y0, z0, x1, y1, z1), tuple(rgb)))

    def cyl(self, mat, cx, cz, r, y0, y1, rgb) -> None:
        self.cyls.append((mat, (cx, cz, r, y0, y1), tuple(rgb)))

    def extent(self, blocking_only: bool = False) -> np.ndarray:
        """[x0, z0, x1, z1] over all prims (or over those that block the floor)."""
        rects = [(b[0], b[2], b[3], b[5]) for _, b, _ in self.boxes if not blocking_only or b[1] < BLOCK_H]
        rects += [(c[0] - c[2], c[1] - c[2], c[0] + c[2], c[1] + c[2]) for _, c, _ in self.cyls
                  if not blocking_only or c[3] < BLOCK_H]
        a = np.array(rects, np.float64).reshape(-1, 4)
        return np.array([a[:, 0].min(), a[:, 1].min(), a[:, 2].max(), a[:, 3].max()])

    def moved(self, k: int, dx: float, dz: float) -> Piece:
        """Rotated by k quarter turns (local +z → +z, +x, -z, -x for k = 0..3), then shifted."""
        c, s = [(1, 0), (0, 1), (-1, 0), (0, -1)][k % 4]

        def tf(x, z):
            return x * c + z * s + dx, -x * s + z * c + dz

        out = Piece(self.kind)
        for mat, (x0, y0, z0, x1, y1, z1), rgb in self.boxes:
            (ax, az), (bx, bz) = tf(x0, z0), tf(x1, z1)
            out.box(mat, min(ax, bx), y0, min(az, bz), max(ax, bx), y1, max(az, bz), rgb)
        for mat, (cx, cz, r, y0, y1), rgb in self.cyls:
            out.cyl(mat, *tf(cx, cz), r, y0, y1, rgb)
        return out


def _jit(rng, rgb, amount=0.08):
    return tuple(np.clip(np.asarray(rgb) * (1 + amount * rng.uniform(-1, 1, 3)), 0, 255).astype(int).tolist())


def table(rng, pal, kind="table", w=None, d=None, h=None) -> Piece:
    w = w or rng.uniform(1.0, 1.6)
    d = d or rng.uniform(0.7, 0.95)
    h = h or rng.uniform(0.72, 0.78)
    p, wood, leg = Piece(kind), pal.wood(rng), rng.uniform(0.045, 0.07)
    p.box("wood", -w / 2, h - 0.04, 0, w / 2, h, d, wood)
    for x in (-w / 2 + 0.05, w / 2 - 0.05 - leg):
        for z in (0.05, d - 0.05 - leg):
            p.box("wood", x, 0, z, x + leg, h - 0.04, z + leg, wood)
    return p


def chair(rng, pal, color=None) -> Piece:
    w, d, h, leg = rng.uniform(0.42, 0.5), rng.uniform(0.42, 0.5), rng.uniform(0.44, 0.48), 0.04
    p, wood = Piece("chair"), color or pal.wood(rng)
    p.box("wood", -w / 2, h - 0.04, 0, w / 2, h, d, wood)
    for x in (-w / 2, w / 2 - leg):
        for z in (0, d - leg):
            p.box("wood", x, 0, z, x + leg, h - 0.04, z + leg, wood)
    p.box("wood", -w / 2, h, 0, w / 2, rng.uniform(0.85, 0.95), 0.04, wood)
    return p


def sofa(rng, pal, w=None) -> Piece:
    w, d = w or rng.uniform(1.6, 2.3), rng.uniform(0.82, 0.95)
    p, col = Piece("sofa" if w > 1.2 else "armchair"), pal.fabric(rng)
    arm = 0.16
    p.box("fabric", -w / 2, 0.08, 0, w / 2, 0.42, d, col)
    p.box("painted", -w / 2 + 0.05, 0, 0.05, w / 2 - 0.05, 0.08, d - 0.05, (40, 36, 32))
    p.box("fabric", -w / 2, 0.42, 0, w / 2, rng.uniform(0.78, 0.9), 0.22, _jit(rng, col))
    for x in (-w / 2, w / 2 - arm):
        p.box("fabric", x, 0.42, 0.22, x + arm, 0.62, d, col)
    return p


def bed(rng, pal) -> Piece:
    w, d = (rng.uniform(1.4, 1.8), 2.05) if rng.random() < 0.65 else (rng.uniform(0.9, 1.0), 2.0)
    p, wood = Piece("bed"), pal.wood(rng)
    p.box("wood", -w / 2, 0, 0, w / 2, 0.32, d, wood)
    p.box("fabric", -w / 2 + 0.03, 0.32, 0.06, w / 2 - 0.03, 0.52, d - 0.03, pal.fabric(rng, light=True))
    p.box("fabric", -w / 2 + 0.03, 0.52, 0.75, w / 2 - 0.03, 0.56, d - 0.02, pal.fabric(rng))
    p.box("wood", -w / 2, 0, 0, w / 2, rng.uniform(0.9, 1.15), 0.06, wood)
    if w > 1.2:  # folded blanket across a double bed: its top is no 2 m² "floor" island
        p.box("fabric", -w / 2 + 0.02, 0.52, 1.0, w / 2 - 0.02, 0.78, 1.3, pal.fabric(rng))
    npill = 2 if w > 1.2 else 1
    pw = (w - 0.2) / npill
    for i in range(npill):
        x = -w / 2 + 0.1 + i * pw
        p.box("fabric", x + 0.03, 0.52, 0.1, x + pw - 0.03, 0.64, 0.5, (235, 235, 228))
    return p


def cabinet(rng, pal, kind="cabinet", w=None, d=None, h=None) -> Piece:
    """A closed box with door seams and knobs: wardrobe, dresser, nightstand, tv stand, cabinet."""
    w, d, h = w or rng.uniform(0.6, 1.2), d or rng.uniform(0.4, 0.6), h or rng.uniform(0.7, 1.0)
    p, wood = Piece(kind), pal.wood(rng)
    p.box("wood", -w / 2, 0.05, 0, w / 2, h, d, wood)
    p.box("painted", -w / 2 + 0.03, 0, 0.03, w / 2 - 0.03, 0.05, d - 0.03, (45, 40, 35))
    ndoor = max(1, int(round(w / 0.5)))
    for i in range(1, ndoor):
        x = -w / 2 + i * w / ndoor
        p.box("painted", x - 0.006, 0.08, d, x + 0.006, h - 0.03, d + 0.008, (50, 45, 40))
    for i in range(ndoor):
        x = -w / 2 + (i + 0.5) * w / ndoor
        p.box("painted", x - 0.05, h * 0.55, d, x + 0.05, h * 0.55 + 0.02, d + 0.025, pal.metal)
    return p


def bookshelf(rng, pal) -> Piece:
    w, d, h = rng.uniform(0.7, 1.5), rng.uniform(0.28, 0.38), rng.uniform(1.5, 2.1)
    p, wood, t = Piece("bookshelf"), pal.wood(rng), 0.025
    p.box("wood", -w / 2, 0, 0, w / 2, h, 0.015, wood)
    for x in (-w / 2, w / 2 - t):
        p.box("wood", x, 0, 0, x + t, h, d, wood)
    nb = int(rng.integers(4, 6))
    for i in range(nb + 1):
        y = 0.06 + i * (h - 0.06 - t) / nb
        p.box("wood", -w / 2 + t, y, 0, w / 2 - t, y + t, d, wood)
        if i == nb:
            break
        x = -w / 2 + t + rng.uniform(0.0, 0.1)
        while True:
            bw = rng.uniform(0.1, 0.3)
            if x + bw > w / 2 - t - 0.02:
                break
            bh = min(rng.uniform(0.15, 0.3), (h - 0.06) / nb - 0.05)
            p.box("painted", x, y + t, 0.03, x + bw, y + t + bh, d - rng.uniform(0.02, 0.08), pal.accent(rng))
            x += bw + rng.uniform(0.0, 0.12)
    return p


def counter(rng, pal) -> Piece:
    """Kitchen counter with worktop, sink, hob and wall cabinets above."""
    w, d, h = rng.uniform(1.6, 3.2), 0.62, 0.9
    p, body, top = Piece("counter"), pal.kitchen, pal.stone
    p.box("painted", -w / 2, 0.1, 0, w / 2, h - 0.04, d - 0.02, body)
    p.box("painted", -w / 2 + 0.02, 0, 0, w / 2 - 0.02, 0.1, d - 0.07, (40, 40, 40))
    p.box("painted", -w / 2, h - 0.04, 0, w / 2, h, d, top)
    ndoor = max(2, int(round(w / 0.6)))
    for i in range(1, ndoor):
        x = -w / 2 + i * w / ndoor
        p.box("painted", x - 0.005, 0.12, d - 0.02, x + 0.005, h - 0.06, d - 0.012, (60, 60, 60))
    sx = rng.uniform(-w / 2 + 0.4, w / 2 - 0.4)
    p.box("painted", sx - 0.25, h, 0.12, sx + 0.25, h + 0.006, 0.5, (175, 178, 182))
    p.box("painted", -w / 2 + 0.08, h, 0.1, -w / 2 + 0.6, h + 0.01, 0.55, (25, 25, 28))
    p.box("painted", -w / 2, 1.45, 0, w / 2, 2.15, 0.35, _jit(rng, body))
    return p


def fridge(rng, pal) -> Piece:
    w, h = rng.uniform(0.6, 0.75), rng.uniform(1.75, 1.95)
    p, col = Piece("fridge"), pal.appliance
    p.box("painted", -w / 2, 0, 0, w / 2, h, 0.66, col)
    p.box("painted", -w / 2, h * 0.62, 0.66, w / 2, h * 0.62 + 0.01, 0.665, (80, 80, 80))
    p.box("painted", w / 2 - 0.08, h * 0.3, 0.66, w / 2 - 0.06, h * 0.55, 0.7, (120, 120, 120))
    return p


def washer(rng, pal) -> Piece:
    p = Piece("washer")
    p.box("painted", -0.3, 0, 0, 0.3, 0.85, 0.6, pal.appliance)
    p.cyl("painted", 0.0, 0.605, 0.2, 0.25, 0.65, (60, 70, 80))
    return p


def floor_lamp(rng, pal) -> Piece:
    """Thin obstacle: a 5 cm pole with a flat base and a shade above the robot."""
    p, h, col = Piece("floor_lamp"), rng.uniform(1.45, 1.75), pal.metal
    p.cyl("painted", 0, 0.2, 0.14, 0, 0.02, col)
    p.cyl("painted", 0, 0.2, 0.025, 0.02, h, col)
    p.cyl("fabric", 0, 0.2, 0.2, h, h + 0.28, (238, 228, 200))
    return p


def plant_stand(rng, pal) -> Piece:
    """Thin obstacle: a 5-6 cm stand whose pot sits above the robot's height."""
    p, h, r = Piece("plant_stand"), rng.uniform(1.05, 1.3), rng.uniform(0.025, 0.03)
    p.cyl("wood", 0, 0.25, r, 0, h, pal.wood(rng))
    p.cyl("painted", 0, 0.25, 0.13, h, h + 0.2, pal.pot)
    p.cyl("plant", 0, 0.25, 0.2, h + 0.2, h + 0.5, (255, 255, 255))
    return p


def floor_plant(rng, pal) -> Piece:
    p, r = Piece("floor_plant"), rng.uniform(0.16, 0.22)
    cz = 1.4 * r + 0.08
    p.cyl("painted", 0, cz, r, 0, rng.uniform(0.3, 0.45), pal.pot)
    for i in range(3):
        rr = r * rng.uniform(1.0, 1.4)
        p.cyl("plant", rng.uniform(-0.05, 0.05), cz + rng.uniform(-0.05, 0.05), rr,
              0.35 + 0.3 * i, 0.75 + 0.3 * i + rng.uniform(0, 0.2), (255, 255, 255))
    return p


def pillar(rng, pal) -> Piece:
    """Floor-to-ceiling column, 12-28 cm wide."""
    s = rng.uniform(0.12, 0.28)
    p = Piece("pillar")
    if rng.random() < 0.5:
        p.box("painted", -s / 2, 0, 0, s / 2, pal.height, s, pal.column)
    else:
        p.cyl("painted", 0, s / 2, s / 2, 0, pal.height, pal.column)
    return p


def coat_rack(rng, pal) -> Piece:
    p, col = Piece("coat_rack"), pal.wood(rng)
    p.cyl("wood", 0, 0.25, 0.025, 0, 1.75, col)
    p.box("wood", -0.22, 0, 0.23, 0.22, 0.03, 0.27, col)
    p.box("wood", -0.02, 0, 0.03, 0.02, 0.03, 0.47, col)
    p.box("fabric", -0.18, 1.2, 0.15, 0.18, 1.65, 0.35, pal.fabric(rng))
    return p


def stool(rng, pal) -> Piece:
    p, h = Piece("stool"), rng.uniform(0.45, 0.7)
    p.cyl("wood", 0, 0.18, 0.17, h - 0.04, h, pal.wood(rng))
    p.cyl("painted", 0, 0.18, 0.03, 0, h - 0.04, pal.metal)
    p.cyl("painted", 0, 0.18, 0.14, 0, 0.02, pal.metal)
    return p


def tv_stand(rng, pal) -> Piece:
    w = rng.uniform(1.2, 1.8)
    p = cabinet(rng, pal, "tv_stand", w=w, d=0.42, h=0.48)
    tw = min(w - 0.1, rng.uniform(0.9, 1.3))
    p.box("painted", -tw / 2, 0.55, 0.12, tw / 2, 0.55 + tw * 0.58, 0.17, (18, 18, 20))
    p.box("painted", -0.12, 0.48, 0.08, 0.12, 0.55, 0.25, (30, 30, 30))
    return p

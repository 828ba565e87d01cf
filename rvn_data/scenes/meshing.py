"""Vectorised primitive meshes for procedural scenes: boxes, vertical cylinders, floor quads.

Every primitive is emitted with its own vertices (flat faces), counter-clockwise winding
seen from outside, metre-based UVs (world coordinates divided by the texture's tile
size, planar per face) and one RGB colour per primitive.
"""
from __future__ import annotations

import numpy as np


def _box_template():
    """Unit-cube corners [24, 3], faces [12, 3] (CCW from outside) and uv axes per vertex."""
    corners, faces, uvax = [], [], []
    for axis in range(3):
        u, v = [(2, 1), (0, 2), (0, 1)][axis]
        for sign in (0, 1):
            quad = []
            for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                c = [0, 0, 0]
                c[axis], c[u], c[v] = sign, a, b
                quad.append(c)
            q = np.array(quad, np.float64)
            n = np.cross(q[1] - q[0], q[2] - q[0])
            if (n[axis] > 0) != (sign == 1):
                q = q[::-1]
            base = len(corners)
            corners.extend(q.tolist())
            faces += [[base, base + 1, base + 2], [base, base + 2, base + 3]]
            uvax += [(u, v)] * 4
    return np.array(corners), np.array(faces, np.int64), np.array(uvax, np.int64)


_CORNERS, _FACES, _UVAX = _box_template()


def boxes(b: np.ndarray, rgb: np.ndarray, tile: float):
    """Boxes [n, 6] (x0, y0, z0, x1, y1, z1) → (vertices, faces, uv, rgb per vertex)."""
    b = np.asarray(b, np.float64).reshape(-1, 6)
    n = len(b)
    lo, size = b[:, None, :3], (b[:, 3:] - b[:, :3])[:, None, :]
    verts = (lo + _CORNERS[None] * size).reshape(-1, 3)
    faces = (_FACES[None] + 24 * np.arange(n)[:, None, None]).reshape(-1, 3)
    idx = np.arange(n * 24)
    ax = np.tile(_UVAX, (n, 1))
    uv = np.stack([verts[idx, ax[:, 0]], verts[idx, ax[:, 1]]], axis=1) / tile
    return verts, faces, uv, np.repeat(np.asarray(rgb).reshape(-1, 3), 24, axis=0)


def cylinders(c: np.ndarray, rgb: np.ndarray, tile: float, segments: int = 10):
    """Vertical cylinders [n, 5] (cx, cz, r, y0, y1) → (vertices, faces, uv, rgb per vertex).

    Side: 2 rings of `segments` vertices; caps: a centre and a ring each (4·segments triangles).
    """
    c = np.asarray(c, np.float64).reshape(-1, 5)
    n, s = len(c), segments
    ang = np.arange(s) * (2 * np.pi / s)
    ca, sa = np.cos(ang), np.sin(ang)
    cx, cz, r, y0, y1 = (c[:, i:i + 1] for i in range(5))
    rx, rz = cx + r * ca, cz + r * sa  # [n, s]
    ring = lambda y: np.stack([rx, np.broadcast_to(y, rx.shape), rz], -1)  # noqa: E731
    centre = lambda y: np.concatenate([cx, y, cz], 1)[:, None, :]  # noqa: E731
    # per cylinder: side bottom ring, side top ring, bottom centre + ring, top centre + ring
    verts = np.concatenate([ring(y0), ring(y1), centre(y0), ring(y0), centre(y1), ring(y1)], 1)
    nv = 4 * s + 2
    i = np.arange(s)
    j = (i + 1) % s
    b0, t0, bc, br, tc, tr = 0, s, 2 * s, 2 * s + 1, 3 * s + 1, 3 * s + 2
    # side: seen from outside (+radial), angle increases from +x towards +z
    side = np.concatenate([np.stack([b0 + i, t0 + j, b0 + j], 1), np.stack([b0 + i, t0 + i, t0 + j], 1)])
    bottom = np.stack([np.full(s, bc), br + i, br + j], 1)
    top = np.stack([np.full(s, tc), tr + j, tr + i], 1)
    tmpl = np.concatenate([side, bottom, top])
    faces = (tmpl[None] + nv * np.arange(n)[:, None, None]).reshape(-1, 3)
    arc = np.concatenate([np.tile(ang, 2)[None] * r, verts[:, 2 * s:, 0]], 1)
    vv = np.concatenate([verts[:, :2 * s, 1], verts[:, 2 * s:, 2]], 1)
    uv = np.stack([arc.reshape(-1), vv.reshape(-1)], 1) / tile
    return verts.reshape(-1, 3), faces, uv, np.repeat(np.asarray(rgb).reshape(-1, 3), nv, axis=0)


def hquads(rects: np.ndarray, y: float, up: bool, rgb: np.ndarray, tile: float):
    """Horizontal quads [n, 4] (x0, z0, x1, z1) at height y facing up (floors) or down (ceilings)."""
    r = np.asarray(rects, np.float64).reshape(-1, 4)
    n = len(r)
    xs = r[:, [0, 0, 2, 2]]
    zs = r[:, [1, 3, 3, 1]]
    verts = np.stack([xs, np.full_like(xs, y), zs], -1).reshape(-1, 3)
    quad = np.array([[0, 1, 2], [0, 2, 3]]) if up else np.array([[0, 2, 1], [0, 3, 2]])
    faces = (quad[None] + 4 * np.arange(n)[:, None, None]).reshape(-1, 3)
    uv = verts[:, [0, 2]] / tile
    return verts, faces, uv, np.repeat(np.asarray(rgb).reshape(-1, 3), 4, axis=0)

"""Spatial chunks of triangles and frustum culling, for the GL back-end.

Each part's faces are reordered so that the triangles of one cubic cell (by centroid)
are contiguous; a chunk is (part, first vertex, vertex count, bounding sphere) in the
part's unindexed vertex buffer (three vertices per face). Per
frame, chunks outside the view frustum are skipped and adjacent visible chunks of a
part are drawn with one call; the culling is one numba pass over the chunks (2-4 µs a view
for 60-130 chunks, where numpy's many small operations took 30-40 µs).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

CHUNK_SIZE = 2.0  # m, edge of the cubic cells
MIN_CHUNK_FACES = 2048  # parts with fewer faces stay one chunk


@dataclass
class Chunks:
    """All chunks of a scene; arrays are [K], ordered by part then position in the part."""

    part: np.ndarray  # int32 part index
    first: np.ndarray  # int64 first vertex (3 per face) in the part's vertex buffer
    count: np.ndarray  # int64 number of vertices
    centre: np.ndarray  # float64 [K, 3]
    radius: np.ndarray  # float64 [K]


def order_faces(vertices: np.ndarray, faces: np.ndarray, cell: float = CHUNK_SIZE):
    """(faces reordered by cell, [(first_face, n_faces, centre, radius), ...])."""
    tri = vertices[faces].astype(np.float64)  # [M, 3, 3]
    if len(faces) < MIN_CHUNK_FACES:
        groups = [np.arange(len(faces))]
    else:
        key = np.floor(tri.mean(axis=1) / cell).astype(np.int64)
        order = np.lexsort((key[:, 2], key[:, 1], key[:, 0]))
        key = key[order]
        starts = np.flatnonzero(np.r_[True, np.any(key[1:] != key[:-1], axis=1)])
        groups = np.split(order, starts[1:])
    out_faces, spans, first = [], [], 0
    for g in groups:
        pts = tri[g].reshape(-1, 3)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        centre = 0.5 * (lo + hi)
        spans.append((first, len(g), centre, 0.5 * float(np.linalg.norm(hi - lo))))
        out_faces.append(faces[g])
        first += len(g)
    return np.ascontiguousarray(np.concatenate(out_faces), dtype=np.int32), spans


def build_chunks(per_part_spans: list[list]) -> Chunks:
    """Collect `order_faces` spans of every part into one `Chunks`."""
    part, first, count, centre, radius = [], [], [], [], []
    for i, spans in enumerate(per_part_spans):
        for f0, n, c, r in spans:
            part.append(i)
            first.append(3 * f0)
            count.append(3 * n)
            centre.append(c)
            radius.append(r)
    return Chunks(np.asarray(part, np.int32), np.asarray(first, np.int64), np.asarray(count, np.int64),
                  np.asarray(centre, np.float64).reshape(-1, 3), np.asarray(radius, np.float64))


@njit(cache=True)
def _runs(mvp, centre, radius, part, first, count):
    """[R, 3] int64 (part, first vertex, vertex count) per run of adjacent chunks inside the frustum of
    ``mvp``. The frustum's planes are the rows m3 + m0, m3 - m0, m3 + m1, ... of ``mvp`` (Gribb-Hartmann),
    normalised; a chunk is inside when its sphere reaches the inner side of all six."""
    planes = np.empty((6, 4))
    for k in range(6):
        sign = 1.0 if k % 2 == 0 else -1.0
        for j in range(4):
            planes[k, j] = mvp[3, j] + sign * mvp[k // 2, j]
        norm = math.sqrt(planes[k, 0] * planes[k, 0] + planes[k, 1] * planes[k, 1] + planes[k, 2] * planes[k, 2])
        for j in range(4):
            planes[k, j] /= norm
    out = np.empty((len(part), 3), np.int64)
    n, last = 0, -2  # runs so far; chunk that ended the last run
    for i in range(len(part)):
        x, y, z, r = centre[i, 0], centre[i, 1], centre[i, 2], -radius[i]
        inside = True
        for k in range(6):
            if not x * planes[k, 0] + y * planes[k, 1] + z * planes[k, 2] + planes[k, 3] >= r:
                inside = False
                break
        if not inside:
            continue
        if last == i - 1 and part[i] == part[last]:  # the next chunk of the same part: the run goes on
            out[n - 1, 2] = first[i] + count[i] - out[n - 1, 1]
        else:
            out[n, 0], out[n, 1], out[n, 2] = part[i], first[i], count[i]
            n += 1
        last = i
    return out[:n]


def visible_runs(chunks: Chunks, mvp: np.ndarray) -> list[list[int]]:
    """[part, first vertex, vertex count] per run of adjacent chunks inside the frustum."""
    return _runs(np.ascontiguousarray(mvp, dtype=np.float64), chunks.centre, chunks.radius, chunks.part,
                 chunks.first, chunks.count).tolist()

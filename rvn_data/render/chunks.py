"""Spatial chunks of triangles and frustum culling, for the GL back-end.

Each part's faces are reordered so that the triangles of one cubic cell (by centroid)
are contiguous; a chunk is (part, first vertex, vertex count, bounding sphere) in the
part's unindexed vertex buffer (three vertices per face). Per
frame, chunks outside the view frustum are skipped and adjacent visible chunks of a
part are drawn with one call.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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


def frustum_planes(mvp: np.ndarray) -> np.ndarray:
    """[6, 4] normalised planes (n, d), inside where n.x + d >= 0 (Gribb-Hartmann)."""
    m = np.asarray(mvp, dtype=np.float64)
    planes = np.stack([m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1], m[3] + m[2], m[3] - m[2]])
    return planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)


def visible_runs(chunks: Chunks, mvp: np.ndarray) -> list[tuple[int, int, int]]:
    """(part, first vertex, vertex count) per run of adjacent chunks inside the frustum."""
    planes = frustum_planes(mvp)
    dist = chunks.centre @ planes[:, :3].T + planes[:, 3]  # [K, 6]
    vis = np.all(dist >= -chunks.radius[:, None], axis=1)
    idx = np.flatnonzero(vis)
    if len(idx) == 0:
        return []
    # a run continues while the next visible chunk is the next chunk of the same part
    brk = np.flatnonzero((np.diff(idx) != 1) | (np.diff(chunks.part[idx]) != 0)) + 1
    starts = np.r_[0, brk]
    ends = np.r_[brk, len(idx)] - 1
    a, b = idx[starts], idx[ends]
    firsts = chunks.first[a]
    counts = chunks.first[b] + chunks.count[b] - firsts
    return list(zip(chunks.part[a].tolist(), firsts.tolist(), counts.tolist()))

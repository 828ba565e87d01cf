"""Detour polygons from RVN's navigable cells, for writing `.navmesh` files.

Each row of a layer is cut into runs of navigable cells (same tile, joined neighbours,
floor heights within `cell_height` of the run's first cell); a run is a rectangle. Detour
links polygons inside a tile only through edges whose two ends are shared vertices, so a
run's top and bottom sides are split where the polygon across them changes (and the
neighbour's side is split at the same points): every edge then faces exactly one polygon,
or none (a wall or drop). Detour allows 6 vertices per polygon, so a run needing more is
cut in two, and the splitting repeats until no run needs cutting. Long runs keep the
polygon count low: Habitat's path queries search at most 2048 polygons.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_VERTS = 6
# edge directions of a cell: (drow, dcol); 0 left (x-), 1 top (z+), 2 right (x+), 3 bottom (z-)
DIRS = ((0, -1), (1, 0), (0, 1), (-1, 0))
SIDES = (4, 2, 0, 6)  # Detour's portal side of each direction


@dataclass
class Poly:
    """A polygon: its layer, tile (tx, ty), vertex keys (layer, row, col) in Detour's winding
    and, per edge (vertex j to j+1), the neighbour polygon (-1: none) and its direction."""

    layer: int
    tile: tuple[int, int]
    verts: list[tuple[int, int, int]]
    nbrs: list[int]
    dirs: list[int]


def cell_table(nm):
    """Navigable cells of all layers: (layer, scene row, scene col) int [N, 3], heights [N],
    and the neighbour cell in each direction [N, 4] (-1: none): same layer within
    `max_climb`, or across a seam link."""
    rows, hs = [], []
    for k, g in enumerate(nm.layers):
        rr, cc = np.nonzero(g.island >= 0)
        rows.append(np.stack([np.full(len(rr), k), rr + g.r0, cc + g.c0], 1))
        hs.append(g.height[rr, cc].astype(np.float64))
    cells = np.concatenate(rows) if rows else np.zeros((0, 3), np.int64)
    height = np.concatenate(hs) if hs else np.zeros(0)
    index = {tuple(c): n for n, c in enumerate(cells.tolist())}
    nbr = np.full((len(cells), 4), -1, np.int64)
    climb = nm.settings.max_climb + 1e-6
    for n, (k, r, c) in enumerate(cells.tolist()):
        for e, (dr, dc) in enumerate(DIRS):
            m = index.get((k, r + dr, c + dc))
            if m is not None and abs(height[m] - height[n]) <= climb:
                nbr[n, e] = m
    for la, ra, ca, lb, rb, cb in nm.links.tolist():  # seams between layers
        a = index.get((la, nm.layers[la].r0 + ra, nm.layers[la].c0 + ca))
        b = index.get((lb, nm.layers[lb].r0 + rb, nm.layers[lb].c0 + cb))
        if a is not None and b is not None:
            d = (cells[b, 1] - cells[a, 1], cells[b, 2] - cells[a, 2])
            if d in DIRS:
                e = DIRS.index(d)
                nbr[a, e], nbr[b, (e + 2) % 4] = b, a
    return cells, height, nbr, index


def _segments(run, index, nbr, run_of, side):
    """[(first col, end col, neighbour run)] along the top (side 1) or bottom (3) of a run."""
    k, r, c0, c1 = run
    segs = []
    for c in range(c0, c1):
        m = nbr[index[(k, r, c)], side]
        q = int(run_of[m]) if m >= 0 else -1
        if segs and segs[-1][2] == q:
            segs[-1][1] = c + 1
        else:
            segs.append([c, c + 1, q])
    return segs


def polygons(nm, tile_cells: int, height_tol: float) -> list[Poly]:
    cells, height, nbr, index = cell_table(nm)
    runs, run_of = [], np.full(len(cells), -1, np.int64)
    for n, (k, r, c) in enumerate(cells.tolist()):  # cells come sorted by layer, row, col
        if runs:
            pk, pr, p0, p1 = runs[-1]
            first = index[(pk, pr, p0)]
            if (pk, pr, p1) == (k, r, c) and c % tile_cells and nbr[n - 1, 2] == n \
                    and abs(height[n] - height[first]) <= height_tol:
                runs[-1][3] = c + 1
                run_of[n] = len(runs) - 1
                continue
        runs.append([k, r, c, c + 1])
        run_of[n] = len(runs) - 1
    while True:  # cut runs needing more than MAX_VERTS vertices, until none does
        new, cut = [], False
        for run in runs:
            tops = [s[0] for s in _segments(run, index, nbr, run_of, 1)[1:]]
            bots = [s[0] for s in _segments(run, index, nbr, run_of, 3)[1:]]
            breaks = sorted(set(tops) | set(bots))
            start = run[2]
            for b in breaks:
                if 4 + sum(start < x <= b for x in tops) + sum(start < x <= b for x in bots) > MAX_VERTS:
                    new.append([run[0], run[1], start, b])  # the vertices at b close this piece
                    start, cut = b, True
            new.append([run[0], run[1], start, run[3]])
        if not cut:
            break
        runs = new
        for i, (k, r, c0, c1) in enumerate(runs):
            run_of[[index[(k, r, c)] for c in range(c0, c1)]] = i
    out = []
    for run in runs:
        k, r, c0, c1 = run
        left = nbr[index[(k, r, c0)], 0]
        right = nbr[index[(k, r, c1 - 1)], 2]
        top = _segments(run, index, nbr, run_of, 1)
        bottom = _segments(run, index, nbr, run_of, 3)[::-1]
        verts = [(k, r, c0)] + [(k, r + 1, s[0]) for s in top] + [(k, r + 1, c1), (k, r, c1)] + \
                [(k, r, s[0]) for s in bottom[:-1]]
        nbrs = [int(run_of[left]) if left >= 0 else -1] + [s[2] for s in top] + \
               [int(run_of[right]) if right >= 0 else -1] + [s[2] for s in bottom]
        dirs = [0] + [1] * len(top) + [2] + [3] * len(bottom)
        out.append(Poly(k, (c0 // tile_cells, r // tile_cells), verts, nbrs, dirs))
    return out

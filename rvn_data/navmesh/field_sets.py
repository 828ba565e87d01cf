"""Many geodesic fields of one scene at once: a goal pool's (`rvn_data.benchmark.goal_pool`).

- `FieldTrees(navmesh, goals)`: the fields of ``navmesh.distance_field(goal, keep=False)`` for every goal, their
  Dijkstra solves in one call, their trees stacked row by row, and smoothed whole (`smooth_trees`: every node the tree
  reaches), so that reads smooth nothing; pickled with their values but without the rest of the smoothing state (a
  helper process that builds or reads back a pool sends the predecessors and values: `rvn_data.helper_process`);
- `fields_distance(navmesh, trees, p)`: every field's distance at points in one call, so that a goal draw (every pool
  field's distance at a start) costs one kernel call instead of one lookup per field (benchmarks/goal_pool.py). The
  same values as field by field, bit for bit (tests/test_env.py).

Why whole: a field smoothed where it is read (as a single field is, `rvn_data.navmesh.geodesic.FieldTree`) gets the
same values, but a read at a new start smooths that start's tree chain in every field: 5.5-9 ms a goal draw on
average and up to ~35 ms in an RL env's first draws in a scene (2-core development CPU, 64 goals), in the middle of a
batched step that every other env then waits for. A pool is built once per cache root and read back after
(`rvn_data.benchmark.pool_cache`), so its smoothing is paid there once too (1.2-1.6 s for 64 goals on a 13.7k-node
procedural apartment, up to ~4 s at 25k nodes), and a draw is a lookup (0.08-0.14 ms, benchmarks/goal_pool.py).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rvn_data.navmesh import kernels as K
from rvn_data.navmesh.geodesic import FieldTree, _fill_chain, run_dijkstra
from rvn_data.navmesh.navmesh import MAX_Y_DELTA


class FieldTrees:
    """The geodesic fields of several goals of one scene (a goal pool's), their trees stacked row by row and read
    together by `fields_distance`; ``trees`` holds each field's `FieldTree`, working on its rows (with ``smooth=False``
    a lookup through either smooths the same state), and ``values`` each field's values in ``dtype`` (float32: a
    pool's).

    Each field is ``navmesh.distance_field(goal, keep=False)``'s (snapped goal, same tree, same values; for a goal with
    no graph node near it a tree that reaches nothing: inf everywhere), their Dijkstra solves in one call (scipy's),
    then every tree smoothed whole (``smooth``, the default) or left to be smoothed where lookups read it."""

    def __init__(self, navmesh, goals, dtype=np.float32, smooth: bool = True):
        graph, _, centres, cells = navmesh._ensure_graph()
        nodes, points = zip(*(navmesh._field_goal(goal) for goal in goals))
        self.goals, self.roots = np.stack(points), np.array(nodes, np.int64)
        solved = np.flatnonzero(self.roots >= 0)
        self.pred = np.full((len(points), graph.shape[0]), -1, np.int32)
        if solved.size:
            self.pred[solved] = run_dijkstra(graph, self.roots[solved], predecessors=True)[1]
        grids = [navmesh._goal_grid(node, p) if node >= 0 else (0, 0.0, 0.0) for node, p in zip(nodes, points)]
        self.gk = np.array([g[0] for g in grids], np.int64)
        self.gi, self.gj = (np.array([g[a] for g in grids], np.float64) for a in (1, 2))
        self._stack_trees(dtype)
        self.smoothed = bool(smooth)  # False: lookups smooth where they read (benchmarks/goal_pool.py's baseline)
        if smooth:
            P = navmesh.packed
            smooth_trees(self.pred, self.roots, cells, centres, P.meta, P.clearance, P.island, self.goals, self.gk,
                         self.gi, self.gj, navmesh.settings.agent_radius - 1e-6, self.out, self.parent, self.values)

    def _stack_trees(self, dtype) -> None:
        """The smoothing state, none done yet (inf / -1), and each field's `FieldTree` on its rows."""
        shape = self.pred.shape
        self.out, self.parent = np.full(shape, np.inf), np.full(shape, -1, np.int32)
        self.values = np.full(shape, np.inf, dtype)
        self.trees = [FieldTree(pred, root, goal, (k, i, j), out, parent) for pred, root, goal, k, i, j, out, parent in
                      zip(self.pred, self.roots, self.goals, self.gk, self.gi, self.gj, self.out, self.parent)]

    def __getstate__(self) -> dict:
        """The trees and, smoothed whole, their values (the predecessors' bytes again for float32), without the
        rest of the smoothing state (``out``, ``parent``: 3x the predecessors'); smoothed where read, without values
        either: lookups fill them again, the same."""
        drop = ("out", "parent", "trees") + (() if self.smoothed else ("values",))
        state = {k: v for k, v in self.__dict__.items() if k not in drop}
        return {**state, "dtype": self.values.dtype.str}

    def __setstate__(self, state: dict) -> None:
        dtype, values = np.dtype(state.pop("dtype")), state.pop("values", None)
        self.__dict__.update(state)
        self._stack_trees(dtype)
        if values is not None:  # smoothed whole: a node is done where its value is finite, and no read smooths again
            self.values[...] = values
            self.out[...] = np.where(np.isfinite(values), values, np.inf)  # done-markers; nothing reads them as sums

    @property
    def nbytes(self) -> int:
        return self.pred.nbytes + self.out.nbytes + self.parent.nbytes + self.values.nbytes


def fields_distance(navmesh, trees: FieldTrees, p: np.ndarray) -> np.ndarray:
    """Distances [G, N] at points [N, 3] (or [G] at a point [3]) of the G fields stacked in ``trees``: each field's
    `GeodesicField.distance`, in one call."""
    _, node_of, centres, cells = navmesh._ensure_graph()
    P, t = navmesh.packed, trees
    pts = np.ascontiguousarray(np.asarray(p, dtype=np.float64).reshape(-1, 3))
    out = trees_lookup(P.meta, P.height, P.x0, P.z0, P.cs, node_of, pts, MAX_Y_DELTA, t.pred, t.roots, cells, centres,
                       P.clearance, P.island, t.goals, t.gk, t.gi, t.gj, navmesh.settings.agent_radius - 1e-6, t.out,
                       t.parent, t.values)
    out = navmesh._straight_near_goal(out, pts, t.goals)
    return out[:, 0] if np.ndim(p) == 1 else out


@njit(cache=True)
def smooth_trees(preds, roots, cells, centres, meta, clearance, island, goals, gks, gis, gjs, r, outs, parents, values):
    """Every stacked tree (row g) smoothed at every node it reaches (`geodesic._fill_chain`): the values lookups would
    give, read in any order."""
    chain = np.empty(256, np.int64)
    for g in range(preds.shape[0]):
        pred, root = preds[g], roots[g]
        for w in range(pred.shape[0]):
            if outs[g, w] == np.inf and (pred[w] >= 0 or w == root):
                chain = _fill_chain(w, chain, pred, root, cells, centres, meta, clearance, island, goals[g], gks[g],
                                    gis[g], gjs[g], r, outs[g], parents[g], values[g])


@njit(cache=True)
def trees_lookup(meta, height, x0, z0, cs, node_of, pts, tol, preds, roots, cells, centres, clearance, island, goals,
                 gks, gis, gjs, r, outs, parents, values):
    """`geodesic.tree_lookup` of each stacked tree (row g of ``preds``, ``outs``, ``parents``, ``values``) at the same
    points [N, 3] → [G, N], the nodes read found once."""
    wanted = K.field_support(meta, height, x0, z0, cs, node_of, pts, tol)
    res = np.empty((preds.shape[0], pts.shape[0]))
    chain = np.empty(256, np.int64)
    for g in range(preds.shape[0]):
        for w in wanted.ravel():
            if w >= 0 and outs[g, w] == np.inf:
                chain = _fill_chain(w, chain, preds[g], roots[g], cells, centres, meta, clearance, island, goals[g],
                                    gks[g], gis[g], gjs[g], r, outs[g], parents[g], values[g])
        res[g] = K.field_lookup(meta, height, x0, z0, cs, node_of, values[g], pts, tol)
    return res

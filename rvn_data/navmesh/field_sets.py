"""Many geodesic fields of one scene at once: a goal pool's (`rvn_data.benchmark.goal_pool`).

- `FieldTrees(navmesh, goals)`: the fields of ``navmesh.distance_field(goal, keep=False)`` for every goal, their
  Dijkstra solves in one call, their trees stacked row by row; pickled without their smoothing state (which lookups
  fill again where they read), so that a helper process that builds a pool sends a few MB
  (`rvn_data.helper_process`);
- `fields_distance(navmesh, trees, p)`: every field's distance at points in one call, so that a goal draw (every pool
  field's distance at a start) costs one kernel call instead of one lookup per field (benchmarks/goal_pool.py). The
  same values as field by field, bit for bit (tests/test_env.py).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rvn_data.navmesh import kernels as K
from rvn_data.navmesh.geodesic import FieldTree, _fill_chain, run_dijkstra
from rvn_data.navmesh.navmesh import MAX_Y_DELTA


class FieldTrees:
    """The geodesic fields of several goals of one scene (a goal pool's), their trees stacked row by row and read
    together by `fields_distance`; ``trees`` holds each field's `FieldTree`, working on its rows (a lookup through
    either smooths the same state), and ``values`` each field's values in ``dtype`` (float32: a pool's).

    Each field is ``navmesh.distance_field(goal, keep=False)``'s (snapped goal, same tree; for a goal with no graph
    node near it a tree that reaches nothing: inf everywhere), their Dijkstra solves in one call (scipy's). The
    arrays are made whole, a few numpy calls in all."""

    def __init__(self, navmesh, goals, dtype=np.float32):
        graph = navmesh._ensure_graph()[0]
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

    def _stack_trees(self, dtype) -> None:
        """The smoothing state, none done yet (inf / -1), and each field's `FieldTree` on its rows."""
        shape = self.pred.shape
        self.out, self.parent = np.full(shape, np.inf), np.full(shape, -1, np.int32)
        self.values = np.full(shape, np.inf, dtype)
        self.trees = [FieldTree(pred, root, goal, (k, i, j), out, parent) for pred, root, goal, k, i, j, out, parent in
                      zip(self.pred, self.roots, self.goals, self.gk, self.gi, self.gj, self.out, self.parent)]

    def __getstate__(self) -> dict:
        """The trees without their smoothing state (3x the predecessors' bytes): lookups fill it again, the same."""
        state = {k: v for k, v in self.__dict__.items() if k not in ("out", "parent", "values", "trees")}
        return {**state, "dtype": self.values.dtype.str}

    def __setstate__(self, state: dict) -> None:
        dtype = np.dtype(state.pop("dtype"))
        self.__dict__.update(state)
        self._stack_trees(dtype)

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

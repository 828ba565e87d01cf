"""`NavMesh`: the navigable surface of a scene and its queries (ARCHITECTURE.md).

All points are world [3] arrays (or [N, 3] where noted), metres, y up. Layers and their
arrays are in `NavMesh.layers` (`NavGrid`); `NavMesh.grid(island)` is the layer holding
most of an island, the grid planners and top-down maps use.
"""
from __future__ import annotations

import math
from functools import cached_property

import numpy as np
from numba import njit
from scipy import ndimage

from rvn_data.navmesh import kernels as K
from rvn_data.navmesh.build import build_layers
from rvn_data.navmesh.geodesic import FieldTree, GeodesicField, build_graph, node_cells, node_centres, run_dijkstra
from rvn_data.navmesh.grid import NavGrid, pack
from rvn_data.navmesh.islands import IslandShapes, island_shapes, sample_point, wide_islands
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.scenes.scene import Scene

MAX_Y_DELTA = 0.5  # m, a point is on a floor within this height (Habitat's is_navigable)
SNAP_EXTENT = 2.0  # m, horizontal search radius of snap (Habitat: (2, 4, 2) box)


@njit(cache=True)
def _islands(meta, height, clearance, island, x0, z0, cs, pts, tol, r):
    out = np.empty(pts.shape[0], np.int64)
    hs = np.empty(pts.shape[0])
    for n in range(pts.shape[0]):
        isl, k, h = K.nav_point(meta, height, clearance, island, x0, z0, cs,
                                pts[n, 0], pts[n, 1], pts[n, 2], tol, r)
        out[n] = isl
        hs[n] = h if k >= 0 else np.nan
    return out, hs


class NavMesh:
    """Navigable surface of a scene; build with `NavMesh.build(scene, settings)`."""

    source_file: str | None = None  # the .navmesh it was read from (None: built from the scene)

    def __init__(self, scene_id: str, settings: NavMeshSettings, layers: list[NavGrid],
                 island_areas: list[float], scene_grid: tuple, links: np.ndarray):
        self.scene_id = scene_id
        self.settings = settings
        self.layers = layers
        self.island_areas = island_areas
        self.x0, self.z0, rows, cols = scene_grid
        self.scene_grid_shape = (int(rows), int(cols))
        self.links = links
        self.packed = pack(layers, self.x0, self.z0, settings.cell_size)
        self.offsets = self.packed.meta[:, 4].copy()
        self._graph = None
        self._fields: dict[int, tuple] = {}
        self._island_cells: dict[tuple, np.ndarray] = {}  # `islands.sample_point`'s cells of a set of islands
        self._nearest: dict[int, tuple] = {}

    @classmethod
    def build(cls, scene: Scene, settings: NavMeshSettings | None = None) -> "NavMesh":
        """Build from a scene; raises SceneError (naming the scene) when nothing is walkable."""
        settings = settings or NavMeshSettings()
        layers, areas, grid, links = build_layers(scene, settings)
        return cls(scene.scene_id, settings, layers, areas, grid, links)

    # ----------------------------------------------------------------- point queries
    @property
    def navigable_area(self) -> float:
        """Area of the main island (m²)."""
        return self.island_areas[0]

    @property
    def num_islands(self) -> int:
        return len(self.island_areas)

    def _query(self, p: np.ndarray, tol: float = MAX_Y_DELTA):
        P = self.packed
        pts = np.ascontiguousarray(np.asarray(p, dtype=np.float64).reshape(-1, 3))
        return _islands(P.meta, P.height, P.clearance, P.island, P.x0, P.z0, P.cs, pts, tol,
                        self.settings.agent_radius)

    def island_of(self, p: np.ndarray) -> int | np.ndarray:
        """Island id of a point (-1 if not navigable); [N, 3] → int [N]."""
        isl, _ = self._query(p)
        return int(isl[0]) if np.ndim(p) == 1 else isl

    def is_navigable(self, p: np.ndarray) -> bool | np.ndarray:
        """True where the robot centre may be: over a floor within 0.5 m of p's y, on a kept
        island, at least agent_radius from obstacles; [N, 3] → bool [N]."""
        isl, _ = self._query(p)
        return bool(isl[0] >= 0) if np.ndim(p) == 1 else isl >= 0

    def floor_height(self, p: np.ndarray) -> float | np.ndarray:
        """Height of the floor under p (the layer nearest p's y within 0.5 m), NaN if none."""
        _, h = self._query(p)
        return float(h[0]) if np.ndim(p) == 1 else h

    def _nearest_nav(self, k: int):
        if k not in self._nearest:
            nav = self.layers[k].island >= 0
            d, (ii, jj) = ndimage.distance_transform_edt(~nav, return_indices=True)
            self._nearest[k] = (ii, jj)
        return self._nearest[k]

    def snap(self, p: np.ndarray, island: int = -1) -> np.ndarray:
        """Nearest navigable point [3] (on `island` if >= 0) within 2 m horizontally and 4 m
        vertically; NaNs if none."""
        p = np.asarray(p, dtype=np.float64).reshape(3)
        isl = self.island_of(p)
        if isl >= 0 and (island < 0 or isl == island):
            return np.array([p[0], self.floor_height(p), p[2]])
        best, bestd = None, math.inf
        for k, g in enumerate(self.layers):
            if island >= 0 and not (g.island == island).any():
                continue
            rc = np.clip(g.world_to_grid(p), 0, np.array(g.shape) - 1)
            if island >= 0:
                rr, cc = np.nonzero(g.island == island)
                j = np.argmin((rr - rc[0]) ** 2 + (cc - rc[1]) ** 2)
                nrc = np.array([rr[j], cc[j]])
            else:
                ii, jj = self._nearest_nav(k)
                nrc = np.array([ii[rc[0], rc[1]], jj[rc[0], rc[1]]])
            c = g.grid_to_world(nrc)
            horiz, dy = math.hypot(c[0] - p[0], c[2] - p[2]), abs(c[1] - p[1])
            if horiz <= SNAP_EXTENT + g.cs and dy <= 4.0 and math.hypot(horiz, dy) < bestd:  # 3-D, as Detour's
                best, bestd = c, math.hypot(horiz, dy)  # findNearestPoly: not the floor above, horizontally nearer
        if best is None:
            return np.full(3, np.nan)
        d = np.array([p[0] - best[0], p[2] - best[2]])
        length = float(np.hypot(*d))
        if length > 1e-9:
            t, y = self._march(best, d / length, length)
            return np.array([best[0] + d[0] / length * t, y, best[2] + d[1] / length * t])
        return best

    @cached_property
    def island_shapes(self) -> IslandShapes:
        """Each island's radius (Habitat's rule's measure) and floor height (`rvn_data.navmesh.islands`)."""
        return island_shapes(self)

    @cached_property
    def sampled_islands(self) -> list[int]:
        """The islands starts and goals are drawn on (`NavMeshSettings.islands`): [0], the main island, or with
        islands=all also every other island whose radius is at least ``min_island_radius`` (`islands.wide_islands`)."""
        st = self.settings
        return [0] if st.islands == "main" else [0, *wide_islands(self, st.min_island_radius)]

    def goal_island(self, p: np.ndarray) -> int:
        """The island goals from ``p`` are drawn on: the main island (0) where it is the only one sampled, else
        p's own (0 where p is on none, as a cell-centre fallback of `sample` may be)."""
        if self.sampled_islands == [0]:
            return 0
        return max(int(self.island_of(np.asarray(p, dtype=np.float64).reshape(3))), 0)

    def sample(self, rng: np.random.Generator, island: int | None = None) -> np.ndarray:
        """A point uniformly distributed over the navigable cells of ``island``, or by default of the
        `sampled_islands` together (so an island's share of the points is its share of their area)."""
        return sample_point(self, rng, self.sampled_islands if island is None else [island])

    def grid(self, island: int = 0) -> NavGrid:
        """The layer holding most cells of `island` (for single-floor planners and maps)."""
        counts = [int((g.island == island).sum()) for g in self.layers]
        return self.layers[int(np.argmax(counts))]

    def topdown(self) -> tuple[np.ndarray, np.ndarray]:
        """Scene-wide (island id int32 [rows, cols], -1 elsewhere; walkable surface bool) with
        the cell layout of the layers (x0, z0, cell_size); upper layers drawn last."""
        isl = np.full(self.scene_grid_shape, -1, np.int32)
        free = np.zeros(self.scene_grid_shape, bool)
        order = np.argsort([np.nanmean(g.height) for g in self.layers])
        for k in order:
            g = self.layers[k]
            view = (slice(g.r0, g.r0 + g.shape[0]), slice(g.c0, g.c0 + g.shape[1]))
            isl[view] = np.where(g.island >= 0, g.island, isl[view])
            free[view] |= g.free
        return isl, free

    # ------------------------------------------------------------ motion and geodesics
    def _march(self, start: np.ndarray, direction: np.ndarray, length: float, tol: float | None = None):
        P, st = self.packed, self.settings
        tol = st.step_tolerance if tol is None else tol
        return K.march(P.meta, P.height, P.clearance, P.island, P.x0, P.z0, P.cs, float(start[0]),
                       float(start[1]), float(start[2]), float(direction[0]), float(direction[1]),
                       float(length), st.agent_radius, tol, 0.2 * st.cell_size)

    def _segment_clear(self, a: np.ndarray, b: np.ndarray) -> bool:
        """The straight segment a → b is navigable and arrives on b's floor."""
        d = np.array([b[0] - a[0], b[2] - a[2]])
        length = float(np.hypot(*d))
        if length < 1e-12:
            return abs(a[1] - b[1]) <= self.settings.step_tolerance
        t, y = self._march(a, d / length, length)
        return t >= length - 1e-6 and abs(y - b[1]) <= self.settings.step_tolerance

    def _ensure_graph(self):
        if self._graph is None:
            st = self.settings  # a move's rise: max_climb a cell; under the habitat profile, what Recast links
            graph, node_of = build_graph(self.layers, self.offsets, self.links,
                                         st.step_tolerance if st.profile == "habitat" else st.max_climb)
            self._graph = (graph, node_of, node_centres(self.layers, node_of, self.offsets),
                           node_cells(self.layers, node_of, self.offsets))
        return self._graph

    def _node(self, p: np.ndarray) -> int:
        graph, node_of = self._ensure_graph()[:2]
        P = self.packed
        k, f = K.locate(P.meta, P.height, P.x0, P.z0, P.cs, p[0], p[1], p[2], MAX_Y_DELTA)
        if k >= 0 and node_of[f] >= 0:
            return int(node_of[f])
        q = self.snap(p)
        if np.isnan(q).any():
            return -1
        k, f = K.locate(P.meta, P.height, P.x0, P.z0, P.cs, q[0], q[1], q[2], MAX_Y_DELTA)
        if k < 0:
            return -1
        if node_of[f] >= 0:
            return int(node_of[f])
        g = self.layers[k]
        ii, jj = self._nearest_nav(k)
        i, j = divmod(f - int(self.offsets[k]), g.shape[1])
        return int(node_of[self.offsets[k] + ii[i, j] * g.shape[1] + jj[i, j]])

    def _solve(self, node: int, goal: np.ndarray | None = None, keep: bool = True) -> FieldTree:
        """The Dijkstra tree to the goal point (default: the node's centre) from every node, smoothed only
        where fields read it; the last 8 are kept and given again. ``keep=False``: a tree of its own, not kept
        (a tree fills one values array: a goal pool's float32 copy cannot share one)."""
        graph, _, centres, _ = self._ensure_graph()
        goal = centres[node] if goal is None else goal
        key = (node, *np.round(goal, 9).tolist())
        if keep and key in self._fields:
            return self._fields[key]
        tree = FieldTree(run_dijkstra(graph, node, predecessors=True)[1], node, goal, self._goal_grid(node, goal))
        if keep:
            if len(self._fields) >= 8:
                self._fields.pop(next(iter(self._fields)))
            self._fields[key] = tree
        return tree

    def _goal_grid(self, node: int, goal: np.ndarray) -> tuple:
        """A field's goal in its node's layer: (layer, row, col), grid units."""
        cells = self._ensure_graph()[3]
        g = self.layers[cells[node, 0]]
        return cells[node, 0], (goal[2] - g.z0) / g.cs - 0.5, (goal[0] - g.x0) / g.cs - 0.5

    def distance_field(self, goal: np.ndarray, keep: bool = True) -> GeodesicField:
        """Geodesic distance field to `goal` (one Dijkstra over the goal's island; the any-angle smoothing
        is done where lookups read it). ``keep``: from and into the navmesh's cache of the last 8 fields."""
        node, goal = self._field_goal(goal)
        if node < 0:  # no graph node at or near the goal: inf everywhere
            return GeodesicField(self, goal, np.full(self._ensure_graph()[0].shape[0], np.inf))
        tree = self._solve(node, goal, keep)
        return GeodesicField(self, goal, tree.out, tree)

    def _field_goal(self, goal) -> tuple[int, np.ndarray]:
        """(graph node, goal point) of a field to ``goal``: the point snapped onto the navmesh unless it is on it or
        has no node (-1)."""
        goal = np.asarray(goal, dtype=np.float64).reshape(3)
        node = self._node(goal)
        return node, goal if node < 0 or self.is_navigable(goal) else self.snap(goal)

    def _field_distance(self, field: GeodesicField, p: np.ndarray):
        _, node_of, centres, cells = self._ensure_graph()
        P = self.packed
        pts = np.ascontiguousarray(np.asarray(p, dtype=np.float64).reshape(-1, 3))
        if field.tree is not None:
            out = field.tree.lookup(pts, field.values, node_of, cells, centres, P, MAX_Y_DELTA,
                                    self.settings.agent_radius - 1e-6)
        else:
            out = K.field_lookup(P.meta, P.height, P.x0, P.z0, P.cs, node_of, field.values, pts, MAX_Y_DELTA)
        out = self._straight_near_goal(out[None], pts, field.goal[None])[0]
        return float(out[0]) if np.ndim(p) == 1 else out

    def _straight_near_goal(self, out: np.ndarray, pts: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """Distances [G, N] to goals [G, 3] with the straight line where a point is next to its goal."""
        near = np.linalg.norm(pts[None] - goals[:, None], axis=-1)
        close = (near < 2 * self.packed.cs) & np.isfinite(out)
        out[close] = np.minimum(out[close], near[close])
        return out

    def shortest_path(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Shortest path [K, 3] from a to b (snapped): the 32-neighbour grid path, string-pulled
        and with its corners tightened onto the obstacle margin; empty [0, 3] if none."""
        a = self.snap(a)
        b = self.snap(b)
        if np.isnan(a).any() or np.isnan(b).any() or self.island_of(a) != self.island_of(b):
            return np.zeros((0, 3))
        d = b - a
        length = float(np.hypot(d[0], d[2]))
        if length < 1e-9 or self._segment_clear(a, b):
            return np.stack([a, b])
        na, nb = self._node(a), self._node(b)
        tree = self._solve(nb)
        if not tree.reaches(na):
            return np.zeros((0, 3))
        centres = self._ensure_graph()[2]
        chain = [na]
        while chain[-1] != nb:
            chain.append(int(tree.pred[chain[-1]]))
        pts = np.concatenate([a[None], centres[chain], b[None]])
        P, st = self.packed, self.settings
        args = (P.meta, P.height, P.clearance, P.island, P.x0, P.z0, P.cs)
        tol, step = st.step_tolerance, 0.2 * st.cell_size
        pts = pts[K.string_pull(*args, pts, st.agent_radius, tol, step)]
        if len(pts) > 2:  # tighten the corners, then drop vertices made redundant
            pts = K.relax_path(*args, pts, st.agent_radius, tol, step, 12)
            pts = pts[K.string_pull(*args, pts, st.agent_radius, tol, step)]
        return pts

    def geodesic_distance(self, a: np.ndarray, b: np.ndarray) -> float:
        """Length of the string-pulled shortest path (inf when unreachable)."""
        path = self.shortest_path(a, b)
        if len(path) == 0:
            return math.inf
        return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())

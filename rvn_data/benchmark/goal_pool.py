"""Train-mode goals from a fixed per-scene pool whose geodesic distance fields are computed
once per process, so an RL reset costs a start draw and a few look-ups instead of two
Dijkstra solves (~3 ms each on a procedural apartment).

`RVNEnv(goal_pool=G)` with G > 0: each scene gets G goal points drawn uniformly over its
sampled islands (`NavMesh.sampled_islands`: the main island unless navmesh.islands=all; a goal
on another island than the source is out of range, its distance infinite, and so is one on another floor than the
source's: `rvn_data.conventions.SAME_FLOOR`) by a generator that
is a pure function of (split, scene index, G), so every env of every process sees the same pool. A goal for a source pose is drawn uniformly among the
pool points whose geodesic distance from it lies in [d_min, d_max] (the benchmark's range);
none in range → the caller draws a fresh goal from two distance fields (`SceneSlot.draw_goal`; with a
pool of 64, none of 200 procedural train scenes' 10,000 random starts had none in range:
benchmarks/pool_fallback.py). G = 0 (the default) keeps the benchmark's sampler: a fresh
uniform goal every time. Evaluation never uses a pool: its episodes are fixed.

A pool's fields are solved and smoothed whole when it is built (`rvn_data.navmesh.field_sets.FieldTrees`): 1.45-1.95 s
for 64 goals on procedural:train/3's 13.7k nodes (Dijkstra solves 0.28-0.37 s, smoothing 1.2-1.6 s; 2-core
development CPU). Given the cache root's ``goal_pools`` folder (`EnvConfig.pool_folder`, as every env passes), a pool
is built once per cache root and read back after (`rvn_data.benchmark.pool_cache`: 50-85 ms for 64, its file
2.3 MB), so the processes of a node or cluster that share the root build each scene's pool once. The fields are
stacked, so a draw reads them all in one call: a visit's draws took 0.08-0.14 ms each (99th percentile 0.2-1.0 ms)
against 5.5-7.5 ms (14-25 ms) when pools were smoothed where read and every visit smoothed its starts' chains again
(`benchmarks/goal_pool.py`). Pools live in one
least-recently-used cache per process of at most ``MAX_BYTES`` (20 bytes per graph node and goal: 17-31 MB for 64
goals on a procedural apartment's 13-25k nodes); values read are float32. rvn-rl's scene prefetch has a scene's pool
made with the scene in a helper process (`rvn_data.helper_process`), which sends its predecessors and values."""
from __future__ import annotations

import threading
from collections import OrderedDict
from typing import NamedTuple

import numpy as np

from rvn_data.conventions import SAME_FLOOR
from rvn_data.navmesh.field_sets import FieldTrees, fields_distance
from rvn_data.navmesh.geodesic import GeodesicField

MAX_BYTES = 512 << 20
_POOLS: OrderedDict[tuple, "GoalPool"] = OrderedDict()
_LOCK = threading.Lock()  # an RL env prepares its next scene's pool in a thread of its own (rvn_rl.vec_env)


class PoolKey(NamedTuple):
    """What names a scene's goal pool in a process's cache (`pool_for`): the scene with its navmesh and scene settings
    (``scene``), and the pool's size, split code and scene index, which seed its goals (`GoalPool.build`)."""

    scene: tuple
    size: int
    split_code: int
    scene_index: int


class GoalPool:
    """``size`` goals of one scene with their fields (``stack``, a `FieldTrees`: trees and float32 values per navmesh
    node)."""

    def __init__(self, stack: FieldTrees):
        self.stack = stack

    @property
    def goals(self) -> np.ndarray:
        return self.stack.goals

    @property
    def nbytes(self) -> int:
        return self.stack.nbytes

    @classmethod
    def build(cls, navmesh, size: int, split_code: int, scene_index: int, folder=None) -> "GoalPool":
        """The pool's goals and fields, their solves in one call (`FieldTrees`); with ``folder`` (the cache root's
        ``goal_pools``), read from there when kept, else built and kept there (`rvn_data.benchmark.pool_cache`)."""
        def goals():
            rng = np.random.default_rng([0x600A1, int(split_code), int(scene_index), int(size)])
            return [navmesh.sample(rng) for _ in range(size)]

        if folder is None:
            return cls(FieldTrees(navmesh, goals()))
        from rvn_data.benchmark.pool_cache import cached_stack
        return cls(cached_stack(navmesh, goals, size, split_code, scene_index, folder))

    def fields(self, navmesh) -> list[GeodesicField]:
        """The pool's fields bound to ``navmesh`` (an env's own build of the same scene)."""
        s = self.stack
        return [GeodesicField(navmesh, g, v, t) for g, v, t in zip(s.goals, s.values, s.trees)]


def pool_for(navmesh, key: PoolKey, pool: GoalPool | None = None, folder=None) -> GoalPool:
    """The pool named ``key`` from this process's cache, else ``pool`` (built elsewhere, the same: a helper
    process's), else built (read from ``folder`` when kept there, `GoalPool.build`); kept in the cache as its most
    recently used."""
    with _LOCK:
        cached = _POOLS.pop(key, None)
    if cached is not None:
        pool = cached
    elif pool is None:  # outside _LOCK; with ``folder`` a second thread waits on the file's `build_lock`, then reads
        pool = GoalPool.build(navmesh, key.size, key.split_code, key.scene_index, folder)
    with _LOCK:
        _POOLS[key] = pool
        while len(_POOLS) > 1 and sum(p.nbytes for p in _POOLS.values()) > MAX_BYTES:
            _POOLS.popitem(last=False)
    return pool


def cached_pool(key: PoolKey) -> GoalPool | None:
    """The pool named ``key`` if this process's cache keeps it (not made more recently used)."""
    with _LOCK:
        return _POOLS.get(key)


class PoolSampler:
    """Goal draws for one loaded scene of one env."""

    def __init__(self, navmesh, pool: GoalPool):
        self.navmesh, self.goals, self.stack = navmesh, pool.goals, pool.stack
        self.fields = pool.fields(navmesh)

    def sample(self, source: np.ndarray, rng: np.random.Generator, d_min: float,
               d_max: float) -> tuple[np.ndarray, GeodesicField] | None:
        """A pool goal in [d_min, d_max] of ``source`` on its floor (within `SAME_FLOOR` of its height) and its
        field; None if no goal is in range."""
        d = fields_distance(self.navmesh, self.stack, source)  # every field's, in one call
        floor = np.abs(self.goals[:, 1] - source[1]) <= SAME_FLOOR
        ok = np.flatnonzero((d >= d_min) & (d <= d_max) & floor)
        if ok.size == 0:
            return None
        k = int(ok[rng.integers(ok.size)])
        return self.goals[k].copy(), self.fields[k]

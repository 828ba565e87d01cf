"""Navmesh and simulator figures (issue 2): build time for a procedural scene (goal <= 0.5 s)
and dream_apartment (goal <= 3 s), the same navmeshes read back from the cache root (a scene's later
visits in rvn-rl, rvn-eval, rvn-gen), simulator steps/s without rendering (goal >= 20,000),
geodesic distance field to one goal on dream_apartment and its first read at 1,000 points (goal <= 30 ms).

Numba compile time is excluded: every measured function runs once first (warm-up), and the
figures are the median of a few repeats. Run: python benchmarks/navmesh.py
"""
from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rvn_data.conventions import Action, AgentConfig
from rvn_data.navmesh import NavMesh, NavMeshSettings
from rvn_data.navmesh.source import open_navmesh
from rvn_data.scenes import load_scene
from rvn_data.sim import Simulator

DREAM = Path("/work/shared/scenes/dream_apartment.glb")


def timed(fn, repeats: int = 5) -> tuple[float, object]:
    fn()  # warm-up: numba compilation / cache load, lazy graph
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def main() -> int:
    settings = NavMeshSettings()
    print("navmesh benchmark (numba compile time excluded: warm-up run first; median of repeats)")
    try:
        from rvn_data.scenes.procedural import make_apartment  # noqa: F401

        scene = load_scene("procedural:train/0")
        dt, nm = timed(lambda: NavMesh.build(scene, settings))
        print(f"navmesh build, procedural:train/0 ({scene.num_triangles:,} triangles): {dt * 1e3:.0f} ms "
              f"(goal <= 500 ms), main island {nm.navigable_area:.1f} m²")
    except ImportError:
        print("navmesh build, procedural scene: skipped (rvn_data.scenes.procedural not available)")
    if not DREAM.exists():
        print(f"dream_apartment: skipped ({DREAM} not found)")
        return 0
    dream = load_scene(DREAM)
    dt, nm = timed(lambda: NavMesh.build(dream, settings), repeats=3)
    print(f"navmesh build, dream_apartment ({dream.num_triangles:,} triangles): {dt * 1e3:.0f} ms "
          f"(goal <= 3000 ms), main island {nm.navigable_area:.1f} m²")

    with tempfile.TemporaryDirectory() as root:  # a scene's later visits: the build read from the cache root
        kept = []
        for name, sc in (("procedural:train/0", scene), ("dream_apartment", dream)):
            open_navmesh(sc, settings, root)
            dt_read, _ = timed(lambda: open_navmesh(sc, settings, root))
            dt_build, _ = timed(lambda: NavMesh.build(sc, settings), repeats=3)
            kept.append(f"{name} {dt_read * 1e3:.1f} ms (build {dt_build * 1e3:.0f} ms, x{dt_build / dt_read:.0f})")
        print("navmesh read from the cache root (<cache root>/navmesh, a scene's later visits): " + ", ".join(kept))

    sim = Simulator(nm, AgentConfig())
    rng = np.random.default_rng(0)
    actions = rng.choice([Action.MOVE_FORWARD] * 2 + [Action.TURN_LEFT, Action.TURN_RIGHT], size=50_000)
    actions = [Action(int(a)) for a in actions]

    def walk():
        sim.reset(nm.sample(np.random.default_rng(1)), 0.0)
        collisions = 0
        for a in actions:
            collisions += sim.step(a).collided
        return collisions

    dt, collisions = timed(walk, repeats=3)
    print(f"simulator: {len(actions) / dt:,.0f} steps/s without rendering (goal >= 20,000; random "
          f"walk, 50 % MOVE_FORWARD, {collisions} collisions)")

    goals = [nm.sample(np.random.default_rng(i)) for i in range(5)]
    pts = np.stack([nm.sample(rng) for _ in range(1000)])
    nm.distance_field(goals[0]).distance(pts)  # warm-up builds the graph once per navmesh
    solve, first_read = [], []
    for g in goals[1:]:
        nm._fields.clear()  # no cache hit: a fresh Dijkstra each time
        t = time.perf_counter()
        field = nm.distance_field(g)
        t1 = time.perf_counter()
        field.distance(pts)  # smooths the nodes these lookups read
        solve.append(t1 - t)
        first_read.append(time.perf_counter() - t1)
    ms = lambda xs: statistics.median(xs) * 1e3  # noqa: E731
    print(f"geodesic distance field to one goal, dream_apartment: {ms(solve):.1f} ms (Dijkstra), {ms(first_read):.1f} ms "
          f"more for its first read at {len(pts):,} points (the smoothing they need): {ms(solve) + ms(first_read):.1f} ms "
          "(goal <= 30 ms; graph built once per navmesh, not counted)")
    field = nm.distance_field(goals[0])
    dt, _ = timed(lambda: field.distance(pts))
    print(f"field lookups: {len(pts) / dt:,.0f} points/s")
    t = time.perf_counter()
    NavMesh.build(dream, settings)._ensure_graph()
    nm2_graph = time.perf_counter() - t
    print(f"navmesh build + geodesic graph, dream_apartment: {nm2_graph * 1e3:.0f} ms")
    print("machine is shared and noisy: figures as measured once")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Goal pool figures (issue 32, RL row): what a train-mode reset with ``env.goal_pool`` costs.

A reset draws a start, then a pool goal whose geodesic distance from it lies in the benchmark's range: it reads the
distance from every one of the pool's fields at the start (smoothing each field's tree where it reads it). Vectorised
envs step together, so on a node with 30 envs, where most batched steps hold a reset, its cost is the batch's.
Printed: a pool's build against its read back from the cache root's ``goal_pools`` (`rvn_data.benchmark.pool_cache`,
which every env uses: a scene's pool is solved once per cache root); a scene's preparation with its pool
(`SceneSlot.prepared_parts`: load, navmesh, pool, the last two read back from the cache root as at a long run's later
visits) by a thread while the process runs a Python loop, in this process (loading holds the GIL: the loop stalls)
against in a helper process (`rvn_data.helper_process`, which `env.prefetch_scenes` uses; the thread waits for its
answer); the ms of a goal draw (at starts not read before, as at a reset, and again at the same starts) with the pool
read in one call (`rvn_data.navmesh.field_sets.fields_distance`) against field by field (the baseline, as before
2026-11-28), each on a pool of its own, the two in turns; the same distances (checked).
Run: python benchmarks/goal_pool.py [--scene procedural:train/3] [--goals 64] [--starts 300]
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def loop_rate(done) -> float:
    """Iterations a second of a pure-Python loop (an env's steps stand-in) until ``done()``."""
    k, t = 0, time.perf_counter()
    while not done():
        k += 1
    return k / (time.perf_counter() - t)


def built_beside_steps(make) -> tuple[float, float]:
    """(ms, share): ``make()`` run by a thread (as `env.prefetch_scenes` does), and the pace the process's own Python
    loop kept meanwhile against alone."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    make()  # a helper process started, numba's kernels loaded: outside the timing
    stop = threading.Event()  # the loop's test costs the same alone and beside the build
    threading.Timer(0.5, stop.set).start()
    alone = loop_rate(stop.is_set)
    with ThreadPoolExecutor(1) as pool:
        built = threading.Event()
        t = time.perf_counter()
        job = pool.submit(make)
        job.add_done_callback(lambda _: built.set())
        beside = loop_rate(built.is_set)
        job.result()
        return 1e3 * (time.perf_counter() - t), beside / alone


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="procedural:train/3")
    p.add_argument("--goals", type=int, default=64, help="pool size (env.goal_pool)")
    p.add_argument("--starts", type=int, default=300, help="start points drawn")
    args = p.parse_args()

    from rvn_data.benchmark.env import RVNEnv
    from rvn_data.benchmark.episodes_source import SceneSlot
    from rvn_data.benchmark.goal_pool import GoalPool, PoolSampler
    from rvn_data.helper_process import HelperProcess
    from rvn_data.navmesh.field_sets import fields_distance

    with tempfile.TemporaryDirectory() as tmp:
        env = RVNEnv(mode="train", split="train", scene_specs=[args.scene], goal_pool=args.goals, cache_dir=tmp)
        env.reset(seed=0)
        nav = env.navmesh
        t = time.perf_counter()
        pools = [GoalPool.build(nav, args.goals, 0, 0) for _ in range(2)]
        build = (time.perf_counter() - t) / 2
        kept = Path(tmp) / "goal_pools"
        GoalPool.build(nav, args.goals, 0, 0, kept)  # solved and written to the cache root
        t = time.perf_counter()
        read = [GoalPool.build(nav, args.goals, 0, 0, kept) for _ in range(5)]
        read_ms, file_mb = 1e3 * (time.perf_counter() - t) / 5, sum(f.stat().st_size for f in kept.glob("*.npz")) / 1e6
        if not all(np.array_equal(r.stack.pred, pools[0].stack.pred) for r in read):
            raise SystemExit("a pool read back differs from the built one")
        stacked, apart = PoolSampler(nav, pools[0]), pools[1].fields(nav)  # the other read field by field
        rng = np.random.default_rng(0)
        starts = [nav.sample(rng, island=0) for _ in range(args.starts)]
        fields_distance(nav, stacked.stack, starts[0] + 1e-3)  # numba: loaded before the timing
        ms = {"new": ([], []), "again": ([], [])}
        for rep in ("new", "again"):
            for s in starts:
                t0 = time.perf_counter()
                one = fields_distance(nav, stacked.stack, s)
                t1 = time.perf_counter()
                each = np.array([f.distance(s) for f in apart])
                t2 = time.perf_counter()
                if not np.array_equal(one, each):
                    raise SystemExit(f"the two reads differ at {s}: {one} against {each}")
                ms[rep][0].append(1e3 * (t1 - t0))
                ms[rep][1].append(1e3 * (t2 - t1))
        helper, prepare = HelperProcess(), (SceneSlot.prepared_parts, env.config, env._slots[0], True)
        try:
            pace = {"in this process": built_beside_steps(lambda: prepare[0](*prepare[1:])),
                    "in a helper process": built_beside_steps(lambda: helper.call(*prepare))}
        finally:
            helper.close()
            env.close()
    print(f"goal pool of {args.goals} on {args.scene} ({nav._ensure_graph()[0].shape[0]} graph nodes): "
          f"built in {1e3 * build:.0f} ms (one Dijkstra solve a goal); read back from the cache root in "
          f"{read_ms:.0f} ms (x{1e3 * build / read_ms:.0f}; its file {file_mb:.2f} MB)")
    for where, (took, share) in pace.items():
        print(f"  scene and pool prepared by a thread, {where:19s}: {took:5.0f} ms, while the process's own loop "
              f"kept {share:.0%} of its pace")
    for rep, label in (("new", "at starts not read before (a reset)"), ("again", "again at the same starts")):
        one, each = (float(np.median(v)) for v in ms[rep])
        print(f"  goal draw {label:38s}: one call {one:7.3f} ms, field by field {each:7.3f} ms (x{each / one:.1f})")


if __name__ == "__main__":
    main()

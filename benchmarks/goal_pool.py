"""Goal pool figures (issue 32, RL row): what a train-mode reset with ``env.goal_pool`` costs.

A reset draws a start, then a pool goal whose geodesic distance from it lies in the benchmark's range: it reads the
distance from every one of the pool's fields at the start. Vectorised envs step together, so on a node with 30 envs,
where most batched steps hold a reset, its cost is the batch's.
Printed: a pool's build (its Dijkstra solves, then its smoothing whole) against its read back from the cache root's
``goal_pools`` (`rvn_data.benchmark.pool_cache`, which every env uses: a scene's pool is built once per cache root); a
scene's preparation with its pool (`SceneSlot.prepared_parts`: load, navmesh, pool, the last two read back from the
cache root as at a long run's later visits) by a thread while the process runs a Python loop, in this process
(loading holds the GIL: the loop stalls) against in a helper process (`rvn_data.helper_process`, which
`env.prefetch_scenes` uses; the thread waits for its answer); the ms of the goal draws of a visit (a scene's first
``--visit`` draws, at new starts, on a pool as read back) and of draws at starts read before, three ways: the pool
smoothed whole (`FieldTrees`' default since 2026-12-02), the pool smoothed where read (one call, 2026-11-28 to
12-01) and field by field smoothed where read (before; the reference), the three the same distances (checked).
Run: python benchmarks/goal_pool.py [--scene procedural:train/3] [--goals 64] [--visits 30] [--visit 8]
"""
from __future__ import annotations

import argparse
import pickle
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


def one_call(nav, stack):
    from rvn_data.navmesh.field_sets import fields_distance

    return lambda s: fields_distance(nav, stack, s)


def field_by_field(fields):
    return lambda s: np.array([f.distance(s) for f in fields])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="procedural:train/3")
    p.add_argument("--goals", type=int, default=64, help="pool size (env.goal_pool)")
    p.add_argument("--visits", type=int, default=30, help="scene visits timed (each on a pool as read back)")
    p.add_argument("--visit", type=int, default=8, help="goal draws a visit (env.scene_switch_every)")
    args = p.parse_args()
    if min(args.goals, args.visits, args.visit) < 1:
        p.error("--goals, --visits and --visit must be positive")

    from rvn_data.benchmark.env import RVNEnv
    from rvn_data.benchmark.episodes_source import SceneSlot
    from rvn_data.benchmark.goal_pool import GoalPool
    from rvn_data.helper_process import HelperProcess
    from rvn_data.navmesh.field_sets import FieldTrees

    with tempfile.TemporaryDirectory() as tmp:
        env = RVNEnv(mode="train", split="train", scene_specs=[args.scene], goal_pool=args.goals, cache_dir=tmp)
        env.reset(seed=0)
        nav = env.navmesh
        goals = GoalPool.build(nav, args.goals, 0, 0).goals  # numba's kernels loaded: outside the timings
        t0 = time.perf_counter()
        lazy = FieldTrees(nav, goals, smooth=False)  # the solves alone
        t1 = time.perf_counter()
        whole = FieldTrees(nav, goals)  # the solves and the smoothing
        solves, build = t1 - t0, time.perf_counter() - t1
        kept = Path(tmp) / "goal_pools"
        GoalPool.build(nav, args.goals, 0, 0, kept)  # built and written to the cache root
        t = time.perf_counter()
        read = [GoalPool.build(nav, args.goals, 0, 0, kept) for _ in range(5)]
        read_ms, file_mb = 1e3 * (time.perf_counter() - t) / 5, sum(f.stat().st_size for f in kept.glob("*.npz")) / 1e6
        if not all(np.array_equal(r.stack.values, whole.values) for r in read):
            raise SystemExit("a pool read back differs from the built one")
        rng = np.random.default_rng(0)
        visits = [[nav.sample(rng, island=0) for _ in range(args.visit)] for _ in range(args.visits)]
        copy = lambda stack: pickle.loads(pickle.dumps(stack))  # as a helper sends a pool: values only if whole
        ways = {"pool smoothed whole": lambda: one_call(nav, copy(whole)),
                "pool smoothed where read": lambda: one_call(nav, copy(lazy)),
                "field by field, where read": lambda: field_by_field(GoalPool(copy(lazy)).fields(nav))}
        ms = {way: ([], []) for way in ways}
        for starts in visits:
            seen = []
            for way, fresh in ways.items():
                draw = fresh()
                for rep in (0, 1):  # a visit's draws, then again at the same starts
                    for s in starts:
                        t0 = time.perf_counter()
                        d = draw(s)
                        ms[way][rep].append(1e3 * (time.perf_counter() - t0))
                        seen.append(d)
            n = 2 * len(starts)
            if not all(np.array_equal(seen[k], seen[k + n * w]) for k in range(n) for w in (1, 2)):
                raise SystemExit("the three ways' distances differ")
        helper, prepare = HelperProcess(), (SceneSlot.prepared_parts, env.config, env._slots[0], True)
        try:
            pace = {"in this process": built_beside_steps(lambda: prepare[0](*prepare[1:])),
                    "in a helper process": built_beside_steps(lambda: helper.call(*prepare))}
        finally:
            helper.close()
            env.close()
    print(f"goal pool of {args.goals} on {args.scene} ({nav._ensure_graph()[0].shape[0]} graph nodes): "
          f"built in {1e3 * build:.0f} ms (Dijkstra solves {1e3 * solves:.0f} ms, smoothing whole "
          f"{1e3 * (build - solves):.0f} ms); read back from the cache root in {read_ms:.0f} ms "
          f"(its file {file_mb:.2f} MB)")
    for where, (took, share) in pace.items():
        print(f"  scene and pool prepared by a thread, {where:19s}: {took:5.0f} ms, while the process's own loop "
              f"kept {share:.0%} of its pace")
    for rep, label in ((0, f"a visit's {args.visit} draws (new starts)"), (1, "again at the same starts")):
        print(f"  goal draw, {label}, {args.visits} visits: mean / 99th percentile / slowest ms")
        base = float(np.mean(ms["pool smoothed where read"][rep]))
        for way, (times, again) in ms.items():
            v = np.array((times, again)[rep])
            print(f"    {way:28s}: {v.mean():7.3f} / {np.percentile(v, 99):7.3f} / {v.max():7.3f}"
                  f"   (x{base / v.mean():.1f} against the pool smoothed where read)")


if __name__ == "__main__":
    main()

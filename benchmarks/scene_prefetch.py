"""Scene prefetch and kept goal pools (issue 32, RL row): env steps/s of rvn-rl's vectorised envs alone with
``env.prefetch_scenes`` off and on, each with every scene's goal pool built at its visit (solved and, since 2026-12-02,
smoothed whole: a run's first pass over its scenes, and every visit before pools were kept) and read back from the
cache root (a long run after its first pass), in worker processes that step together, and each batched step's time
(median, 90th and 99th percentile); with ``--workers 0`` the envs step in this process (rvn-rl's default
``env.workers=0``).

Vectorised envs step together: a batched step lasts as long as its slowest worker. An env switching scene (every
``env.scene_switch_every`` resets; with random actions an episode lasts ~25 steps) waited for the scene (~0.1 s) and
its goal pool (~0.3 s), and with 15 workers one or another of them did at most steps (on an H200 node, 28 env steps/s
per worker in 15 workers against 331 in one). With prefetch each env draws its next scene ahead and has it prepared in a
helper process while it steps (`rvn_rl.vec_env.CachedSceneEnv._prepare`): the same scenes and episodes
(tests/test_rl_vec_env.py), without the wait. A pool's 64 Dijkstra solves still cost the node's cores at every visit
until pools were kept on disk (`rvn_data.benchmark.pool_cache`): read back in ~20 ms instead of ~0.3 s, the same pool.
Short runs (``--steps`` a few hundred) also time each env's helper starting (~1 s, once a run): give ``--steps 1000``
or more for a long run's rate. Each setting also prints what its batched steps' times predict for a node's 15 workers
stepping together, each taking the slowest of 15 resampled times (as the first GPU run's analysis did: 45 env steps/s
a worker predicted against the node's 28; a 2-core machine's own workers share its cores with the helpers).

A first untimed run fills the cache root's navmeshes and pools of the scenes the runs visit (all runs draw the same
scenes); then runs alternate over the four settings, those with pools built after the root's ``goal_pools`` folder was
emptied, so each timed run loads built navmeshes and either builds or reads its pools.
Run: python benchmarks/scene_prefetch.py [--workers CPUS] [--envs-per-worker 2] [--scenes 200] [--steps 200] [--rounds 2]
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np


def batched_step_times(cfg, steps: int) -> np.ndarray:
    """Seconds of each of ``steps`` batched steps (random actions) after 10 of warm-up (`rl.collection`)."""
    import rl as rl_bench

    times: list[float] = []
    rl_bench.collection(cfg, steps, False, times)
    return np.array(times)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                   help="env worker processes (default: one per CPU; 0: the envs in this process)")
    p.add_argument("--envs-per-worker", type=int, default=2)
    p.add_argument("--scenes", type=int, default=200)
    p.add_argument("--steps", type=int, default=200, help="timed batched steps per run")
    p.add_argument("--rounds", type=int, default=2, help="off/on pairs")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--renderer", default="auto")
    p.add_argument("--goal-pool", type=int, default=64)
    args = p.parse_args()
    if args.workers < 0 or args.envs_per_worker < 1 or args.steps < 1 or args.rounds < 1:
        p.error("--envs-per-worker, --steps and --rounds must be positive, --workers at least 0")
    from rvn_rl.cli import compose

    envs, processes = max(1, args.workers) * args.envs_per_worker, max(1, args.workers)
    settings = [(prefetch, kept) for kept in (False, True) for prefetch in (False, True)]
    with tempfile.TemporaryDirectory() as tmp:
        def cfg(prefetch: bool):
            return compose([f"env.size={args.size}", f"env.num_envs={envs}", f"env.workers={args.workers}",
                            f"env.num_scenes={args.scenes}", f"env.goal_pool={args.goal_pool}", f"renderer={args.renderer}",
                            f"env.prefetch_scenes={str(prefetch).lower()}", f"cache_dir={tmp}/cache", f"out_dir={tmp}/run",
                            "progress=false"])

        from rvn_data.benchmark import goal_pool

        batched_step_times(cfg(False), args.steps)  # fills the cache root's navmeshes and pools
        kept_pools = Path(tmp) / "cache" / "goal_pools"
        runs = {k: [] for k in settings}
        for _ in range(args.rounds):
            for prefetch, kept in settings:
                goal_pool._POOLS.clear()  # with --workers 0: no pool kept from an earlier run (workers start empty)
                if not kept:
                    shutil.rmtree(kept_pools, ignore_errors=True)
                runs[prefetch, kept].append(batched_step_times(cfg(prefetch), args.steps))
    where = f"{args.workers} worker processes" if args.workers else "this process"
    print(f"rvn-rl envs alone: {envs} envs in {where}, {args.size}² RGB, renderer={args.renderer}, "
          f"{args.scenes} train scenes, goal pool {args.goal_pool}, random actions, {args.steps} batched steps a run, "
          f"{args.rounds} run(s) each, alternated:")
    rate, rng = {}, np.random.default_rng(0)
    for (prefetch, kept), times in runs.items():
        t = np.concatenate(times)
        rate[prefetch, kept] = envs * len(t) / t.sum()
        q = np.percentile(t, [50, 90, 99]) * 1e3
        # each time is a batched step of `processes` workers already (the slowest's): ~15 workers is this many of them
        draws = max(1, round(15 / processes))
        lockstep = args.envs_per_worker / t[rng.integers(len(t), size=(20000, draws))].max(1).mean()
        print(f"  env.prefetch_scenes={str(prefetch).lower():5s} pools {'read back' if kept else 'built':9s} "
              f"{rate[prefetch, kept]:7.0f} env steps/s ({rate[prefetch, kept] / processes:.0f} per process); batched "
              f"step median {q[0]:.1f} ms, 90th {q[1]:.1f} ms, 99th {q[2]:.1f} ms, slowest {1e3 * t.max():.0f} ms; "
              f"resampled for {draws * processes} workers stepping together: {lockstep:.0f} env steps/s a worker")
    for kept in (False, True):
        print(f"  prefetch, pools {'read back' if kept else 'built':9s}: x{rate[True, kept] / rate[False, kept]:.2f} "
              "the env steps/s without it")
    for prefetch in (False, True):
        ratio = rate[prefetch, True] / rate[prefetch, False]
        print(f"  pools read back, prefetch {'on ' if prefetch else 'off'}: x{ratio:.2f} the env steps/s with them "
              "built at each visit")


if __name__ == "__main__":
    main()

"""Environment figures (issue 5): `RVNEnv` steps/s with rendering (256² RGB by default)
under the oracle policy, with 1 and 2 worker processes (combined steps/s).

Each worker builds its own env (eval mode, one procedural val scene each, episodes
generated beforehand), takes a few warm-up steps, waits for the others, then runs
``--steps`` steps (resets included). As in rvn-eval, with 2 workers each gets half of the
cores for software GL, OpenMP/BLAS and OpenCV (`rvn_data.worker_threads`) unless the user set
their variables. Run: python benchmarks/env.py [--steps 600]
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import sys
import tempfile
import time


def env_kwargs(args, rank: int, episodes_dir: str) -> dict:
    return dict(mode="eval", split="val", scenes={"first_scene": rank, "num_scenes": 1}, per_scene=args.per_scene,
                camera={"width": args.size, "height": args.size}, renderer={"backend": args.backend},
                episodes={"n_goals": 32, "dir": episodes_dir})


def worker(args, rank: int, threads: int, episodes_dir: str, barrier, results) -> None:
    from rvn_data.benchmark.env import RVNEnv
    from rvn_data.benchmark.policies import OraclePolicy
    from rvn_data.worker_threads import settle_worker_threads

    settle_worker_threads(threads)  # as rvn-eval's workers

    env = RVNEnv(**env_kwargs(args, rank, episodes_dir))
    oracle = OraclePolicy()
    oracle.bind(env)
    obs, _ = env.reset(seed=0)
    oracle.reset()

    def run(n: int):
        nonlocal obs
        for _ in range(n):
            obs, _, terminated, truncated, _ = env.step(oracle.act(obs))
            if terminated or truncated:
                obs, _ = env.reset()
                oracle.reset()

    run(20)  # warm-up: numba caches, GL pipeline
    barrier.wait()
    t = time.perf_counter()
    run(args.steps)
    results.put((rank, args.steps, time.perf_counter() - t, env._scene.renderer.backend))
    env.close()


def measure(args, workers: int, episodes_dir: str) -> tuple[float, str]:
    from rvn_data.worker_threads import threads_per_worker, worker_threads

    ctx = mp.get_context("spawn")
    barrier, results = ctx.Barrier(workers), ctx.Queue()
    threads = threads_per_worker(workers)
    procs = [ctx.Process(target=worker, args=(args, r, threads, episodes_dir, barrier, results)) for r in range(workers)]
    with worker_threads(threads):  # as rvn-eval: the cores split between the workers
        for p in procs:
            p.start()
    out = [results.get() for _ in procs]
    for p in procs:
        p.join()
    steps = sum(o[1] for o in out)
    return steps / max(o[2] for o in out), out[0][3]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=600, help="measured steps per worker")
    ap.add_argument("--size", type=int, default=256, help="image width = height")
    ap.add_argument("--backend", default="auto", help="renderer: auto | gl | raycast")
    ap.add_argument("--per-scene", type=int, default=4, help="episodes per scene")
    args = ap.parse_args()

    from rvn_data.benchmark.episodes_source import EnvConfig, ensure_scene_episodes

    with tempfile.TemporaryDirectory() as episodes_dir:
        for rank in range(2):
            cfg = EnvConfig.from_kwargs(**env_kwargs(args, rank, episodes_dir))
            ensure_scene_episodes(cfg, cfg.scene_slots()[0])
        print(f"RVNEnv steps/s with rendering ({args.size}x{args.size} RGB), oracle policy, "
              f"{args.steps} steps per worker (shared, noisy machine: figures as measured)")
        one, backend = measure(args, 1, episodes_dir)
        print(f"  1 worker : {one:8.1f} steps/s  (renderer backend: {backend})")
        two, _ = measure(args, 2, episodes_dir)
        print(f"  2 workers: {two:8.1f} steps/s combined  ({two / one:.2f}x one worker)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

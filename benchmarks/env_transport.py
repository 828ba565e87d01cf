"""How rvn-rl's env workers hand observations to the learner's process (`rvn_rl.vec_procs`): ms per
batched step spent moving them, pickled through the workers' pipes (before) against shared memory
(`ObsBlocks`, now), with stand-in workers that only reply (no env stepping), so the figure is the
transport alone, paid serially in the learner's process.

Run: python benchmarks/env_transport.py [--envs 32] [--workers 8] [--size 128] [--depth] [--steps 300]
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import time

import numpy as np


def worker(conn, envs: int, size: int, depth: bool, shared: bool) -> None:
    from rvn_rl.vec_procs import ObsBlocks

    rng = np.random.default_rng(0)
    obs = {"rgb": rng.integers(0, 255, (envs, size, size, 3), dtype=np.uint8),
           "pointgoal": rng.normal(size=(envs, 2)).astype(np.float32)}
    if depth:
        obs["depth"] = rng.random((envs, size, size), dtype=np.float32)
    blocks = ObsBlocks()
    flags = (np.zeros(envs, np.float32), np.zeros(envs, np.float32), np.zeros(envs, bool), [{}] * envs)
    try:
        while conn.recv() is not None:
            conn.send(("ok", ((blocks.write(obs) if shared else obs), *flags)))
    finally:
        blocks.close(unlink=True)


def ms_per_step(args, shared: bool) -> float:
    from rvn_rl.vec_procs import ObsBlocks, gather_obs

    ctx = mp.get_context("spawn")
    per = np.diff(np.linspace(0, args.envs, args.workers + 1).round().astype(int))
    conns, procs = [], []
    for n in per:
        a, b = ctx.Pipe()
        p = ctx.Process(target=worker, args=(b, int(n), args.size, args.depth, shared), daemon=True)
        p.start()
        conns.append(a)
        procs.append(p)
    blocks = [ObsBlocks() for _ in conns]

    def step():
        for c in conns:
            c.send(1)
        replies = [c.recv()[1] for c in conns]
        if shared:
            return gather_obs(blocks, [r[0] for r in replies])
        return {k: np.concatenate([r[0][k] for r in replies]) for k in replies[0][0]}  # as before shared memory

    for _ in range(20):
        step()
    t = time.perf_counter()
    for _ in range(args.steps):
        step()
    ms = 1e3 * (time.perf_counter() - t) / args.steps
    for b in blocks:
        b.close()
    for c in conns:
        c.send(None)
    for p in procs:
        p.join(timeout=10)
    return ms


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=32)
    ap.add_argument("--workers", type=int, default=8)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--depth", action="store_true", help="rendered depth in the observation too")
    ap.add_argument("--steps", type=int, default=300)
    args = ap.parse_args()
    pipe = [ms_per_step(args, False) for _ in range(2)]
    shm = [ms_per_step(args, True) for _ in range(2)]
    print(f"{args.envs} envs in {args.workers} workers, {args.size}² RGB{' + depth' if args.depth else ''}: "
          f"moving a step's observations to the learner {min(pipe):.2f} ms pickled through pipes, "
          f"{min(shm):.2f} ms through shared memory (x{min(pipe) / min(shm):.1f}); "
          f"per env step {1e3 * min(pipe) / args.envs:.0f} vs {1e3 * min(shm) / args.envs:.0f} µs")


if __name__ == "__main__":
    main()

"""Processes that ask for the same scenes' navmeshes and goal pools at once, over an empty cache root (issue 32: the RL
recipes' trainings side by side on the same scenes, DD-PPO's ranks, an env's scene prefetch): the CPU seconds they
spend and the wall time until the last is done, in three settings:

- own roots: each process its own cache root, so each builds every scene (the RL recipes' runs until 2026-12-02,
  each with its ``<out_dir>/cache``);
- one root: the same root for all (`jobs/rl_small.sh` and `jobs/rl_paper_scale.sh` now give their runs ``$OUT/cache``),
  each file built under its lock (`rvn_data.cache_root.build_lock`): one process builds a scene, the others wait for it
  and read it;
- one root, built before: the same root read back once every scene is kept (a long run's steady state).

Every process walks the scenes in the same order, as trainings with the same seed do, and starts at the same signal,
after its imports. Printed: the three settings' CPU seconds (summed over the processes) and wall seconds, and the
ratio of the first two's CPU.
Run: python benchmarks/shared_cache.py [--processes 2] [--scenes 4] [--pool 64]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = """
import sys, time
from pathlib import Path
from rvn_data.benchmark.goal_pool import GoalPool
from rvn_data.navmesh import NavMeshSettings
from rvn_data.navmesh.source import open_navmesh
from rvn_data.scenes import load_scene

root, go, scenes, pool = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
while not go.exists():
    time.sleep(0.002)
cpu = time.process_time()
for i in range(scenes):
    navmesh = open_navmesh(load_scene(f"procedural:train/{i}"), NavMeshSettings(), root)
    GoalPool.build(navmesh, pool, 0, i, folder=root / "goal_pools")
print(time.process_time() - cpu, time.time())
"""


def run(roots: list[Path], scenes: int, pool: int, work: Path) -> tuple[float, float]:
    """(CPU seconds summed over the processes, wall seconds from the signal to the last one's end): one process per
    root in ``roots`` (the same root given several times is shared)."""
    go = work / f"go-{time.monotonic_ns()}"
    procs = [subprocess.Popen([sys.executable, "-c", CHILD, str(root), str(go), str(scenes), str(pool)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for root in roots]
    time.sleep(4.0)  # their imports
    start = time.time()
    go.touch()
    outs = [p.communicate(timeout=600) for p in procs]
    for p, (_, err) in zip(procs, outs):
        if p.returncode:
            raise SystemExit(f"a process failed:\n{err[-3000:]}")
    cpu, ends = zip(*(map(float, out.split()) for out, _ in outs))
    return sum(cpu), max(ends) - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--scenes", type=int, default=4, help="procedural train scenes, the same for every process")
    ap.add_argument("--pool", type=int, default=64, help="goals a scene's pool (env.goal_pool)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        n = args.processes
        own = run([work / f"own{k}" for k in range(n)], args.scenes, args.pool, work)
        shared = run([work / "one"] * n, args.scenes, args.pool, work)
        kept = run([work / "one"] * n, args.scenes, args.pool, work)
    print(f"{n} processes asking at once for the navmesh and goal pool ({args.pool} goals) of the same "
          f"{args.scenes} procedural scenes, in the same order:")
    for name, (cpu, wall) in (("own roots (each builds all)", own), ("one root (each built once, under its lock)",
                                                                      shared), ("one root, built before", kept)):
        print(f"  {name:<44} {cpu:7.1f} CPU-s  {wall:6.1f} s wall")
    print(f"  one root against own roots: x{own[0] / shared[0]:.2f} less CPU")


if __name__ == "__main__":
    main()

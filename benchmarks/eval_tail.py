"""rvn-eval with one episode to run (a tiny run, the last episode of a resumed one): the seconds of the whole command
with ``workers=2`` against ``workers=1``, a NoMaD-PointGoal checkpoint on one val episode.

rvn-eval builds the policy once to check it before any episode; with one worker that policy runs the episodes in the
process. Until 2026-12-03 ``workers=2`` with one episode started a pool of one process instead, which imported torch
and loaded the policy again (`rvn_data.benchmark.runner.run_episodes`: never more workers than episodes now). The two
settings run in turns, one fresh command each, after one untimed pair (disk cache, the episode set); medians and their
ratio are printed. The checkpoint: policy_start.py's (a 2-step rvn-train run of NoMaD-PointGoal, small, on a synthetic
GNM dataset), in a temporary folder.
Run: python benchmarks/eval_tail.py [--rounds 3]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EVAL = ["split=val", "episodes.num_scenes=1", "episodes.per_scene=1", "episodes.n_goals=1", "env.t_max=20",
        "camera.width=96", "camera.height=96", "progress=false", "renderer=auto"]


def eval_seconds(tmp: Path, ckpt: Path, workers: int, k: int, env: dict) -> float:
    """Seconds of one rvn-eval command (a fresh out_dir each), start to exit."""
    cmd = [sys.executable, "-m", "rvn_data.benchmark.cli", "policy=checkpoint", f"policy.checkpoint_path={ckpt}",
           f"workers={workers}", f"out_dir={tmp / f'eval_{workers}_{k}'}", f"episodes.dir={tmp / 'episodes'}",
           f"cache_dir={tmp / 'cache'}", *EVAL]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    if r.returncode != 0:
        raise SystemExit(f"rvn-eval failed:\n{r.stderr[-2000:]}")
    return time.perf_counter() - t0


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=3, help="timed pairs (default 3)")
    args = p.parse_args()
    if args.rounds < 1:
        p.error("--rounds must be positive")
    from policy_start import small_nomad_checkpoint  # benchmarks/, beside this script

    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        ckpt = small_nomad_checkpoint(tmp, env)
        times = {1: [], 2: []}
        for k in range(args.rounds + 1):
            for workers in (2, 1):
                t = eval_seconds(tmp, ckpt, workers, k, env)
                if k:
                    times[workers].append(t)
    one, two = statistics.median(times[1]), statistics.median(times[2])
    print(f"rvn-eval, NoMaD-PointGoal (small) on one val episode, whole command, {args.rounds} rounds:")
    for w, m in ((1, one), (2, two)):
        print(f"  workers={w}   {m:.2f} s median ({', '.join(f'{t:.2f}' for t in times[w])})")
    print(f"  workers=2 / workers=1: x{two / one:.2f}")


if __name__ == "__main__":
    main()

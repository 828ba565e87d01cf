"""Policy start (a NoMaD checkpoint): the seconds a fresh Python process takes to load a NoMaD policy and make
its first decision, as each rvn-eval run and each of its worker processes does.

A NoMaD policy samples with the plans' own noise schedule (`rvn_il.models.sampling_plan.NoiseSchedule`), so the
process never imports diffusers, whose import brings torch._dynamo in. The baseline is the same process with
diffusers imported before the load, which is what every NoMaD policy paid until 2026-11-28 (the model made its
DDPMScheduler when it was built). The two run in turns, one fresh process each, after one untimed pair (disk
cache); the medians and their ratio are printed. The checkpoint: a 2-step rvn-train run of NoMaD-PointGoal
(small) on a synthetic GNM dataset, in a temporary folder.
Run: python benchmarks/policy_start.py [--rounds 5] [--threads 1]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

CHILD = """
import time; t0 = time.perf_counter()
import sys, numpy as np
if {baseline}:
    import diffusers
from rvn_il.policies import load_policy
from rvn_il.data.synthetic import render_frame
p = load_policy({ckpt!r}); p.reset()
p.act({{"rgb": render_frame(np.zeros(2), 0.0, 96), "pointgoal": np.array([3.0, -1.0], np.float32)}})
print(time.perf_counter() - t0, "diffusers" in sys.modules)
"""


def start_seconds(ckpt: Path, baseline: bool, env: dict) -> float:
    """Seconds from the child's first line to its first action (its interpreter's own start is left out)."""
    r = subprocess.run([sys.executable, "-c", CHILD.format(baseline=baseline, ckpt=str(ckpt))], capture_output=True,
                       text=True, env=env, timeout=600)
    if r.returncode != 0:
        raise SystemExit(f"policy start failed:\n{r.stderr[-2000:]}")
    seconds, imported = r.stdout.split()
    if imported != str(baseline):
        raise SystemExit(f"diffusers imported: {imported}, expected {baseline}")
    return float(seconds)


def small_nomad_checkpoint(tmp: Path, env: dict) -> Path:
    """A 2-step rvn-train run of NoMaD-PointGoal (small) on a synthetic GNM dataset, in ``tmp`` (also eval_tail.py's)."""
    from rvn_il.data.synthetic import write_synthetic_gnm

    write_synthetic_gnm(tmp / "data", 2, 20, image_size=96, seed=0)
    ckpt = tmp / "nomad"
    r = subprocess.run([sys.executable, "-m", "rvn_il.train.cli", "model=nomad_pointgoal", "model.size=small",
                        f"data.root={tmp}/data", f"out_dir={ckpt}", "train.max_steps=2", "train.batch_size=4",
                        "data.num_workers=0", f"cache_dir={tmp}/cache"], capture_output=True, text=True, env=env,
                       timeout=600)
    if r.returncode != 0:
        raise SystemExit(f"rvn-train failed:\n{r.stderr[-2000:]}")
    return ckpt


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=5, help="timed pairs (default 5)")
    p.add_argument("--threads", type=int, default=1, help="torch threads of each process (rvn-eval's workers: 1)")
    args = p.parse_args()
    if args.rounds < 1 or args.threads < 1:
        p.error("--rounds and --threads must be positive")
    env = {**os.environ, "OMP_NUM_THREADS": str(args.threads)}
    with tempfile.TemporaryDirectory() as tmp:
        ckpt = small_nomad_checkpoint(Path(tmp), env)
        times = {False: [], True: []}
        for k in range(args.rounds + 1):
            for baseline in (True, False):
                t = start_seconds(ckpt, baseline, env)
                if k:
                    times[baseline].append(t)
    new, old = statistics.median(times[False]), statistics.median(times[True])
    print(f"NoMaD policy start (load + first decision, fresh process, {args.threads} torch thread(s), {args.rounds} rounds):")
    print(f"  without diffusers (now)         {new:.2f} s median ({', '.join(f'{t:.2f}' for t in times[False])})")
    print(f"  diffusers imported (baseline)   {old:.2f} s median ({', '.join(f'{t:.2f}' for t in times[True])})")
    print(f"  {old - new:.2f} s less a process: x{old / new:.2f}")


if __name__ == "__main__":
    main()

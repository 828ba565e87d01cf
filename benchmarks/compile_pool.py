"""torch.compile's compile processes when rvn-eval's workers compile a policy at once (issue 32; `rvn_data.worker_threads`).

inductor compiles in a pool of helper processes, one per core by default, started by every process that compiles.
rvn-eval with workers=N and policy.compile=true compiles in each worker at its first decision: N pools of one process
per core (16 x 16 on a 16-core node), unless each worker gets its share (TORCHINDUCTOR_COMPILE_THREADS = cores // N,
at least 2: what rvn_data.worker_threads gives). This runs rvn-eval with one pool size per row (one per core, RVN's
share, one: the worker compiles alone), each with a cold kernel cache, on a NoMaD-PointGoal checkpoint trained here
for 2 steps (model.size=small, one Transformer layer, a 2-level U-Net, 4 denoising steps: small graphs, as
tests/test_compiled.py), and samples rvn-eval's process tree every 0.2 s: peak process count, peak memory (RSS summed
over the tree) and wall time. Rows with the same pool size run once.
On the 2-core development machine, 2 workers, two runs: a pool of two each (one per core, and RVN's) 110 and 92 s,
10 processes, 2.63 GB; a pool of one 126 and 117 s, 8 processes, 2.40 GB.

    python benchmarks/compile_pool.py [--workers 2]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rvn_data.worker_threads import COMPILE_VAR, compile_threads, threads_per_worker, usable_cores

PAGE = os.sysconf("SC_PAGE_SIZE")


def tree(root: int) -> list[int]:
    """``root`` and its descendants (from /proc)."""
    children: dict[int, list[int]] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(d.name))
    out, todo = [], [root]
    while todo:
        pid = todo.pop()
        out.append(pid)
        todo += children.get(pid, [])
    return out


def rss_bytes(pid: int) -> int:
    try:
        return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * PAGE
    except (OSError, IndexError, ValueError):
        return 0


def watched(cmd: list[str], env: dict, cwd: Path) -> tuple[float, int, float, int]:
    """(wall s, peak processes, peak GB of RSS over the tree, exit status) of ``cmd``; its stderr goes to a file, so
    a full pipe nobody reads while the tree is sampled cannot stall it (printed when it fails)."""
    t = time.perf_counter()
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=err, text=True)
        peak_n = peak_rss = 0
        while proc.poll() is None:
            pids = tree(proc.pid)
            peak_n, peak_rss = max(peak_n, len(pids)), max(peak_rss, sum(rss_bytes(p) for p in pids))
            time.sleep(0.2)
        if proc.returncode:
            err.seek(0)
            print(err.read()[-2000:], file=sys.stderr)
    return time.perf_counter() - t, peak_n, peak_rss / 1e9, proc.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2, help="rvn-eval workers (each compiles the policy)")
    args = ap.parse_args()
    if args.workers < 2:
        ap.error(f"--workers={args.workers}: give 2 or more (workers that compile at once)")
    from rvn_il.data.synthetic import write_synthetic_gnm

    cores = usable_cores()
    base = {k: v for k, v in os.environ.items() if k != COMPILE_VAR}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_synthetic_gnm(tmp / "expert", 3, 24, image_size=64, seed=0)
        train = [sys.executable, "-m", "rvn_il.train.cli", "model=nomad_pointgoal", f"data.root={tmp / 'expert'}",
                 "model.size=small", "train.max_steps=2", "train.batch_size=4", "model.num_diffusion_iters=4",
                 "model.num_layers=1", "model.sizes.small.down_dims=[32,64]", "data.num_workers=0",
                 f"out_dir={tmp / 'ckpt'}", f"cache_dir={tmp / 'train_cache'}"]
        subprocess.run(train, env=base, check=True, capture_output=True, timeout=600)
        print(f"rvn-eval, {args.workers} workers, policy.compile=true (NoMaD-PointGoal small, 4 steps), cold kernel "
              f"cache each, {cores} cores:")
        sizes: dict[int, list[str]] = {}  # pool size -> what gives it
        for label, n in (("one per core", cores), ("RVN's share", compile_threads(threads_per_worker(args.workers))),
                         ("one", 1)):
            sizes.setdefault(n, []).append(label)
        for n, labels in sizes.items():
            label, env = f"a pool of {n} in each worker ({', '.join(labels)})", {COMPILE_VAR: str(n)}
            out = tmp / f"eval_{n}"
            cmd = [sys.executable, "-m", "rvn_data.benchmark.cli", "split=val", f"episodes.num_scenes={args.workers}",
                   "episodes.per_scene=1", "episodes.n_goals=1", "env.t_max=4", f"workers={args.workers}",
                   "policy=checkpoint", f"policy.checkpoint_path={tmp / 'ckpt'}", "+policy.compile=true",
                   "camera.width=64", "camera.height=64", f"out_dir={out}", f"cache_dir={out}_cache",
                   "progress=false"]
            wall, procs, gb, rc = watched(cmd, {**base, **env}, tmp)
            print(f"  {label:56s}: {wall:6.1f} s, peak {procs:3d} processes, peak {gb:5.2f} GB RSS"
                  + ("" if rc == 0 else f"  (exit status {rc})"))


if __name__ == "__main__":
    main()

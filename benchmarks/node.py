"""Node benchmark (issue 32, item 1): every figure of issue 32's table, measured on this machine,
in one table with the device (GPU name or "CPU only"), CPU count, torch version and git commit; its header also
names the CPUs, their cgroup quota and the share of a core each process gets with all CPUs busy (node_cpu.py).

    python benchmarks/node.py [--seconds-per-row 15] [--out DIR] [--rows render gen train decision rl]
                              [--threads N] [--backends gl raycast] [--quick]

Rows (each timed for --seconds-per-row after its warm-up, so figures are steady state):
 1. renderer=gl and raycast, 256² RGB + depth, procedural:train/0: frames/s in 1, 2 and cpu_count processes
    (beside habitat-sim's published 1,042 frames/s in one process and 1,774 with five, Titan Xp), one view per
    render call, then 8 views per render_batch call in one process and 32 in 1, 2 and cpu_count processes;
 2. rvn-gen with cpu_count workers, 256², renderer=auto (with CUDA also renderer=raycast, and gl with
    __GL_YIELD=USLEEP, NVIDIA's GL waiting without spinning): frames/s after each
    worker's set-up (start-up, scene, navmesh, renderer; the end-to-end figure beside it), and each phase's share
    of the time and ms per frame (set-up, planning, rendering, encoding, writing), beside one worker's alone;
 3. rvn-train's step (its DataLoader with cpu_count workers, forward, backward, AdamW, EMA) of NoMaD-PointGoal
    and ViNT-PointGoal on synthetic GNM data: full size, batch 256, bf16 on a GPU; model.size=small, a small batch
    on a CPU: samples/s;
 4. one decision (act) of a NoMaD-PointGoal policy, 8 samples x its diffusion steps, on the GPU and on one
    CPU thread: median ms (the GPU row says "skipped" on a machine without CUDA);
 (--compile, on by default with CUDA: rows 3 and 4 with train.compile / policy.compile as rows of their own
    (`<row>_compiled`), each after its plain row, so a time limit that cuts a first compile (minutes; kernels are
    cached for the next run) leaves the plain figure; --compile-mode default reduce-overhead: a compiled training row
    per torch.compile mode (`<row>_compiled_reduce-overhead`: CUDA graphs); --warm SECONDS: the cold compiles first,
    side by side (node_warm.py); RVN's numba kernels are always compiled, or loaded, once before the render, gen and
    rl rows, so no worker of theirs compiles them (a GPU lease is a fresh install);
    --profile, on by default with CUDA: torch.profiler's operator table of a few more steps of rows 3 and 4
    (and of row 5's learner: one update's act, storage and PPO update without the envs), written beside node.md as
    profile_<row>.txt, so a goal the table misses comes with what bounds it);
 5. rvn-rl PPO collection + learning at 128², ResNet-18, scale=small PPO settings, envs in worker processes:
    env steps/s (with CUDA also the envs alone: random actions, no policy or learner, in the rl row's workers with
    and without env.prefetch_scenes, and in one worker); and with the paper's network and PPO
    settings (ResNet-50, 256²) beside DD-PPO's ~160 per GPU.
With CUDA, each row shows issue 32's goal and measured/goal, and "GPU busy": GPU 0's mean utilization
(torch.cuda.utilization or pynvml; "n/a" without them) during the timed steps of rows 3 and 4, while the whole row
ran for the others (set-up and warm-up included: the third GPU run's kernel-bound training steps read 7-24 % so);
the profiles give the kernel time of the profiled steps. On the first GPU
run (H200, 16 cores, 5 s per figure) render with --backends gl took 86 s, gen 16 s, rl 66 s; the plain decision
and train groups 44 and 58 s (6 s per figure); cold compiles of both ran past 150 and 190 s. --quick: about a second per figure at tiny sizes (a smoke test;
its figures mean little; on a CPU that emulates bfloat16 it leaves rl_bf16 out). --out DIR: DIR/node.md and DIR/node.json (with the commit), e.g.
docs/results/<date>_gpu/, rewritten after each row (a run cut short keeps the rows it measured; groups run in
the order --rows names them;
benchmarks/node_gpu.sh runs it on an offline GPU node). Exit status 1 when a row failed (its error is in the table), 2 for bad options.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from types import SimpleNamespace

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the other benchmarks' modules

import node_cpu  # noqa: E402
import node_report  # noqa: E402
import node_warm  # noqa: E402
from node_rl import SKIPPABLE, rl_rows  # noqa: E402
from node_rows import decision_rows, failed_row, gen_rows, render_rows, train_rows  # noqa: E402

from rvn_il.train.choices import COMPILE_MODES  # noqa: E402  (torch-free: node.py parses without torch)

GROUPS = {"render": render_rows, "gen": gen_rows, "train": train_rows, "decision": decision_rows, "rl": rl_rows}


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit status 2
        self.exit(2, f"benchmarks/node.py: {message} (see --help)\n")


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    ap = _Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds-per-row", type=float, default=None,
                    help="seconds each figure is timed after warm-up (default 15; --quick: 1)")
    ap.add_argument("--quick", action="store_true", help="about a second per figure at tiny sizes (tests)")
    ap.add_argument("--out", type=Path, default=None, help="write node.md and node.json to this folder")
    ap.add_argument("--rows", nargs="+", choices=list(GROUPS), default=list(GROUPS),
                    help="row groups to run, in this order")
    ap.add_argument("--threads", type=int, default=None,
                    help="torch intra-op threads of the training rows (rvn-train, rvn-rl); default: all cores "
                         "(rvn-rl on a GPU: 4), --quick: 1 (on a busy machine threads spin-wait on each other)")
    ap.add_argument("--loader-workers", type=int, default=None, metavar="N",
                    help="DataLoader worker processes of the training rows (default: one per CPU with CUDA, else 1; "
                         "--quick: 0): fewer leave the host's main thread a core of its own")
    ap.add_argument("--scene", default="procedural:train/0", help="scene of the renderer rows")
    ap.add_argument("--backends", nargs="+", choices=("gl", "raycast"), default=["gl", "raycast"],
                    help="renderers of the renderer rows (default both; rvn-gen and rvn-rl use renderer=auto)")
    ap.add_argument("--compile", choices=("auto", "on", "off"), default="auto",
                    help="train.compile and policy.compile in the training and decision rows (auto: on with CUDA, "
                         "not with --quick; the plain decision is timed beside the compiled one)")
    ap.add_argument("--profile", choices=("auto", "on", "off"), default="auto",
                    help="torch.profiler's operator table of a few steps of the training and decision rows, and of "
                         "the RL rows' learner, written beside node.md as profile_<row>.txt (auto: on with CUDA, not "
                         "with --quick)")
    ap.add_argument("--compile-mode", nargs="+", choices=COMPILE_MODES, default=["default"],
                    help="torch.compile modes of the compiled training rows, a row each (reduce-overhead: CUDA graphs "
                         "for a step bound by the host's launches; row train_<model>_compiled_reduce-overhead)")
    ap.add_argument("--warm", type=float, default=0, metavar="SECONDS",
                    help="first compile the compiled rows' models side by side in processes of their own, at most "
                         "SECONDS (node_warm.py): their rows then load the kernels (default 0: each row compiles cold)")
    ap.add_argument("--skip", nargs="+", choices=SKIPPABLE, default=[], metavar="ROW",
                    help=f"RL rows to leave out, each named as skipped in the table ({', '.join(SKIPPABLE)}): "
                         "rows a lease has measured already, whose minutes another row needs")
    args = ap.parse_args(argv)
    if args.seconds_per_row is None:
        args.seconds_per_row = 1.0 if args.quick else 15.0
    if not 0 < args.seconds_per_row <= 120:
        ap.error(f"--seconds-per-row={args.seconds_per_row:g} must be in (0, 120]")
    if args.warm < 0:
        ap.error(f"--warm={args.warm:g} must be >= 0")
    if args.threads is not None and args.threads < 1:
        ap.error(f"--threads={args.threads} must be >= 1")
    if args.loader_workers is not None and args.loader_workers < 0:
        ap.error(f"--loader-workers={args.loader_workers} must be >= 0")
    if args.out is not None:  # checked before minutes of measuring
        if args.out.exists() and not args.out.is_dir():
            ap.error(f"--out {args.out} is a file, not a folder")
        try:
            args.out.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            ap.error(f"--out {args.out}: {e.strerror or e}")
        if not os.access(args.out, os.W_OK):
            ap.error(f"--out {args.out} is not writable")
    return args


def make_plan(args, cuda: bool, cpus: int) -> SimpleNamespace:
    """Sizes, batches and process counts of every row on this machine (quick: tiny)."""
    q = args.quick
    return SimpleNamespace(
        quick=q, seconds=args.seconds_per_row, cuda=cuda, cpus=cpus, scene=args.scene, backends=args.backends,
        compile=args.compile == "on" or (args.compile == "auto" and cuda and not q),
        compile_modes=list(dict.fromkeys(args.compile_mode)),
        profile=args.profile == "on" or (args.profile == "auto" and cuda and not q),
        size=64 if q else 256,
        render_processes=sorted({1, 2, cpus}),
        render_batches=[(4, [1])] if q else [(8, [1]), (32, sorted({1, 2, cpus}))],
        gen_workers=min(2, cpus) if q else cpus,
        train_data=(6, 20) if q else (64, 40) if cuda else (16, 30),
        train_image=64 if q else 128,
        train_batch=4 if q else 256 if cuda else 16,
        loader_workers=args.loader_workers if args.loader_workers is not None else 0 if q else cpus if cuda else 1,
        train_threads=args.threads or (1 if q else None),
        cpu_model_size="small",
        decision_cpu_size="small" if q else "full",
        rl_size=64 if q else 128,
        rl_paper_size=64 if q else 256,
        rl_envs=2 if q else 2 * max(1, cpus - 1) if cuda else 8,
        rl_workers=1 if q else max(1, cpus - 1) if cuda else min(cpus, 8),
        rl_scenes=1 if q else 200,  # most scene switches load a scene the worker has not seen, as over all 800
        rl_num_steps=8 if q else 64,
        rl_threads=args.threads or (1 if q else min(4, cpus) if cuda else cpus),
        # RL rows: the seconds of each run's start not timed (its envs' scene-prefetch helpers starting, ~1.3 s each
        # on the development CPU: `rl.steady_updates`); until the fifth GPU run, 10 batched steps or one update
        rl_warm_seconds=0.0 if q else 5.0,
        skip=sorted(set(args.skip)),
    )


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    info = node_report.machine()
    plan = make_plan(args, info["cuda"], info["cpu_count"])
    print(f"[node] {info['device']}, {info['cpu_count']} CPUs, torch {info['torch']}: rows {' '.join(args.rows)}, "
          f"{plan.seconds:g} s per figure", file=sys.stderr, flush=True)
    try:  # before any row loads the CPUs; a probe that fails is a line of the header, not the end of the run
        info["cpu"] = node_cpu.cpu_info(plan.cpus, 0.3 if plan.quick else 1.5)
    except Exception as e:
        info["cpu"] = {"error": f"{type(e).__name__}: {e}"}
    print(f"[node] {node_cpu.describe(info['cpu'], plan.cpus)}", file=sys.stderr, flush=True)
    rows, plan_dict, paths = [], dict(vars(plan)), []
    try:  # before any worker process of a row needs them
        plan_dict["numba"] = node_warm.numba_kernels(args.rows)
    except Exception as e:
        plan_dict["numba"] = f"numba kernels: the one-trajectory rvn-gen FAILED ({type(e).__name__}: {e})"[:300]
    if plan_dict["numba"]:
        print(f"[node] {plan_dict['numba']}", file=sys.stderr, flush=True)
    if args.warm:
        t = time.perf_counter()
        plan_dict["warm"] = node_warm.warm(plan, args.rows, args.warm)
        print(f"[node] --warm: {'; '.join(plan_dict['warm']) or 'nothing to compile'} "
              f"({time.perf_counter() - t:.0f} s)", file=sys.stderr, flush=True)
    numbers = {name: k for k, name in enumerate(GROUPS, 1)}

    def add(r: dict) -> None:  # the row, then the table so far: a run stopped by a time limit keeps what it measured
        nonlocal paths
        node_report.compare(r, info["cuda"])
        rows.append(r)
        if args.out is not None:
            paths = node_report.write(args.out, info, rows, plan_dict, node_report.markdown(info, rows, plan_dict))

    for name in dict.fromkeys(args.rows):  # in the order given: a GPU node's time limit cuts the last ones
        t, got = time.perf_counter(), 0
        try:
            for r in GROUPS[name](plan):
                r["wall_s"] = round(time.perf_counter() - t, 1)  # since the group began
                add(r)
                got += 1
        except Exception as e:  # the other groups still run; the table says what failed
            add(failed_row(numbers[name], name, name, "", e))
        print(f"[node] {name}: {got} row(s) in {time.perf_counter() - t:.0f} s", file=sys.stderr, flush=True)
    print(node_report.markdown(info, rows, plan_dict), end="")
    if paths:
        print(f"\nwritten: {', '.join(str(p) for p in paths)}")
    return 1 if any(r["error"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())

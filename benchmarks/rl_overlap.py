"""Learning while collecting (issue 32's RL row): rvn-rl's own loop (`rvn_rl.trainer.train`) with
``train.overlap`` off and on, alternated over ``--rounds`` pairs of runs, each from the same weights and scenes. Prints
each setting's env steps/s of collection + learning (each run's steady updates counted: not its first, which loads
scenes and warms up, nor, overlapped, its last, beside which nothing is collected), the shares of the loop's time (envs stepping, waiting for the PPO update) and the ratio on / off.

With ``train.overlap=true`` each PPO update runs in a learner thread while the envs collect the next rollout, so an
update's time is the longer of the two instead of their sum: the gain is largest where the two use different hardware
(the learner a GPU, the envs the node's cores). On a CPU they share the cores: with envs in worker processes
(``--workers``) the learner's convolutions run beside the workers' stepping; with the envs in the loop's process
(``--workers 0``) both also take turns for the GIL. ``--recompute-advantages``: the overlapped runs with
``ppo.recompute_advantages=true`` too (the rollout's values recomputed with the learner's weights, one forward pass
without gradients an update), as the recipe sets it: overlap alone collided more (docs/results/2026-12-02_rl_overlap).
Run: python benchmarks/rl_overlap.py [--envs 4] [--workers 1] [--updates 4] [--threads 1] [--device cpu|cuda]
    [--precision bf16] [--compile] [--recompute-advantages]
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np


def steady_rows(args, cache: str, **settings) -> list[dict]:
    """The metrics rows of one rvn-rl run's steady updates (`rl.steady_updates`: not the first and, overlapped, not
    the last either) over the cache root ``cache``: ``args`` and ``settings`` (`rl.overrides`' names) on ``args.device``."""
    import rl as rl_bench
    from rvn_rl.cli import compose
    from rvn_rl.trainer import train

    with tempfile.TemporaryDirectory() as tmp:
        spec = SimpleNamespace(**{**vars(args), **settings}, cache_dir=cache)
        train(compose(rl_bench.overrides(spec, f"{tmp}/run") + [f"device={args.device}"]))
        return rl_bench.steady_updates([json.loads(line) for line in
                                        (Path(tmp) / "run" / "metrics.jsonl").read_text().splitlines()])


def one_run(args, overlap: bool, cache: str) -> tuple[float, dict] | None:
    """(env steps/s of the steady-state updates, their time-weighted shares) of one rvn-rl run (None without any)."""
    import rl as rl_bench

    rows = steady_rows(args, cache, overlap=overlap, recompute=overlap and args.recompute_advantages)
    if not rows:
        return None
    steps = np.array([r["rollout_steps"] * args.envs for r in rows])
    seconds = np.array([rl_bench.update_seconds(r, args.envs) for r in rows])
    shares = {k: float((seconds * [r[k] for r in rows]).sum() / seconds.sum()) for k in ("time_envs", "time_learn")}
    return float(steps.sum() / seconds.sum()), shares


def loop_arguments(p: argparse.ArgumentParser, workers: int) -> None:
    """The run's arguments that this benchmark and benchmarks/rl_double_buffered.py share (`rl.overrides` reads them),
    with ``--workers`` defaulting to ``workers``, and ``--rounds``."""
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--envs", type=int, default=4)
    p.add_argument("--workers", type=int, default=workers, help="env worker processes (0: in the loop's process)")
    p.add_argument("--scenes", type=int, default=4)
    p.add_argument("--updates", type=int, default=4, help="updates a run (the first not counted, nor an "
                   "overlapped run's last)")
    p.add_argument("--num-steps", type=int, default=32, help="rollout length")
    p.add_argument("--ppo-epoch", type=int, default=2)
    p.add_argument("--mini-batches", type=int, default=2)
    p.add_argument("--threads", type=int, default=1, help="torch intra-op threads of the loop and its learner")
    p.add_argument("--base-planes", type=int, default=16, help="ResNet-18 base width")
    p.add_argument("--renderer", default="auto")
    p.add_argument("--goal-pool", type=int, default=64)
    p.add_argument("--device", default="cpu")
    p.add_argument("--rounds", type=int, default=2, help="off/on pairs")


def alternated(args, one_run) -> tuple[dict, float]:
    """``one_run(args, on, cache)`` off then on, ``args.rounds`` times, over one cache root that an untimed first run
    of one update fills. Returns {False: [...], True: [...]} of the runs' results and the timed runs' seconds."""
    runs = {False: [], True: []}
    with tempfile.TemporaryDirectory() as cache:
        one_run(SimpleNamespace(**{**vars(args), "updates": 1}), False, cache)  # fills the cache root's scenes, untimed
        t = time.perf_counter()
        for _ in range(args.rounds):
            for on in (False, True):
                runs[on].append(one_run(args, on, cache))
    return runs, time.perf_counter() - t


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    loop_arguments(p, workers=1)
    p.add_argument("--precision", default="fp32")
    p.add_argument("--compile", action="store_true", help="train.compile=true (the learner's trunk compiled; on a GPU "
                   "as CUDA graphs): each run compiles in its first, uncounted update")
    p.add_argument("--recompute-advantages", action="store_true",
                   help="the overlapped runs with ppo.recompute_advantages=true (the recipe's pairing)")
    args = p.parse_args()
    if args.updates < 3 or args.rounds < 1 or args.envs < args.mini_batches:
        p.error("--updates must be at least 3, --rounds at least 1, --envs at least --mini-batches")
    args.backbone = "resnet18"
    runs, seconds = alternated(args, one_run)
    where = f"{args.workers} worker processes" if args.workers else "the loop's process"
    print(f"rvn-rl PPO collection + learning, {args.size}² RGB, ResNet-18 (base {args.base_planes}), {args.envs} envs in "
          f"{where}, rollouts of {args.num_steps}, {args.ppo_epoch} epochs x {args.mini_batches} mini-batches, "
          f"{args.threads} torch thread(s), {args.device}, {args.precision}{', compiled' if args.compile else ''}; {args.updates - 1} updates counted a plain run, {args.updates - 2} an overlapped one, "
          f"{args.rounds} run(s) each, alternated ({seconds:.0f} s):")
    rate = {}
    for overlap, results in runs.items():
        rates = [r for r, _ in results]
        rate[overlap] = float(np.mean(rates))
        shares = {k: np.mean([s[k] for _, s in results]) for k in results[0][1]}
        print(f"  train.overlap={str(overlap).lower():5s}{' + recompute' if overlap and args.recompute_advantages else ''} {rate[overlap]:7.1f} env steps/s (runs: "
              f"{', '.join(f'{r:.1f}' for r in rates)}); envs stepping {100 * shares['time_envs']:.0f}% of the time, "
              f"{'waiting for' if overlap else 'in'} the PPO update {100 * shares['time_learn']:.0f}%")
    on = "train.overlap=true" + (" with ppo.recompute_advantages=true" if args.recompute_advantages else "")
    print(f"  {on}: x{rate[True] / rate[False]:.2f} the env steps/s without it")


if __name__ == "__main__":
    main()

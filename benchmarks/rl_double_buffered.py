"""Double-buffered collection (issue 32's RL row): rvn-rl's own loop (`rvn_rl.trainer.train`) with
``train.double_buffered`` off and on, alternated over ``--rounds`` pairs of runs from the same weights and scenes.
Prints each setting's env steps/s of collection alone (each update's rollout: the acts and the envs' steps) and of
collection + learning, over each run's steady updates (`rl.steady_updates`: not the first, which loads scenes), the
share of the collection the loop waited for the envs, and the ratios on / off.

With ``train.double_buffered=true`` the env workers are two halves, and the policy acts for one while the other steps
(`rvn_rl.collect`), so an act's time hides behind the other half's step instead of adding to it. It pays where the
acts and the envs' steps use different hardware (a GPU acting, the node's cores stepping) and two acts of half the
envs take little more than one of all (``--graph-act``: a CUDA graph's replay an act). Acts of host launches (~7.9 ms
for 30 envs on the fourth H200 run) cost about as much for half the envs, so two a step would cost more than they hide.
On a CPU the acts' convolutions and the workers' steps share the cores.
Run: python benchmarks/rl_double_buffered.py [--envs 4] [--workers 2] [--updates 4] [--threads 1] [--device cpu|cuda]
    [--graph-act] [--rounds 2]
"""
from __future__ import annotations

import argparse

import numpy as np


def one_run(args, double: bool, cache: str) -> tuple[float, float, float] | None:
    """(env steps/s of collection alone, of collection + learning, the collection's share waiting for the envs) over
    one rvn-rl run's steady updates (None without any)."""
    import rl as rl_bench
    import rl_overlap

    rows = rl_overlap.steady_rows(args, cache, double_buffered=double)
    if not rows:
        return None
    steps = np.array([r["rollout_steps"] * args.envs for r in rows])
    collecting = steps / np.array([r["fps_collect"] for r in rows])
    seconds = np.array([rl_bench.update_seconds(r, args.envs) for r in rows])
    waiting = float((seconds * [r["time_envs"] for r in rows]).sum() / collecting.sum())
    return float(steps.sum() / collecting.sum()), float(steps.sum() / seconds.sum()), waiting


def main() -> None:
    import rl_overlap

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    rl_overlap.loop_arguments(p, workers=2)  # the same run's arguments, at least 2 workers: two halves
    p.add_argument("--graph-act", action="store_true", help="train.graph_act=true in both (a CUDA graph's replay an "
                   "act; on a CPU the acts run as without it)")
    args = p.parse_args()
    if args.updates < 2 or args.rounds < 1 or args.envs < args.mini_batches or not 2 <= args.workers <= args.envs:
        p.error("--updates must be at least 2, --rounds at least 1, --envs at least --mini-batches, --workers "
                "between 2 and --envs")
    args.backbone = "resnet18"
    runs, seconds = rl_overlap.alternated(args, one_run)
    if not all(runs[True] + runs[False]):
        raise SystemExit("no steady update to count: raise --updates")
    print(f"rvn-rl PPO collection, {args.size}² RGB, ResNet-18 (base {args.base_planes}), {args.envs} envs in "
          f"{args.workers} worker processes, rollouts of {args.num_steps}, {args.threads} torch thread(s), "
          f"{args.device}{', train.graph_act=true' if args.graph_act else ''}; {args.updates - 1} updates counted a "
          f"run, {args.rounds} run(s) each, alternated ({seconds:.0f} s):")
    rate = {}
    for double, results in runs.items():
        collect, both, waiting = (np.array([r[i] for r in results]) for i in range(3))
        rate[double] = (float(collect.mean()), float(both.mean()))
        print(f"  train.double_buffered={str(double).lower():5s} collection {rate[double][0]:7.1f} env steps/s (runs: "
              f"{', '.join(f'{r:.1f}' for r in collect)}), waiting for the envs {100 * waiting.mean():.0f}% of it; "
              f"collection + learning {rate[double][1]:7.1f}")
    print(f"  train.double_buffered=true: collection x{rate[True][0] / rate[False][0]:.2f}, collection + learning "
          f"x{rate[True][1] / rate[False][1]:.2f} the env steps/s without it")


if __name__ == "__main__":
    main()

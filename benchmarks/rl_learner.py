"""rvn-rl's learner alone (issue 32's RL row): one PPO update in float32 and with ``train.precision=bf16`` (the visual
encoder under torch.autocast(bfloat16)) and, with ``--compile``, both with ``train.compile`` (the visual trunk
compiled; on a GPU its forward and backward as CUDA graphs) and, with ``--decoupled`` and ``--recompute``, in float32
with train.overlap's lag corrections ``ppo.decoupled`` (the proximal log-probs recomputed first: one forward pass
over the rollout without gradients) and ``ppo.recompute_advantages`` (the values recomputed first: the same pass;
with both flags also both settings, which share it), and with ``--unfused``, in float32 with Adam's for-each step
instead of rvn-rl's fused one (CUDA: `rvn_il.train.choices.fused_on`; on a CPU both are torch's default), as rvn-rl
runs it (`ppo_update` over `DeviceRollouts`) on a rollout of random frames with ~25-step episodes; alternated rounds
after a warm-up one, best of ``--repeats``. Prints each update's ms, the env steps/s that learning alone would allow
(rollout steps / update seconds), the ratio, the first update's seconds (compiling, for a compiled one) and how far
each first update's losses from the same weights are from float32's. ``--cudnn-benchmark`` runs every variant on
cuDNN's timed choice of convolution algorithms (``torch.backends.cudnn.benchmark``; the fourth GPU run's profile of
an update and 64 acts spent 83 of its 430 ms of kernels in FFT convolutions, filter flips and cuDNN's layout
conversions, which its heuristics chose: profile_rl.txt in docs/results/2026-12-04_gpu4). cuDNN keys its cache of
choices without the flag, so the flag is a run of its own, compared with a run without it.

On the 2-core development CPU an update of scale=small (8 envs x 64 steps, 128², ResNet-18 base 32, 4 x 4
mini-batches) takes ~15 s in float32, the bound of rvn-rl's README recipe there (collection alone runs at ~150 env
steps/s); on the third GPU run (H200, 30 envs) the update was 1.1 s of every 1,920 env steps.
Run: python benchmarks/rl_learner.py [--device cuda --envs 30 --compile] [--decoupled] [--recompute] [--size 128]
[--threads 2] [--repeats 2] [--no-bf16] [--unfused] [--cudnn-benchmark]
"""
from __future__ import annotations

import argparse
import copy
import dataclasses
import time

import numpy as np
import torch


def filled_rollouts(n: int, steps: int, size: int, state_shape: tuple, seed: int = 0, episode: int = 25):
    """A `RolloutStorage` of ``steps`` x ``n`` random RGB frames, goals, actions, values and rewards, episodes ending
    with probability 1/``episode`` a step, returns computed."""
    from rvn_rl.rollout import RolloutStorage

    rng = np.random.default_rng(seed)
    space = {"rgb": ((size, size, 3), torch.uint8), "pointgoal": ((2,), torch.float32)}
    rollouts = RolloutStorage(steps, n, space, state_shape, 1)

    def obs() -> dict:
        return {"rgb": rng.integers(0, 256, (n, size, size, 3), dtype=np.uint8),
                "pointgoal": rng.normal(size=(n, 2)).astype(np.float32)}

    rollouts.set_first(obs(), torch.zeros(state_shape), torch.zeros(n, dtype=torch.long), torch.ones(n))
    for _ in range(steps):
        rollouts.insert(obs(), torch.as_tensor(rng.integers(0, 4, n)), torch.as_tensor(rng.normal(size=n) - 1.4),
                        torch.as_tensor(rng.normal(size=(n, 1))), rng.normal(size=(n, 1)), rng.random(n) < 1 / episode)
    rollouts.compute_returns(torch.as_tensor(rng.normal(size=(n, 1)), dtype=torch.float32), 0.99, 0.95)
    return rollouts


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--envs", type=int, default=8)
    p.add_argument("--steps", type=int, default=64, help="rollout length (ppo.num_steps)")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--backbone", default="resnet18")
    p.add_argument("--base-planes", type=int, default=32)
    p.add_argument("--epochs", type=int, default=4, help="ppo.ppo_epoch (scale=small: 4)")
    p.add_argument("--mini-batches", type=int, default=4, help="ppo.num_mini_batch (scale=small: 4)")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--repeats", type=int, default=2, help="timed rounds of each variant")
    p.add_argument("--compile", action="store_true", help="also with train.compile (the visual trunk compiled)")
    p.add_argument("--decoupled", action="store_true", help="also fp32 with ppo.decoupled (its proximal pass)")
    p.add_argument("--recompute", action="store_true",
                   help="also fp32 with ppo.recompute_advantages (its values pass, on a copy of the rollout)")
    p.add_argument("--unfused", action="store_true",
                   help="also fp32 with Adam's for-each step (rvn-rl's Adam is fused on CUDA)")
    p.add_argument("--cudnn-benchmark", action="store_true",
                   help="torch.backends.cudnn.benchmark for the whole run (its algorithm cache is shared by every "
                   "variant, so compare with a run without it)")
    p.add_argument("--no-bf16", action="store_true", help="float32 alone (a CPU without native bfloat16 emulates "
                   "it, ~16x slower)")
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    torch.backends.cudnn.benchmark = args.cudnn_benchmark
    from rvn_il.train.choices import fused_on
    from rvn_rl.model import PointNavResNetPolicy
    from rvn_rl.ppo import PPOConfig, ppo_update
    from rvn_rl.rollout import DeviceRollouts
    from rvn_rl.settings import TrainSettings
    from rvn_rl.trainer import _Evaluate, set_trunk

    dev, n, T = torch.device(args.device), args.envs, args.steps
    cfg = PPOConfig(ppo_epoch=args.epochs, num_mini_batch=args.mini_batches, num_steps=T,
                    use_normalized_advantage=True)  # scale=small's

    def learner(bf16: bool, compiled: bool, unfused: bool = False) -> tuple:
        torch.manual_seed(0)
        policy = PointNavResNetPolicy(obs_size=args.size, backbone=args.backbone, base_planes=args.base_planes,
                                      ngroups=min(16, args.base_planes // 2)).to(dev).train()
        # train.compile's default mode, reduce-overhead: CUDA graphs on a GPU, torch.compile's default on a CPU
        set_trunk(policy, TrainSettings(precision="bf16" if bf16 else "fp32", compile=compiled))
        fused = fused_on(dev) if not unfused else None  # rvn-rl's Adam: fused on CUDA (one kernel a step)
        return _Evaluate(policy), torch.optim.Adam(policy.parameters(), lr=cfg.lr, eps=cfg.eps, fused=fused)

    precisions = ["fp32"] + ([] if args.no_bf16 else ["bf16"])
    names = precisions + ([f"{p} compiled" for p in precisions] if args.compile else []) + (
        ["fp32 decoupled"] if args.decoupled else []) + (["fp32 recomputed"] if args.recompute else []) + (
        ["fp32 decoupled recomputed"] if args.decoupled and args.recompute else []) + (  # one pass serves both
        ["fp32 unfused"] if args.unfused else [])
    cfgs = {name: dataclasses.replace(cfg, decoupled="decoupled" in name, recompute_advantages="recomputed" in name)
            for name in names}
    learners = {name: learner("bf16" in name, "compiled" in name, "unfused" in name) for name in names}
    state_shape = tuple(learners["fp32"][0].policy.initial_state(n).shape)
    rollouts = filled_rollouts(n, T, args.size, state_shape)
    # ppo.recompute_advantages rewrites its rollout's values and returns: a copy of its own
    batches = {name: DeviceRollouts(copy.deepcopy(rollouts) if "recomputed" in name else rollouts, dev)
               for name in names}
    losses, first, best = {}, {}, {name: float("inf") for name in names}
    for i in range(args.repeats + 1):  # round 0: the same weights' first update (warm-up: compiling, cuDNN, allocator)
        for name, (evaluate, optimizer) in learners.items():
            t = time.perf_counter()
            gen = torch.Generator().manual_seed(i)
            out = ppo_update(evaluate, optimizer, batches[name], cfgs[name], gen)  # ends on a host read
            if i:
                best[name] = min(best[name], time.perf_counter() - t)
            else:  # said at once: a time limit that cuts a later compile keeps it
                losses[name], first[name] = out, time.perf_counter() - t
                print(f"  {name}: first update {first[name]:.1f} s", flush=True)
    where = torch.cuda.get_device_name(dev) + (", cudnn.benchmark" if args.cudnn_benchmark else "") \
        if dev.type == "cuda" else f"cpu, {args.threads} threads"
    print(f"One PPO update ({where}; {n} envs x {T} steps, {args.size}², {args.backbone} base {args.base_planes}, "
          f"{args.epochs} epochs x {args.mini_batches} mini-batches; best of {args.repeats}):")
    for name, sec in best.items():
        print(f"  {name:<25} {1000 * sec:9.1f} ms   learning alone allows {n * T / sec:8.0f} env steps/s   "
              f"x{best['fp32'] / sec:.2f}   (first update {first[name]:.1f} s)")
    for name in names[1:]:
        diff = ", ".join(f"{k} {losses['fp32'][k]:.4g} / {losses[name][k]:.4g}" for k in losses["fp32"])
        print(f"  first update's mean losses from the same weights, fp32 / {name}: {diff}")


if __name__ == "__main__":
    main()

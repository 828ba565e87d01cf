"""The PPO update's recurrent pass over rollouts in which envs restart episodes (issue 16's
collection + learning figure).

1. The policy's LSTM alone (2 layers, hidden 512, input 576; 2 envs x 64 steps, the small
   recipe's mini-batch): forward + backward with k restarts, run as one LSTM call per stretch
   between restarts (rvn-rl before 2026-11-25: the baseline), as a PackedSequence of episode
   pieces, and as one padded batch of pieces (what a PPO update now uses).
2. rvn-rl's own loop (``train()``) at the small recipe's settings (64x64, ResNet-18 at base width
   16, 8 envs, 64-step rollouts, 4 epochs x 4 mini-batches), once with the baseline patched in
   and once as it is: env steps/s of collection + learning, and the ratio.
3. ``--update``: one PPO update as rvn-rl runs it (`ppo_update` over `DeviceRollouts`: 4 epochs x 4 mini-batches of
   64-step rollouts, ResNet-18, restarts as a ~25-step episode makes them) with each mini-batch's plan of pieces
   (`recurrent.Pieces`, computed on the CPU), against the same update with the LSTM reading its masks on the host
   (three host-device waits a mini-batch on a GPU), alternated, best of ``--repeats``; ``--device cuda`` on a node.
Run: python benchmarks/rl_lstm.py [--threads 2] [--updates 3] [--update [--device cuda --envs 30 --size 128]]
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings

import torch
from torch import nn


def split_lstm(rnn, x, masks, h, c, need_state=True, pieces=None):
    """The baseline: one LSTM call per stretch between steps where any env restarts (a PPO update's plan of
    pieces unused)."""
    starts = [0] + [t for t in range(1, masks.size(0)) if bool((masks[t] == 0).any())] + [masks.size(0)]
    outs = []
    for a, b in zip(starts[:-1], starts[1:]):
        keep = masks[a].view(1, -1, 1)
        out, (h, c) = rnn(x[a:b], (h * keep, c * keep))
        outs.append(out)
    return torch.cat(outs), h, c


def best_ms(fn, repeats: int = 5) -> float:
    fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1000 * min(times)


def lstm_alone(restarts: list[int]) -> None:
    from rvn_rl.recurrent import run_lstm

    rnn = nn.LSTM(576, 512, num_layers=2)
    T, N = 64, 2
    g = torch.Generator().manual_seed(0)
    x = torch.randn(T, N, 576, generator=g, requires_grad=True)
    h, c = torch.zeros(2, N, 512), torch.zeros(2, N, 512)
    print(f"LSTM forward + backward, {N} envs x {T} steps (ms, best of 5):")
    print(f"  {'restarts':>8} {'per stretch':>12} {'packed':>8} {'padded':>8} {'ratio':>7}")
    for k in restarts:
        masks = torch.ones(T, N)
        masks.view(-1)[1 + torch.randperm(T * N - 1, generator=g)[:k]] = 0.0

        def run(fn, **kw):
            return lambda: fn(rnn, x, masks, h, c, **kw)[0].sum().backward()
        base, packed = best_ms(run(split_lstm)), best_ms(run(run_lstm))
        padded = best_ms(run(run_lstm, need_state=False))
        print(f"  {k:>8} {base:>12.0f} {packed:>8.0f} {padded:>8.0f} {base / padded:>6.2f}x")


def train_fps(args, baseline: bool) -> tuple[float, float]:
    import rvn_rl.model
    from rvn_rl.cli import compose
    from rvn_rl.recurrent import run_lstm
    from rvn_rl.trainer import train

    rvn_rl.model.run_lstm = split_lstm if baseline else run_lstm
    try:
        with tempfile.TemporaryDirectory() as tmp:
            cfg = compose(["scale=small", "env.size=64", "env.num_envs=8", "env.num_scenes=4", "env.goal_pool=64",
                           "model.backbone=resnet18", "model.base_planes=16", "model.ngroups=8", "ppo.num_steps=64",
                           "ppo.num_mini_batch=4", f"train.threads={args.threads}", "progress=false",
                           f"renderer={args.renderer}", f"out_dir={tmp}/run", "train.checkpoint_every=1000",
                           f"train.total_steps={(args.updates + 1) * 512}", "seed=0"])
            train(cfg)
            rows = [json.loads(line) for line in open(f"{tmp}/run/metrics.jsonl")]
    finally:
        rvn_rl.model.run_lstm = run_lstm
    timed = rows[1:]  # the first update includes scene loading
    # metrics.jsonl's episodes count the last 20 updates' (rvn_rl.runlog.RunLog): --updates is at most 18
    episodes = (rows[-1].get("episodes", 0) - rows[0].get("episodes", 0)) / len(timed)
    return 8 * 64 * len(timed) / sum(8 * 64 / r["fps"] for r in timed), episodes


def update_with_plans(args) -> None:
    from rl_learner import filled_rollouts
    from rvn_il.train.choices import fused_on
    from rvn_rl.model import PointNavResNetPolicy
    from rvn_rl.ppo import PPOConfig, ppo_update
    from rvn_rl.rollout import DeviceRollouts
    from rvn_rl.trainer import _Evaluate

    dev, T, N, size = torch.device(args.device), 64, args.envs, args.size
    torch.manual_seed(0)
    policy = PointNavResNetPolicy(obs_size=size, backbone="resnet18", base_planes=args.base_planes,
                                  ngroups=args.base_planes // 2).to(dev)
    learner = _Evaluate(policy)
    optimizer = torch.optim.Adam(policy.parameters(), lr=2.5e-4, eps=1e-5, fused=fused_on(dev))  # as rvn-rl's
    rollouts = filled_rollouts(N, T, size, tuple(policy.initial_state(N).shape))
    cfg = PPOConfig(ppo_epoch=4, num_mini_batch=4, num_steps=T, use_normalized_advantage=True)  # scale=small's
    gen = torch.Generator().manual_seed(0)
    planned = DeviceRollouts(rollouts, dev)
    variants = {"plans (now)": planned, "masks read on the host": DeviceRollouts(rollouts, dev, plans=False)}
    best = {k: float("inf") for k in variants}
    for i in range(args.repeats + 1):  # the first round warms up (cuDNN's choices, the allocator): not counted
        for name, batches in variants.items():
            t = time.perf_counter()
            ppo_update(learner, optimizer, batches, cfg, gen)  # ends reading its loss sums: the device has finished
            if i:
                best[name] = min(best[name], time.perf_counter() - t)
    restarts = int((rollouts.masks[1:T] == 0).sum())
    print(f"One PPO update on {dev.type} ({N} envs x {T} steps, {restarts} restarts, {size}², ResNet-18 base "
          f"{args.base_planes}, 4 x 4 mini-batches; ms, best of {args.repeats}):")
    base = best["masks read on the host"]
    for name, sec in best.items():
        print(f"  {name:<24} {1000 * sec:8.1f} ms   x{base / sec:.2f}")
    if dev.type == "cuda":  # the host's waits for the GPU, as torch's sync debug mode reports them
        for name, batches in variants.items():
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                torch.cuda.set_sync_debug_mode("warn")
                try:
                    ppo_update(learner, optimizer, batches, cfg, gen)
                finally:
                    torch.cuda.set_sync_debug_mode("default")
            waits = [w for w in caught if "synchroniz" in str(w.message)]
            print(f"  {name:<24} {len(waits)} synchronizing CUDA operations in one update")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--updates", type=int, default=3, choices=range(1, 19), metavar="1..18",
                   help="PPO updates timed per variant (after one warm-up)")
    p.add_argument("--renderer", default="auto")
    p.add_argument("--lstm-only", action="store_true")
    p.add_argument("--update", action="store_true", help="only section 3: the PPO update with and without plans")
    p.add_argument("--device", default="cpu", help="section 3's device")
    p.add_argument("--envs", type=int, default=8, help="section 3's envs")
    p.add_argument("--size", type=int, default=64, help="section 3's frame size")
    p.add_argument("--base-planes", type=int, default=16, help="section 3's ResNet width")
    p.add_argument("--repeats", type=int, default=3, help="section 3's timed rounds")
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    if args.update:
        update_with_plans(args)
        return
    lstm_alone([0, 2, 4, 8, 16, 32])
    if args.lstm_only:
        return
    base, eps = train_fps(args, baseline=True)
    now, _ = train_fps(args, baseline=False)
    print(f"rvn-rl collection + learning, small recipe (64x64, resnet18 base 16, 8 envs x 64 steps, 4 x 4 "
          f"mini-batches, {args.threads} threads; ~{eps:.0f} episodes per update):")
    print(f"  per-stretch LSTM (baseline): {base:6.1f} env steps/s")
    print(f"  padded episode pieces      : {now:6.1f} env steps/s   x{now / base:.2f}")


if __name__ == "__main__":
    main()

"""rvn-rl's act alone (issue 32's RL row): one batched act of the rollouts as `rvn_rl.collect` runs it (the
frames to the device, the policy's act under no_grad, the action, log-prob and values back to the host) on ``--envs``
random frames, plain, with the visual trunk compiled (``train.compile``, CUDA graphs; --compile, CUDA only) and
replayed as one CUDA graph (``train.graph_act``, `rvn_rl.graphed`; CUDA only). Prints each one's ms per act, the env
steps/s that acting alone would allow (envs / act seconds) and the ratio to the plain act; best of ``--repeats``
rounds of ``--acts`` acts after a warm-up round. Also checks that the graphed act drew the plain act's actions. With
``--workers`` (>= 2), also the acts as ``train.double_buffered`` runs them, one for each half of the envs
(`rvn_rl.vec_procs.halves`: 16 and 14 of 30 in 15 workers), plain and graphed: double buffering hides them behind the
other half's step, so it pays where the two halves' acts take less than a half's step.

On the fourth GPU run (H200) the plain act of 30 envs took ~7.9 ms, 1.8 ms of it kernels (host-bound), 4.3 ms with
the compiled trunk (docs/results/2026-12-04_gpu4): a third of scale=small's update time.
Run: python benchmarks/rl_act.py --device cuda [--envs 30 --size 128 --compile]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import torch


def timed(actor, frames: list[dict], device, state, acts: int, repeats: int, seed: int = 0) -> tuple[float, list]:
    """Best seconds per act over ``repeats`` rounds of ``acts`` acts (after one round of warm-up), and the actions of
    the last round (drawn from a generator of ``seed`` each round)."""
    from rvn_rl.rollout import to_device

    n = state.size(1)
    prev, masks = torch.zeros(n, dtype=torch.long), torch.ones(n)
    best, actions = float("inf"), []
    for r in range(repeats + 1):
        gen = torch.Generator(device=device).manual_seed(seed)
        actions, s = [], state
        t = time.perf_counter()
        for i in range(acts):
            with torch.no_grad():
                a, logp, v, s = actor.act(to_device(frames[i % len(frames)], device), s, prev.to(device),
                                          masks.to(device), generator=gen)
            actions.append(a.cpu().numpy())
            logp.cpu(), v.cpu()
        if r:  # round 0 warms up (cuDNN plans, the graph's recording, compiling)
            best = min(best, (time.perf_counter() - t) / acts)
    return best, actions


def timed_halves(actor, frames: list[dict], device, state, acts: int, repeats: int, halves: list[slice]) -> float:
    """Best seconds of one act for each of ``halves`` (in turn, as train.double_buffered acts), as `timed`."""
    parts = [[{k: v[h] for k, v in f.items()} for f in frames] for h in halves]
    sec = [timed(actor, part, device, state[:, h].contiguous(), acts, repeats)[0] for part, h in zip(parts, halves)]
    return sum(sec)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--envs", type=int, default=30)
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--backbone", default="resnet18")
    p.add_argument("--base-planes", type=int, default=32)
    p.add_argument("--acts", type=int, default=64, help="acts a round (a rollout of scale=small: 64)")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--threads", type=int, default=4)
    p.add_argument("--compile", action="store_true", help="also the compiled trunk (train.compile; CUDA graphs)")
    p.add_argument("--workers", type=int, default=0, help="also two halves' acts, as train.double_buffered splits "
                   "this many env workers (0: not; scale=small on a node: 15)")
    args = p.parse_args()
    for key in ("envs", "size", "acts", "repeats", "threads"):
        if getattr(args, key) < 1:
            p.error(f"--{key}={getattr(args, key)} must be >= 1")
    if args.workers and not 2 <= args.workers <= args.envs:
        p.error(f"--workers={args.workers}: two halves need 2 to --envs={args.envs} workers (or 0: not)")
    from rvn_rl.graphed import GraphedAct
    from rvn_rl.model import PointNavResNetPolicy
    from rvn_rl.vec_procs import halves, worker_bounds

    torch.set_num_threads(args.threads)
    device = torch.device(args.device)
    cuda = device.type == "cuda"
    torch.manual_seed(0)
    policy = PointNavResNetPolicy(args.size, args.backbone, args.base_planes, input_size=args.size).to(device).eval()
    rng = np.random.default_rng(0)
    frames = [{"rgb": rng.integers(0, 256, (args.envs, args.size, args.size, 3), dtype=np.uint8),
               "pointgoal": rng.normal(size=(args.envs, 2)).astype(np.float32)} for _ in range(8)]
    state = policy.initial_state(args.envs, device)
    name = torch.cuda.get_device_name(device) if cuda else "CPU"
    print(f"One batched act ({name}; {args.envs} envs, {args.size}², {args.backbone} base {args.base_planes}, "
          f"{args.threads} threads; best of {args.repeats} rounds of {args.acts}):")
    plain, want = timed(policy, frames, device, state, args.acts, args.repeats)

    def line(what: str, sec: float) -> None:
        print(f"  {what:<30} {1e3 * sec:7.2f} ms   acting alone allows {args.envs / sec:8.0f} env steps/s   "
              f"x{plain / sec:.2f}")
    line("plain", plain)
    split = halves(worker_bounds(args.envs, args.workers)) if args.workers else None
    sizes = "" if split is None else " + ".join(str(h.stop - h.start) for h in split)
    if split is not None:
        line(f"two halves' acts ({sizes})", timed_halves(policy, frames, device, state, args.acts, args.repeats, split))
    if not cuda:
        print("  graphed (train.graph_act)      skipped: CUDA graphs need a GPU (on a CPU it acts as plain)")
        return
    graphed = GraphedAct(policy)
    sec, got = timed(graphed, frames, device, state, args.acts, args.repeats)
    line("graphed (train.graph_act)", sec)
    if split is not None:
        line(f"graphed, two halves ({sizes})", timed_halves(graphed, frames, device, state, args.acts, args.repeats,
                                                             split))
    if not graphed.graphs:
        print("  the graph's recording FAILED (the warning above): the graphed line's acts ran one kernel at a time")
    same = sum(np.array_equal(a, b) for a, b in zip(want, got))
    print(f"  graphed acts with the plain act's actions: {same} of {len(want)}")
    if args.compile:
        policy.compile_visual("reduce-overhead")
        t = time.perf_counter()
        sec, _ = timed(policy, frames, device, state, args.acts, args.repeats)
        line("compiled trunk (train.compile)", sec)
        print(f"  (compiling and timing took {time.perf_counter() - t:.0f} s)")


if __name__ == "__main__":
    main()

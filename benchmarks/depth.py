"""Depth model inference speed: frames/s of `rvn_rl.depth.load_depth_model`'s predictor
(uint8 RGB in, metres out, frozen, no gradients) at 128x128, batch 4, on the CPU (or
--device cuda), with 1 torch thread (the predictor's default) and with every core.

The predictor is what algo=ddppo_depth calls once per environment step batch, so its
frames/s bounds the RL collection speed with predicted depth. Without --model the default
architecture is timed with untrained weights (same cost). The machine is shared with other
jobs: the figures are as measured, and the load average is printed beside them.
Run: python benchmarks/depth.py [--model /work/runs/depth_small] [--frames 400]
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np


def frames_per_s(predictor, batch: int, size: int, frames: int, seed: int = 0) -> float:
    rng = np.random.default_rng(seed)
    rgb = rng.integers(0, 256, (batch, size, size, 3), dtype=np.uint8)
    for _ in range(3):  # warm-up
        predictor(rgb)
    calls = max(1, frames // batch)
    t0 = time.perf_counter()
    for _ in range(calls):
        predictor(rgb)
    return calls * batch / (time.perf_counter() - t0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default=None, help="a depth run's out_dir (default: untrained default architecture)")
    ap.add_argument("--size", type=int, default=128, help="frame width = height")
    ap.add_argument("--batch", type=int, default=4)
    ap.add_argument("--frames", type=int, default=400, help="frames per figure")
    ap.add_argument("--device", default="cpu")
    args = ap.parse_args()

    import torch

    from rvn_rl.depth import DepthNet, DepthPredictor, load_depth_model

    if args.model:
        predictor = load_depth_model(args.model, device=args.device, threads=None)
    else:
        predictor = DepthPredictor(DepthNet(), image_size=args.size, device=args.device, threads=None)
    params = sum(p.numel() for p in predictor.net.parameters())
    print(f"Depth model inference, {args.size}x{args.size}, batch {args.batch}, {params:,} parameters, "
          f"model {args.model or 'untrained default'}, device {args.device}")
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} cores "
          "(shared machine: figures as measured)")
    counts = [1, os.cpu_count() or 1] if args.device == "cpu" else [torch.get_num_threads()]
    for threads in dict.fromkeys(counts):
        torch.set_num_threads(threads)
        fps = frames_per_s(predictor, args.batch, args.size, args.frames)
        print(f"  threads={threads}: {fps:8.1f} frames/s  ({1000 * args.batch / fps:.1f} ms per batch)")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Training and evaluation of the depth model on (RGB, depth) pairs.

Loss on valid pixels (depth > 0), with g = log(predicted) - log(true) per image:
``silog_weight * sqrt(mean(g^2) - variance_focus * mean(g)^2) + l1_weight * mean(|g|)``;
the first term is the scale-invariant log loss (shape), the second anchors the metric
scale. Adam with a linear warm-up and cosine decay; horizontal flips as augmentation
(a flipped frame is a valid view). Batches are drawn with a torch Generator from the seed.

Metrics (`depth_metrics`), computed per image over its valid pixels and averaged over
images: ``absrel`` = mean |d - d*| / d*, ``delta1`` = share of pixels with
max(d/d*, d*/d) < 1.25, ``rmse`` (m), ``log_rmse``. Baselines (`baseline_metrics`): a
constant depth (the training pixels' median) and a per-pixel median over the training
frames (what the fixed camera height alone predicts).
"""
from __future__ import annotations

import math

import numpy as np
import torch

from .model import DepthNet, to_input
from .settings import TrainSettings  # the ``train`` group

DELTA = 1.25


def depth_loss(log_pred: torch.Tensor, depth: torch.Tensor, s: TrainSettings) -> torch.Tensor:
    """The training loss of log-depth predictions [N,H,W] against depth [N,H,W] (0 = invalid)."""
    valid = depth > 0
    g = torch.where(valid, log_pred - torch.log(depth.clamp_min(1e-6)), torch.zeros_like(log_pred))
    n = valid.flatten(1).sum(1).clamp_min(1)
    mean_g = g.flatten(1).sum(1) / n
    mean_g2 = (g * g).flatten(1).sum(1) / n
    silog = torch.sqrt((mean_g2 - s.variance_focus * mean_g * mean_g).clamp_min(1e-8))
    l1 = g.abs().flatten(1).sum(1) / n
    keep = valid.flatten(1).any(1).float()
    return ((s.silog_weight * silog + s.l1_weight * l1) * keep).sum() / keep.sum().clamp_min(1)


def lr_at(step: int, s: TrainSettings) -> float:
    if step < s.warmup:
        return s.lr * (step + 1) / s.warmup
    t = (step - s.warmup) / max(1, s.steps - s.warmup)
    return 0.5 * s.lr * (1.0 + math.cos(math.pi * min(1.0, t)))


def depth_metrics(pred: np.ndarray, depth: np.ndarray) -> dict:
    """AbsRel, delta1, RMSE, log RMSE of predictions [N,H,W] against depth [N,H,W] (0 = invalid)."""
    rows = []
    for p, d in zip(pred, depth):
        valid = d > 0
        if not valid.any():
            continue
        p, d = np.maximum(p[valid].astype(np.float64), 1e-6), d[valid].astype(np.float64)
        ratio = np.maximum(p / d, d / p)
        rows.append((np.mean(np.abs(p - d) / d), np.mean(ratio < DELTA), math.sqrt(np.mean((p - d) ** 2)),
                     math.sqrt(np.mean((np.log(p) - np.log(d)) ** 2))))
    if not rows:
        raise ValueError("no valid depth pixels to evaluate (every depth is 0)")
    a = np.mean(rows, axis=0)
    return {"absrel": float(a[0]), "delta1": float(a[1]), "rmse": float(a[2]), "log_rmse": float(a[3]),
            "frames": len(rows)}


def median_depth(depth: np.ndarray) -> float:
    valid = depth[depth > 0]
    if valid.size == 0:
        raise ValueError("the training pairs have no valid depth pixels")
    return float(np.median(valid))


def baseline_metrics(train_depth: np.ndarray, val_depth: np.ndarray) -> dict:
    """Metrics on ``val_depth`` of the constant training median and the per-pixel training median."""
    const = np.full(val_depth.shape, median_depth(train_depth), np.float32)
    masked = np.where(train_depth > 0, train_depth, np.nan)
    per_pixel = np.nan_to_num(np.nanmedian(masked, axis=0), nan=median_depth(train_depth)).astype(np.float32)
    return {"constant_median": depth_metrics(const, val_depth),
            "pixel_median": depth_metrics(np.broadcast_to(per_pixel, val_depth.shape), val_depth)}


def predict(net: DepthNet, rgb: np.ndarray, batch_size: int = 32) -> np.ndarray:
    """Depth (metres) of uint8 frames [N,H,W,3] with ``net`` in eval mode (restored after)."""
    was_training = net.training
    net.eval()
    out = []
    with torch.no_grad():
        for i in range(0, len(rgb), batch_size):
            out.append(net(to_input(rgb[i:i + batch_size])).exp().numpy())
    net.train(was_training)
    return np.concatenate(out).astype(np.float32)


def evaluate(net: DepthNet, rgb: np.ndarray, depth: np.ndarray) -> dict:
    return depth_metrics(predict(net, rgb), depth)


def train_depth(net: DepthNet, rgb: np.ndarray, depth: np.ndarray, s: TrainSettings, seed: int,
                val: tuple[np.ndarray, np.ndarray] | None = None, progress: bool = False) -> list[dict]:
    """Train ``net`` in place for ``s.steps`` steps; returns the log (loss, and val metrics
    every ``s.eval_every`` steps when ``val`` is given)."""
    from tqdm import tqdm

    gen = torch.Generator().manual_seed(int(seed))
    opt = torch.optim.AdamW(net.parameters(), lr=s.lr, weight_decay=s.weight_decay)
    rgb_t, depth_t = torch.from_numpy(rgb), torch.from_numpy(depth)
    log, running = [], None
    net.train()
    bar = tqdm(range(s.steps), desc="train depth", unit="step", disable=not progress)
    for step in bar:
        idx = torch.randint(len(rgb_t), (s.batch_size,), generator=gen)
        x, d = to_input(rgb_t[idx]), depth_t[idx]
        if s.flip:
            flip = torch.rand(len(idx), generator=gen) < 0.5
            x = torch.where(flip[:, None, None, None], x.flip(-1), x)
            d = torch.where(flip[:, None, None], d.flip(-1), d)
        for group in opt.param_groups:
            group["lr"] = lr_at(step, s)
        loss = depth_loss(net(x), d, s)
        if not torch.isfinite(loss):
            raise ValueError(f"depth training diverged at step {step} (loss {loss.item()}); lower train.lr")
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        running = loss.item() if running is None else 0.95 * running + 0.05 * loss.item()
        bar.set_postfix(loss=f"{running:.3f}", refresh=False)
        row = {"step": step + 1, "loss": loss.item()}
        if val is not None and s.eval_every and (step + 1) % s.eval_every == 0 and step + 1 < s.steps:
            row["val"] = evaluate(net, *val)
            net.train()
        log.append(row)
    net.eval()
    return log

"""A member's optimisation state for rvn-train: the network (compiled with ``train.compile``), AdamW, the
warm-up + cosine schedule and the EMA (`optimisation`); resuming them from a checkpoint (`resume`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import torch
from safetensors.torch import load_file

from ..models import build_model
from ..models.checkpoint import latest_checkpoint, load_state_dict_checked, read_weights
from ..models.compiled import compile_for_training
from .choices import fused_on, load_optimizer_state, training_compile_mode
from .ema import EMA


def lr_lambda(warmup: int, max_steps: int):
    """Linear warm-up over ``warmup`` steps, then cosine decay to 0 at ``max_steps``."""
    def f(step: int) -> float:
        if step < warmup:
            return (step + 1) / warmup
        progress = (step - warmup) / max(1, max_steps - warmup)
        return 0.5 * (1.0 + math.cos(math.pi * min(1.0, progress)))
    return f


@dataclass
class Optimisation:
    """A member's network and its optimiser state (`optimisation`, `resume`)."""

    model: torch.nn.Module
    opt: torch.optim.Optimizer
    sched: torch.optim.lr_scheduler.LambdaLR
    ema: EMA | None
    batch_size: int
    max_steps: int
    step: int = 0
    # train.compile_mode=reduce-overhead on a GPU (auto's choice there with one rank): the compiled parts replay as
    # CUDA graphs, whose outputs the next replay overwrites, so each training step says it begins (`train_loop`)
    cuda_graphs: bool = False


def optimisation(model_cfg: Mapping, tcfg: Mapping, dataset, world: int, device: torch.device) -> Optimisation:
    """The member's network (NoMaD's action_stats from its data; compiled with train.compile), AdamW (fused on
    CUDA: one kernel per step instead of one per tensor group), the warm-up + cosine schedule, EMA."""
    model = build_model(model_cfg).to(device).use_channels_last()
    if model_cfg.get("action_stats") == "auto":  # NoMaD: delta range of this member's data
        lo, hi = dataset.delta_range()
        model.action_min.copy_(torch.from_numpy(lo).float())
        model.action_max.copy_(torch.from_numpy(hi).float())
    bs = int(tcfg["batch_size"] or model_cfg["batch_size"])
    lr = float(tcfg["lr"] or model_cfg["lr"])
    use_ema = model_cfg.get("ema", False) if tcfg["ema"] is None else bool(tcfg["ema"])
    steps_per_epoch = max(1, len(dataset) // (bs * world))
    max_steps = int(tcfg["max_steps"] if tcfg["max_steps"] is not None else int(tcfg["epochs"]) * steps_per_epoch)
    given = tcfg["warmup_steps"]  # 0: no warm-up (it took warmup_frac's 4 % instead)
    warmup = int(given) if given is not None else round(float(tcfg["warmup_frac"]) * max_steps)
    for key, value in (("train.batch_size", bs), ("train.max_steps", max_steps), ("train.lr", lr)):
        if not value > 0:
            raise ValueError(f"{key}={value} must be positive")
    opt = torch.optim.AdamW(model.parameters(), lr=lr, weight_decay=float(tcfg["weight_decay"]), fused=fused_on(device))
    sched = torch.optim.lr_scheduler.LambdaLR(opt, lr_lambda(max(1, warmup), max_steps))
    ema = EMA(model, float(model_cfg.get("ema_power", 0.75))) if use_ema else None
    mode = training_compile_mode(tcfg["compile_mode"], device.type, world) if tcfg["compile"] else None
    if mode is not None:
        compile_for_training(model, mode)
    return Optimisation(model, opt, sched, ema, bs, max_steps,
                        cuda_graphs=mode == "reduce-overhead" and device.type == "cuda")


def resume(run: Optimisation, member_dir: Path, model_cfg: Mapping, device: torch.device) -> None:
    """Continue from the member's latest checkpoint, if any: weights, optimiser, schedule, EMA, step."""
    ckpt = latest_checkpoint(member_dir)
    if ckpt is None:
        return
    load_state_dict_checked(run.model, read_weights(ckpt, model_cfg["name"], prefer_ema=False), ckpt)
    state = torch.load(ckpt / "state.pt", map_location=device, weights_only=False)
    load_optimizer_state(run.opt, state["optimizer"], device)
    run.sched.load_state_dict(state["scheduler"])
    if run.ema is not None and state.get("ema"):
        run.ema.load_state_dict(state["ema"], load_file(str(ckpt / "ema.safetensors"), device=str(device)))
    run.step = int(state["step"])

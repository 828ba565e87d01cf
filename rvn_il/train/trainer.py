"""Training loop of rvn-train (AdamW, warm-up + cosine schedule and EMA: `.optimisation`): TensorBoard
scalars, tqdm, atomic checkpoints with exact resume, DDP under torchrun.

Randomness: model init from ``[seed, member]``; data order and per-item draws from
:class:`EpochSampler`/``GNMDataset`` (``[seed, epoch]``, ``[seed, index]``); diffusion noise,
timesteps and dropout are re-seeded every step from ``[seed, member, rank, step]``. Nothing
depends on process history, so a resumed run continues exactly as an uninterrupted one.
"""
from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import numpy as np
import torch
import torch.distributed as dist
from torch.utils.data import BatchSampler, DataLoader
from tqdm import tqdm

from ..data import (BatchView, EpochSampler, MixtureDataset, crop_setting, depth_seed, entry_settings, make_depth_frames,
                    make_training_data, recorded_hfov)
from ..data.report import dataset_report
from ..data.sources import ignored_official_keys
from rvn_data.benchmark.trained_scenes import shown_names
from rvn_data.cache_root import cache_root, keep_compiled_kernels
from rvn_data.provenance import provenance_record
from ..models import resolve_size
from ..models.checkpoint import read_config, save_checkpoint, write_config
from ..models.encoders import IMAGENET_MEAN, IMAGENET_STD
from .adopt import adopt_expert
from .optimisation import Optimisation, optimisation, resume
from .preflight import data_roots, member_entries, preflight, val_training_scenes
from .settings import complete_config
from .validate import Validator

log = logging.getLogger(__name__)


def derive_seed(*ints: int) -> int:
    return int(np.random.SeedSequence([int(i) for i in ints]).generate_state(1, np.uint64)[0] >> 1)


def _dist_info() -> tuple[int, int, int]:
    world = int(os.environ.get("WORLD_SIZE", 1))
    if world > 1 and not dist.is_initialized():
        dist.init_process_group("nccl" if torch.cuda.is_available() else "gloo")
    rank = dist.get_rank() if world > 1 else 0
    return rank, world, int(os.environ.get("LOCAL_RANK", 0))


def built_by_rank_0(make: Callable[[bool], Any], rank: int, world: int) -> Any:
    """``make(build=True)`` on rank 0 (writes the packed cache), then, after a barrier, ``make(build=False)``
    on the other ranks (only open it)."""
    out = make(True) if rank == 0 else None
    if world > 1:
        dist.barrier()
    return out if rank == 0 else make(False)


def run_training(cfg: Mapping[str, Any], on_checked: Callable[[dict], None] | None = None) -> Path:
    """Train every member of ``cfg['model']`` into ``cfg['out_dir']``; returns the out_dir.
    ``cfg`` is rvn-train's config (`rvn_il.train.settings.TrainConfig`); what it leaves out
    takes the schema's default. Every path and setting is checked first (`preflight`:
    `ConfigError`, nothing written); then ``on_checked(cfg)`` runs, before anything is written."""
    cfg = complete_config(cfg)
    rank, world, local_rank = _dist_info()
    device, record, agent, overrides = preflight(cfg)
    cfg["agent"] = agent
    if record is not None:
        cfg["embodiment"] = {**record, "agent": {**record["agent"], **{k: agent[k] for k in record["agent"]}}}
        if overrides:
            cfg["embodiment"]["overrides"] = overrides
    if device.type == "cuda" and world > 1:
        device = torch.device("cuda", local_rank)
        torch.cuda.set_device(device)
    out_dir = Path(cfg["out_dir"]).expanduser()
    roots = data_roots(cfg)
    if on_checked is not None:
        on_checked(cfg)
    if rank == 0 and cfg["data"]["official_config"]:
        ignored = ignored_official_keys(cfg["data"]["official_config"])
        if ignored:
            log.warning("data.official_config: %s read but not applied (goals_per_obs: unused by the official ViNT_Dataset; "
                        "negative_mining: the image-goal distance head, which PointGoal models lack)", ", ".join(ignored))
    for o in overrides if rank == 0 else ():
        log.warning("%s=%s overrides the data's %s (%s): the checkpoint records both", o["setting"], o["given"], o["data"],
                    cfg["data"]["root"])
    shared = val_training_scenes(cfg) if rank == 0 else []
    if shared:
        log.warning("data.val_root=%s holds %d scene(s) of the training data (%s): validation on them is not held out; "
                    "generate it on other scenes (rvn-gen split=val)", cfg["data"]["val_root"], len(shared),
                    shown_names(shared))
    if rank == 0:
        resuming = any((out_dir / m / "latest").is_file() for m in ("model", "expert", "negative"))
        earlier = read_config(out_dir) if resuming and (out_dir / "config.yaml").is_file() else None
        write_config(out_dir, {**cfg, **provenance_record(earlier, resuming)})
    entries = member_entries(cfg)
    for index, member in enumerate(roots):
        train_member(cfg, member, index, entries.get(member, []), out_dir, device, rank, world)
    if world > 1:
        dist.barrier()
        dist.destroy_process_group()
    return out_dir


def train_member(cfg: Mapping, member: str, index: int, entries: list[dict], out_dir: Path, device: torch.device,
                 rank: int, world: int) -> None:
    """Train (or, for NoMaD_e with train.expert_from, adopt) one member from its datasets ``entries``."""
    model_cfg, data_cfg, tcfg, seed = resolve_size(cfg["model"]), dict(cfg["data"]), dict(cfg["train"]), int(cfg["seed"])
    if member == "expert" and tcfg["expert_from"]:  # NoMaD_e = a finished NoMaD-PointGoal run (adopt.py)
        if rank == 0:
            adopt_expert(tcfg["expert_from"], out_dir / member, model_cfg,
                         {"model": model_cfg["name"], "image_size": list(model_cfg["image_size"]),
                          "crop": crop_setting(data_cfg, model_cfg),
                          "context_size": model_cfg["context_size"], "len_traj_pred": model_cfg["len_traj_pred"]},
                         tcfg.get("expert_step"))
        if world > 1:
            dist.barrier()
        return
    data_cfg["progress"] = rank == 0
    data_cfg["cache_dir"] = str(data_cfg["cache_dir"] or cache_root(cfg["cache_dir"], out_dir) / "packed")
    if tcfg["compile"]:
        keep_compiled_kernels(cache_root(cfg["cache_dir"], out_dir))
    root = entries[0]["root"]  # the first dataset is the deployment robot's (its spacing, hfov, embodiment)
    dataset = built_by_rank_0(lambda build: make_training_data(entries, model_cfg, data_cfg, seed, build=build), rank, world)
    report = dataset_report(dataset, entries) if rank == 0 else None
    if report is not None:
        log.info("%s/%s datasets:\n%s", model_cfg["name"], member, report["text"])
    depth_frames = None
    if data_cfg["depth_root"]:  # frames for the depth head alone (rvn_il/data/depth_frames.py)
        depth_frames = built_by_rank_0(lambda build: make_depth_frames(data_cfg["depth_root"], model_cfg, data_cfg, build),
                                       rank, world)
    torch.manual_seed(derive_seed(seed, index))
    run = optimisation(model_cfg, tcfg, dataset, world, device)
    if tcfg["resume"]:
        resume(run, out_dir / member, model_cfg, device)
    if rank == 0:
        log.info("%s/%s: %d samples from %s, batch %d x %d, steps %d/%d, device %s", model_cfg["name"], member,
                 len(dataset), root, run.batch_size, world, run.step, run.max_steps, device)
        if depth_frames is not None:
            log.info("depth head also on %d frames of %s, %d per step", len(depth_frames), data_cfg["depth_root"],
                     int(data_cfg["depth_batch"]))
    if run.step >= run.max_steps:
        return
    crop = crop_setting(entry_settings(entries[0], data_cfg), model_cfg)  # the policy's, so validation's too
    stats = {"model": model_cfg["name"], "member": member, "metric_waypoint_spacing": dataset.spacing,
             "action_stats": {"min": run.model.action_min.tolist(), "max": run.model.action_max.tolist()}
             if hasattr(run.model, "action_min") else None, "image_size": list(model_cfg["image_size"]),
             "crop": crop, "context_size": model_cfg["context_size"],
             "len_traj_pred": model_cfg["len_traj_pred"], "imagenet_mean": IMAGENET_MEAN, "imagenet_std": IMAGENET_STD,
             "dataset": str(Path(root).expanduser().resolve()), "num_samples": len(dataset),
             "hfov_deg": recorded_hfov(root, dataset.cache.names[0])}  # for policy.depth_veto_rule=swept
    if isinstance(dataset, MixtureDataset) and report is not None:
        stats["datasets"] = report["datasets"]
    validator = None
    if rank == 0 and data_cfg["val_root"] and member != "negative":  # NoMaD_n imitates collisions: no agreement
        validator = Validator(data_cfg["val_root"], model_cfg, {**data_cfg, "crop": crop}, tcfg, cfg["agent"], seed,
                              run.batch_size, dataset.spacing, out_dir / member / "val.json")
    batches = training_batches(dataset, depth_frames, data_cfg, seed, rank, world, run.step, run.batch_size, device)
    train_loop(run, batches, stats, validator, tcfg, f"{model_cfg['name']}/{member}", out_dir / member,
               (seed, index, rank, world), device)


def training_batches(dataset, depth_frames, data_cfg: Mapping, seed: int, rank: int, world: int, step: int, bs: int,
                     device: torch.device) -> Iterator[dict]:
    """The batches from ``step`` on (sample order from the seed and the position alone), with the depth head's
    frames of ``data.depth_root`` added to each."""
    workers = int(data_cfg["num_workers"])
    order = dataset.sampler(seed, rank, world, step * bs) if isinstance(dataset, MixtureDataset) \
        else EpochSampler(len(dataset), seed, rank, world, step * bs)
    loader = DataLoader(BatchView(dataset), batch_size=None, sampler=BatchSampler(order, bs, drop_last=True),
                        num_workers=workers, pin_memory=device.type == "cuda", persistent_workers=workers > 0,
                        prefetch_factor=4 if workers > 0 else None)
    depth_batches = None
    if depth_frames is not None:
        fb = int(data_cfg["depth_batch"])
        depth_batches = iter(DataLoader(depth_frames, batch_size=None, pin_memory=device.type == "cuda",
                                        sampler=BatchSampler(EpochSampler(len(depth_frames), depth_seed(seed), rank, world,
                                                                          step * fb), fb, drop_last=True)))
    for batch in loader:
        if depth_batches is not None:
            batch.update(next(depth_batches))
        yield batch


def check_finite(pending: list[tuple[int, torch.Tensor]], label: str) -> None:
    """A ValueError naming the first step of ``pending`` whose loss is not finite (one host sync for all); empties it."""
    finite = torch.isfinite(torch.stack([loss for _, loss in pending])).tolist()
    steps = [s for s, _ in pending]
    pending.clear()
    if not all(finite):
        raise ValueError(f"non-finite loss at step {steps[finite.index(False)]} of {label}; lower train.lr or check the data")


def check_weights(model: torch.nn.Module, step: int, label: str) -> None:
    """A ValueError naming the first weight that is not finite (one host sync), before a checkpoint is written: a
    step whose loss was finite can still overflow a gradient, and its checkpoint would become ``latest``, the one a
    resume continues from, while the last good one is pruned two saves later."""
    floats = [(k, v) for k, v in model.state_dict().items() if v.is_floating_point()]
    finite = torch.stack([torch.isfinite(v).all() for _, v in floats]).tolist()
    if not all(finite):
        raise ValueError(f"non-finite weight {floats[finite.index(False)][0]} after step {step} of {label}, not saved "
                         "(a gradient overflowed with a finite loss); lower train.lr or check the data")


def train_loop(run: Optimisation, batches: Iterator[dict], stats: dict, validator, tcfg: Mapping, label: str,
               member_dir: Path, ids: tuple[int, int, int, int], device: torch.device) -> None:
    """Optimise until ``run.max_steps``: per-step seeds from ``[seed, index, rank, step]``, TensorBoard scalars,
    validation and atomic checkpoints (rank 0)."""
    seed, index, rank, world = ids
    model, step, max_steps = run.model, run.step, run.max_steps
    net = model
    if world > 1:
        net = torch.nn.parallel.DistributedDataParallel(model, device_ids=[device.index] if device.type == "cuda" else None)
    writer = None
    if rank == 0:
        from torch.utils.tensorboard import SummaryWriter
        writer = SummaryWriter(str(member_dir.parent / "tb" / member_dir.name), purge_step=step)
    val_every, bf16 = int(tcfg["val_every"]), tcfg["precision"] == "bf16"
    # the compiled parts replayed as CUDA graphs (`Optimisation.cuda_graphs`): each step says it begins (its outputs are
    # all read within the step: losses are eager)
    graphs = run.cuda_graphs
    gen = torch.Generator(device=device)
    log_every, ckpt_every = int(tcfg["log_every"]), int(tcfg["ckpt_every"])
    net.train()
    pending: list[tuple[int, torch.Tensor]] = []  # (step, loss) checked together: no host sync every step
    bar = tqdm(total=max_steps, initial=step, desc=label, disable=rank != 0, mininterval=float(tcfg["tqdm_interval"]))
    try:
        for batch in batches:
            if graphs:
                torch.compiler.cudagraph_mark_step_begin()
            batch = {k: v.to(device, non_blocking=True) for k, v in batch.items()}
            gen.manual_seed(derive_seed(seed, index, rank, step))
            torch.manual_seed(derive_seed(seed, index, rank, step, 1))
            with torch.autocast(device.type, dtype=torch.bfloat16, enabled=bf16):
                losses = net(batch, gen)
            pending.append((step, losses["loss"].detach()))
            run.opt.zero_grad(set_to_none=True)
            losses["loss"].backward()
            if tcfg["grad_clip"]:
                torch.nn.utils.clip_grad_norm_(model.parameters(), float(tcfg["grad_clip"]))
            run.opt.step()
            run.sched.step()
            step += 1
            if run.ema is not None:
                run.ema.update(model)
            bar.update(1)
            if step % log_every == 0 or step % val_every == 0 or step % ckpt_every == 0 or step >= max_steps:
                check_finite(pending, label)  # before anything is logged, validated or saved
            if writer is not None and (step % log_every == 0 or step == max_steps):
                for k, v in losses.items():
                    writer.add_scalar(f"train/{k}", float(v.detach()), step)
                writer.add_scalar("train/lr", run.sched.get_last_lr()[0], step)
                bar.set_postfix(loss=f"{float(losses['loss'].detach()):.4f}")
            if validator is not None and (step % val_every == 0 or step >= max_steps):
                validator(model, run.ema.shadow if run.ema is not None else None, step, writer)
            if step % ckpt_every == 0 or step >= max_steps:
                check_weights(model, step, label)  # every rank: their weights are the same, so all of them stop
                if rank == 0:
                    state = {"step": step, "optimizer": run.opt.state_dict(), "scheduler": run.sched.state_dict(),
                             "ema": run.ema.state_dict() if run.ema is not None else None, "max_steps": max_steps}
                    save_checkpoint(member_dir, step, model.state_dict(), {**stats, "step": step}, state,
                                    run.ema.shadow if run.ema is not None else None, int(tcfg["keep_checkpoints"]))
            if step >= max_steps:
                break
    finally:
        bar.close()
        if writer is not None:
            writer.close()

"""NoMaD-Neg's NoMaD_e taken from a trained NoMaD-PointGoal run (``train.expert_from``; its latest checkpoint, or the
kept one after ``train.expert_step`` steps).

NoMaD_e is a NoMaD-PointGoal network trained on expert data (the paper's NoMaD-Neg), so a
finished NoMaD-PointGoal run can serve as NoMaD_e instead of a second expert training (the
longest step of a small experiment). The paper's NoMaD_e sees 93.75 % of the expert
trajectories (the rest are replaced by negatives); an adopted one saw all of them. The
adoption is recorded in the copied checkpoint's ``stats.json`` (``adopted_from``).
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Mapping

from safetensors.torch import load_file

from ..data.images import crop_setting
from ..models import build_model
from ..models.checkpoint import (checked_step, checkpoint_of, latest_checkpoint, load_state_dict_checked, read_config,
                                 read_stats, read_weights, save_checkpoint)

log = logging.getLogger(__name__)
SAME = ("image_size", "crop", "context_size", "len_traj_pred", "metric_waypoint_spacing")


def expert_source(source: str | Path, model_cfg: Mapping, step: int | None = None) -> Path:
    """The latest checkpoint of the finished NoMaD-PointGoal run ``source`` (``train.expert_from``), or its kept
    checkpoint after ``step`` steps (``train.expert_step``); a ValueError naming the setting when there is none or it
    cannot serve as NoMaD_e."""
    if checked_step(step, "train.expert_step", "train.expert_from's model") is not None and not source:
        raise ValueError(f"train.expert_step={step} needs train.expert_from (the NoMaD-PointGoal run whose checkpoint "
                         "to adopt as NoMaD_e)")
    src_dir = Path(source).expanduser()
    if not src_dir.exists():
        raise ValueError(f"train.expert_from={source} does not exist; pass the out_dir of a finished "
                         "rvn-train model=nomad_pointgoal run, or leave train.expert_from unset")
    src_model = read_config(src_dir)["model"]
    name = src_model["name"]
    if name != "nomad_pointgoal":
        raise ValueError(f"train.expert_from={source} holds a {name!r} run; NoMaD_e must come from a nomad_pointgoal run")
    theirs, ours = src_model.get("prediction_type", "epsilon"), model_cfg.get("prediction_type", "epsilon")
    if theirs != ours:
        raise ValueError(f"train.expert_from={source} was trained with model.prediction_type={theirs}, this run has "
                         f"{ours}; set model.prediction_type={theirs}")
    ckpt = checkpoint_of(src_dir / "model", step, "train.expert_step")  # step None: the latest, None when none yet
    if ckpt is None:
        raise ValueError(f"train.expert_from={source} has no finished checkpoint (no {src_dir / 'model' / 'latest'}); "
                         "train it first")
    return ckpt


def adopted_before(member_dir: Path, ckpt: Path) -> Path | None:
    """NoMaD-Neg's ``expert`` checkpoint in ``member_dir`` when it was adopted from ``ckpt`` (a rerun), None when there
    is none yet; a ValueError when it holds another NoMaD_e (trained, or adopted from another run or step)."""
    mine = latest_checkpoint(member_dir)
    if mine is None or read_stats(mine).get("adopted_from") == str(ckpt.resolve()):
        return mine
    raise ValueError(f"{member_dir} already holds a NoMaD_e checkpoint that is not {ckpt}; choose another out_dir=, or "
                     "the train.expert_from (and train.expert_step) it was made with")


def adopt_expert(source: str | Path, member_dir: Path, model_cfg: Mapping, stats: Mapping,
                 step: int | None = None) -> Path:
    """Copy the latest checkpoint of the NoMaD-PointGoal run ``source`` (its kept one after ``step`` steps) into
    ``member_dir`` (NoMaD-Neg's ``expert``) unless that already holds it; returns the adopted checkpoint."""
    ckpt = expert_source(source, model_cfg, step)
    mine = adopted_before(member_dir, ckpt)
    if mine is not None:
        return mine
    src_stats = read_stats(ckpt)
    src_stats["crop"] = crop_setting(src_stats, setting=f"crop in {ckpt / 'stats.json'}")  # older stats: crop_to_aspect
    for key in SAME:
        if key in stats and src_stats.get(key) != stats[key]:
            raise ValueError(f"train.expert_from={source}: its {key}={src_stats.get(key)} differs from this run's "
                             f"{stats[key]}; train it with the same model and data settings")
    weights = read_weights(ckpt, "nomad_pointgoal", prefer_ema=False)
    load_state_dict_checked(build_model(dict(model_cfg)), weights, ckpt)  # same architecture and size
    ema_path = ckpt / "ema.safetensors"
    ema = load_file(str(ema_path)) if ema_path.is_file() else None
    step = int(src_stats.get("step", 0))
    out_stats = {**src_stats, "model": stats["model"], "member": "expert", "adopted_from": str(ckpt.resolve())}
    out = save_checkpoint(member_dir, step, weights, out_stats, {"step": step, "adopted_from": str(ckpt.resolve())}, ema)
    log.info("nomad_neg/expert: adopted %s (step %d) as NoMaD_e", ckpt, step)
    return out


"""Checkpoint directory of ``rvn-train`` (everything a policy needs, nothing else):

    <out_dir>/config.yaml                     resolved config (model, data, train, agent)
    <out_dir>/<member>/latest                 name of the newest complete checkpoint
    <out_dir>/<member>/ckpt_<step>/weights.safetensors   raw weights
                                  ema.safetensors       EMA weights (NoMaD; used for inference)
                                  stats.json            normalisation statistics + model name
                                  state.pt              optimizer/scheduler/EMA/step/RNG (resume)

``member`` is ``model`` for one network, ``expert`` and ``negative`` for NoMaD-Neg. A
checkpoint folder is filled under a temporary name and renamed, then ``latest`` is replaced:
an interrupted save leaves the previous checkpoint intact.
"""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any, Mapping

import torch
import yaml
from safetensors.torch import load_file, save_file

from rvn_data.atomic import write_text_atomic


def members_of(model_name: str) -> list[str]:
    return ["expert", "negative"] if model_name == "nomad_neg" else ["model"]


def write_config(out_dir: Path, cfg: Mapping) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out_dir / "config.yaml", yaml.safe_dump(dict(cfg), sort_keys=False))


def read_config(out_dir: str | Path) -> dict:
    path = Path(out_dir) / "config.yaml"
    if not path.is_file():
        raise ValueError(f"{out_dir} is not an rvn-train checkpoint directory (no config.yaml); pass the out_dir of rvn-train")
    try:
        cfg = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        raise ValueError(f"corrupt checkpoint config {path} ({type(e).__name__}: {e})") from None
    model = cfg.get("model") if isinstance(cfg, dict) else None
    if not isinstance(model, dict) or "name" not in model:
        raise ValueError(f"{out_dir} is not an rvn-train or rvn-rl checkpoint directory: {path} names no model "
                         f"(model.name){_kind_hint(Path(out_dir), cfg)}; pass the out_dir of rvn-train or rvn-rl")
    return cfg


def _kind_hint(out_dir: Path, cfg) -> str:
    """What the folder holds instead, when it says: a ``kind`` in its config.yaml or model.json."""
    kind = cfg.get("kind") if isinstance(cfg, dict) else None
    if kind is None and (out_dir / "model.json").is_file():
        try:
            meta = json.loads((out_dir / "model.json").read_text())
            kind = meta.get("kind") if isinstance(meta, dict) else None
        except (OSError, ValueError):
            kind = None
    return f" (its kind: {kind!r})" if kind else ""


def save_checkpoint(member_dir: Path, step: int, weights: Mapping[str, torch.Tensor], stats: Mapping[str, Any],
                    state: Mapping[str, Any], ema: Mapping[str, torch.Tensor] | None = None, keep: int = 2) -> Path:
    """Write ``ckpt_<step>`` atomically, point ``latest`` at it, keep the newest ``keep``."""
    member_dir.mkdir(parents=True, exist_ok=True)
    name = checkpoint_at(member_dir, step).name
    tmp = member_dir / f".{name}.tmp-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    # one metadata key: safetensors writes a header's keys in hash order, so two keys made the same run's bytes differ
    meta = {"rvn": json.dumps({"model": str(stats["model"]), "step": int(step)}, sort_keys=True)}
    save_file({k: v.detach().cpu().contiguous() for k, v in weights.items()}, str(tmp / "weights.safetensors"), metadata=meta)
    if ema is not None:
        save_file({k: v.detach().cpu().contiguous() for k, v in ema.items()}, str(tmp / "ema.safetensors"), metadata=meta)
    (tmp / "stats.json").write_text(json.dumps(dict(stats), indent=1))
    torch.save(dict(state), tmp / "state.pt")
    final = member_dir / name
    if final.exists():
        shutil.rmtree(final)
    os.replace(tmp, final)
    write_text_atomic(member_dir / "latest", name + "\n")
    others = sorted(p for p in member_dir.glob("ckpt_*") if p.is_dir() and p != final)
    for p in others[:max(0, len(others) - (max(1, keep) - 1))]:
        shutil.rmtree(p, ignore_errors=True)
    return final


def latest_checkpoint(member_dir: Path) -> Path | None:
    """The newest complete checkpoint folder of a member, or None."""
    pointer = member_dir / "latest"
    if not pointer.is_file():
        return None
    path = member_dir / pointer.read_text().strip()
    if not (path / "weights.safetensors").is_file():
        raise ValueError(f"checkpoint {path} named by {pointer} is missing or incomplete; delete {member_dir} to start over")
    return path


def checkpoint_at(member_dir: Path, step: int) -> Path:
    """A member's checkpoint after ``step`` optimiser steps (``ckpt_<step>``), kept or not."""
    return member_dir / f"ckpt_{step:08d}"


def kept_steps(member_dir: Path) -> list[int]:
    """The steps of a member's complete checkpoints (``train.keep_checkpoints`` of them), oldest first."""
    return sorted(int(p.name.removeprefix("ckpt_")) for p in member_dir.glob("ckpt_*")
                  if p.is_dir() and p.name.removeprefix("ckpt_").isdigit() and (p / "weights.safetensors").is_file())


def checked_step(step: Any, setting: str, folder: str) -> int | None:
    """A kept checkpoint's optimiser step given as ``setting`` (policy.step, train.expert_step), as an int (None: the
    latest); a ValueError naming the setting for anything but a step count (``folder``: where its ckpt_<step> lies)."""
    if step is not None and (isinstance(step, bool) or not isinstance(step, int) or step < 0):
        raise ValueError(f"{setting}={step!r}: give a kept checkpoint's optimiser step (an integer >= 0; its folder "
                         f"{folder}/ckpt_<step>), or leave it unset for the latest")
    return step


def checkpoint_of(member_dir: Path, step: int | None, setting: str = "policy.step") -> Path | None:
    """The latest checkpoint of a member (``step`` None; None when it has none yet), else its kept checkpoint after
    ``step`` steps: a ValueError naming ``setting`` and the steps it keeps when there is none."""
    if step is None:
        return latest_checkpoint(member_dir)
    ckpt = checkpoint_at(member_dir, step)
    if not (ckpt / "weights.safetensors").is_file():
        kept = kept_steps(member_dir)
        raise ValueError(f"{member_dir} keeps no checkpoint of step {step} ({setting}); it keeps "
                         f"{', '.join(map(str, kept)) or 'none'} (rvn-train keeps the newest train.keep_checkpoints)")
    return ckpt


def read_stats(ckpt: Path) -> dict:
    try:
        return json.loads((ckpt / "stats.json").read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise ValueError(f"corrupt checkpoint statistics {ckpt / 'stats.json'} ({e})") from None


def read_weights(ckpt: Path, expected_model: str, prefer_ema: bool = True) -> dict[str, torch.Tensor]:
    """Inference weights (EMA if present) after checking the checkpoint holds ``expected_model``."""
    stats = read_stats(ckpt)
    if stats.get("model") != expected_model:
        raise ValueError(f"checkpoint {ckpt} holds a {stats.get('model')!r} model, not {expected_model!r}")
    path = ckpt / "ema.safetensors"
    if not (prefer_ema and path.is_file()):
        path = ckpt / "weights.safetensors"
    try:
        return load_file(str(path))
    except Exception as e:  # safetensors raises its own error types
        raise ValueError(f"corrupt checkpoint weights {path} ({e})") from None


_OLD_VINT = {"vint_pointgoal": ", or before 2026-12-05, when ViNT-PointGoal's decoder took the official first layer "
                                "((C+2)*encoding_size -> encoding_size): train it again"}


def load_state_dict_checked(model: torch.nn.Module, weights: Mapping[str, torch.Tensor], source: Path) -> None:
    """``load_state_dict`` with a one-line error naming the checkpoint when keys or shapes differ."""
    own = model.state_dict()
    missing = sorted(set(own) - set(weights))
    unexpected = sorted(set(weights) - set(own))
    wrong = sorted(k for k in set(own) & set(weights) if own[k].shape != weights[k].shape)
    if missing or unexpected or wrong:
        raise ValueError(f"checkpoint {source} does not fit a {getattr(model, 'name', type(model).__name__)} of this config "
                         f"({len(missing)} missing, {len(unexpected)} unexpected, {len(wrong)} mis-shaped tensors, "
                         f"e.g. {(missing + unexpected + wrong)[0]!r}); it was trained with another model or size"
                         + _OLD_VINT.get(getattr(model, "name", None), ""))
    model.load_state_dict(weights)

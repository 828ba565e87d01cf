"""rvn-rl checkpoints: ``out_dir/config.yaml`` (``kind: rl``, the run's settings and the
network's arguments) and ``out_dir/checkpoints/ckpt_<env steps>/`` holding
``weights.safetensors`` (the policy, with its input normalisation statistics) and
``state.pt`` (optimiser, Lagrange multiplier, counters: what a resumed run needs);
``out_dir/checkpoints/latest`` names the newest."""
from __future__ import annotations

import io
import shutil
from pathlib import Path

import torch
import yaml
from safetensors.torch import load_file, save_file

from rvn_data.atomic import atomic_path, write_bytes_atomic, write_text_atomic
from rvn_data.provenance import provenance_record

from .settings import ALGOS

KIND = "rl"
POLICY_LOADER = "rvn_rl.policy.load_rl_policy"  # recorded for readers; rvn-eval finds it by KIND (entry point rvn.checkpoint_loaders)


def read_rl_config(out_dir: str | Path) -> dict:
    """config.yaml of an rvn-rl out_dir; a one-line ValueError for anything else."""
    path = Path(out_dir).expanduser() / "config.yaml"
    if not path.is_file():
        raise ValueError(f"{out_dir} is not an rvn-rl checkpoint directory (no config.yaml); pass the out_dir of rvn-rl")
    try:
        cfg = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        raise ValueError(f"corrupt checkpoint config {path} ({type(e).__name__})") from None
    if not isinstance(cfg, dict) or cfg.get("kind") != KIND:
        found = cfg.get("kind", "rvn-train (IL)") if isinstance(cfg, dict) else "unknown"
        raise ValueError(f"{path} holds a checkpoint of kind {found!r}, not an rvn-rl (kind: rl) one")
    algo = (cfg.get("algo") or {}).get("name")
    if algo not in ALGOS or "policy" not in cfg:
        raise ValueError(f"{path}: unknown RL algo {algo!r} or no policy settings; expected one of {', '.join(ALGOS)}")
    return cfg


def resume_point(out_dir: Path, policy: dict, algo: str, resume: bool, depth: dict | None = None) -> Path | None:
    """The checkpoint a run of network ``policy`` (`RLConfig.model_kwargs`) and ``algo`` continues from (None: it
    starts afresh); a one-line ValueError for an out_dir that holds another run or another kind, or, for a network
    with a depth channel, another ``depth`` record (source, depth model digest where the earlier run recorded one), or
    whose checkpoints a run not resuming (train.resume=false) would start over (its own checkpoints pruned as older by
    name than the old run's, its log rows appended to that run's)."""
    if not (out_dir / "config.yaml").is_file():
        return None
    old = read_rl_config(out_dir)
    if old["policy"] != policy or old["algo"]["name"] != algo:
        raise ValueError(f"out_dir={out_dir} holds another run ({old['algo']['name']}, {old['policy']['backbone']}, "
                         f"{old['policy']['obs_size']}px); choose a new out_dir")
    was = old.get("depth") or {}
    for key in ("source", "model_digest") if depth is not None and policy.get("use_depth") else ():
        if key in was and was[key] != depth.get(key):
            raise ValueError(f"out_dir={out_dir} holds a run trained with depth.{key}={was[key]}, not "
                             f"{depth.get(key)} (another depth input); choose a new out_dir")
    if not resume and any(p.is_dir() for p in (out_dir / "checkpoints").glob("ckpt_*")):
        raise ValueError(f"out_dir={out_dir} holds the checkpoints of a run, which train.resume=false would start "
                         "over; choose a new out_dir, or train.resume=true to continue that run")
    return latest(out_dir) if resume else None


def write_config(out_dir: Path, settings: dict, resuming: bool) -> None:
    """config.yaml: ``kind: rl``, the loader, ``settings`` and what code made the run (a resumed run keeps what the
    earlier record says of its start)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "config.yaml"
    earlier = yaml.safe_load(path.read_text()) if path.is_file() else None
    made_by = provenance_record(earlier if isinstance(earlier, dict) else None, resuming)
    write_text_atomic(path, yaml.safe_dump({"kind": KIND, "policy_loader": POLICY_LOADER, **settings, **made_by},
                                           sort_keys=False))


def latest(out_dir: str | Path) -> Path | None:
    marker = Path(out_dir).expanduser() / "checkpoints" / "latest"
    if not marker.is_file():
        return None
    ckpt = marker.parent / marker.read_text().strip()
    return ckpt if (ckpt / "weights.safetensors").is_file() else None


def env_steps_of(ckpt: Path) -> int:
    """The env steps over all ranks after which ``ckpt`` was saved (its name: ckpt_<env steps>)."""
    return int(ckpt.name.removeprefix("ckpt_"))


def save(out_dir: Path, env_steps: int, model: torch.nn.Module, state: dict, keep: int = 2) -> Path:
    root = out_dir / "checkpoints"
    ckpt = root / f"ckpt_{env_steps:012d}"
    ckpt.mkdir(parents=True, exist_ok=True)
    weights = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    with atomic_path(ckpt / "weights.safetensors") as tmp:
        save_file(weights, str(tmp))
    buf = io.BytesIO()
    torch.save(state, buf)
    write_bytes_atomic(ckpt / "state.pt", buf.getvalue())
    write_text_atomic(root / "latest", ckpt.name + "\n")
    for old in sorted(p for p in root.glob("ckpt_*") if p.is_dir())[:-keep]:
        shutil.rmtree(old, ignore_errors=True)
    return ckpt


def load(ckpt: Path, model: torch.nn.Module) -> dict:
    """Load ``ckpt``'s weights into ``model``; returns its state.pt."""
    load_weights(model, ckpt)
    return load_state(ckpt)


def load_weights(model: torch.nn.Module, ckpt: Path) -> None:
    weights = load_file(str(ckpt / "weights.safetensors"))
    missing, unexpected = model.load_state_dict(weights, strict=False)
    if missing or unexpected:
        raise ValueError(f"{ckpt}: weights do not fit the network of config.yaml (missing {sorted(missing)[:3]}, "
                         f"unexpected {sorted(unexpected)[:3]})")


def load_state(ckpt: Path) -> dict:
    return torch.load(ckpt / "state.pt", map_location="cpu", weights_only=False)

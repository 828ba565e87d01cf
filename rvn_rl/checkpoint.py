"""rvn-rl checkpoints: ``out_dir/config.yaml`` (``kind: rl``, the run's settings and the
network's arguments) and ``out_dir/checkpoints/ckpt_<env steps>/`` holding
``weights.safetensors`` (the policy, with its input normalisation statistics) and
``state.pt`` (optimiser, Lagrange multiplier, counters: what a resumed run needs);
``out_dir/checkpoints/latest`` names the newest."""
from __future__ import annotations

import io
import json
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


def resume_point(out_dir: Path, policy: dict, algo: str, resume: bool, depth: dict | None = None,
                 named: str = "out_dir") -> Path | None:
    """The checkpoint a run of network ``policy`` (`RLConfig.model_kwargs`) and ``algo`` continues from (None: it
    starts afresh); a one-line ValueError for an out_dir that holds another run or another kind, or, for a network
    with a depth channel, another ``depth`` record (source, depth model digest where the earlier run recorded one), or
    whose checkpoints a run not resuming (train.resume=false) would start over (its own checkpoints pruned as older by
    name than the old run's, its log rows appended to that run's). ``named``: the setting the errors name."""
    if not (out_dir / "config.yaml").is_file():
        return None
    old = read_rl_config(out_dir)
    if old["policy"] != policy or old["algo"]["name"] != algo:
        raise ValueError(f"{named}={out_dir} holds another run ({old['algo']['name']}, {old['policy']['backbone']}, "
                         f"{old['policy']['obs_size']}px); choose another {named}")
    was = old.get("depth") or {}
    for key in ("source", "model_digest") if depth is not None and policy.get("use_depth") else ():
        if key in was and was[key] != depth.get(key):
            raise ValueError(f"{named}={out_dir} holds a run trained with depth.{key}={was[key]}, not "
                             f"{depth.get(key)} (another depth input); choose another {named}")
    if not resume and kept(out_dir):
        raise ValueError(f"out_dir={out_dir} holds the checkpoints of a run, which train.resume=false would start "
                         "over; choose a new out_dir, or train.resume=true to continue that run")
    return latest(out_dir) if resume else None


def continue_point(source: Path, out_dir: Path, policy: dict, algo: str, depth: dict | None,
                   resume_from: Path | None) -> tuple[Path | None, dict | None]:
    """``train.continue_from=source``: another run's out_dir whose latest checkpoint (weights, optimiser, multiplier,
    counters) a new out_dir starts from, so that a longer budget (or a second look at one) trains on in a run folder
    of its own while ``source`` stays as it was evaluated. Returns (the checkpoint to start from, config.yaml's
    ``continued_from`` record: the source, its checkpoint and env steps, the code that trained it). An out_dir that
    already holds checkpoints resumes its own (``resume_from``) where its config.yaml says it started from ``source``;
    a one-line ValueError for a source that is out_dir itself, holds no checkpoint or another run, or an out_dir that
    holds a run started otherwise."""
    source = source.expanduser().resolve()
    if source == out_dir.expanduser().resolve():
        raise ValueError(f"train.continue_from={source} is out_dir itself; leave train.continue_from unset to resume "
                         "out_dir's run, or choose a new out_dir")
    if not source.is_dir():
        raise ValueError(f"train.continue_from={source} is not a directory; give the out_dir of an rvn-rl run")
    try:
        made = read_rl_config(source)
    except ValueError as e:
        raise ValueError(f"train.continue_from: {e}") from None
    resume_point(source, policy, algo, True, depth, named="train.continue_from")
    ckpt = latest(source)
    if ckpt is None:
        raise ValueError(f"train.continue_from={source} holds no checkpoint (checkpoints/latest); give the out_dir of "
                         "an rvn-rl run that saved one")
    if resume_from is not None:  # out_dir's own run: it must be the one that started from source
        started = (yaml.safe_load((out_dir / "config.yaml").read_text()) or {}).get("continued_from") or {}
        if started.get("out_dir") != str(source):
            said = f"from {started['out_dir']}" if started.get("out_dir") else "afresh"
            raise ValueError(f"out_dir={out_dir} holds a run that started {said}, not from train.continue_from="
                             f"{source}; choose a new out_dir, or leave train.continue_from unset to resume that run")
        return resume_from, started
    return ckpt, {"out_dir": str(source), "checkpoint": ckpt.name, "env_steps": env_steps_of(ckpt),
                  **{k: made[k] for k in ("provenance", "resumed_by", "continued_from") if made.get(k)}}


def continue_log(source: Path, out_dir: Path, env_steps: int) -> None:
    """``source``'s metrics.jsonl rows up to ``env_steps`` (its checkpoint's) as out_dir's first rows, so that a
    continued run's log and learning curve show the whole training; TensorBoard's events stay the source's."""
    path = source / "metrics.jsonl"
    if not path.is_file():
        return
    lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
    rows = [ln for ln in lines if json.loads(ln).get("env_steps", 0) <= env_steps]
    write_text_atomic(out_dir / "metrics.jsonl", "".join(ln + "\n" for ln in rows))


def write_config(out_dir: Path, settings: dict, resuming: bool, continued_from: dict | None = None) -> None:
    """config.yaml: ``kind: rl``, the loader, ``settings``, where the run started (``continued_from``: another run's
    checkpoint, `continue_point`) and what code made the run (a resumed run keeps what the earlier record says of its
    start)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "config.yaml"
    earlier = yaml.safe_load(path.read_text()) if path.is_file() else None
    made_by = provenance_record(earlier if isinstance(earlier, dict) else None, resuming)
    if continued_from is None and resuming and isinstance(earlier, dict):  # resumed without the setting: kept
        continued_from = earlier.get("continued_from")
    origin = {"continued_from": continued_from} if continued_from else {}
    write_text_atomic(path, yaml.safe_dump({"kind": KIND, "policy_loader": POLICY_LOADER, **settings, **origin,
                                            **made_by}, sort_keys=False))


def latest(out_dir: str | Path) -> Path | None:
    marker = Path(out_dir).expanduser() / "checkpoints" / "latest"
    if not marker.is_file():
        return None
    ckpt = marker.parent / marker.read_text().strip()
    return ckpt if (ckpt / "weights.safetensors").is_file() else None


def checkpoint_at(out_dir: Path, env_steps: int) -> Path:
    """The folder of ``out_dir``'s checkpoint after ``env_steps`` env steps (whether or not it is kept)."""
    return out_dir / "checkpoints" / f"ckpt_{env_steps:012d}"


def kept(out_dir: Path) -> list[Path]:
    """``out_dir``'s checkpoint folders, oldest first (a folder whose weights are not yet written included)."""
    return sorted(p for p in (out_dir / "checkpoints").glob("ckpt_*") if p.is_dir())


def env_steps_of(ckpt: Path) -> int:
    """The env steps over all ranks after which ``ckpt`` was saved (its name: ckpt_<env steps>)."""
    return int(ckpt.name.removeprefix("ckpt_"))


def save(out_dir: Path, env_steps: int, model: torch.nn.Module, state: dict, keep: int = 2) -> Path:
    ckpt = checkpoint_at(out_dir, env_steps)
    root = ckpt.parent
    ckpt.mkdir(parents=True, exist_ok=True)
    weights = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    with atomic_path(ckpt / "weights.safetensors") as tmp:
        save_file(weights, str(tmp))
    buf = io.BytesIO()
    torch.save(state, buf)
    write_bytes_atomic(ckpt / "state.pt", buf.getvalue())
    write_text_atomic(root / "latest", ckpt.name + "\n")
    for old in kept(out_dir)[:-keep]:
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

"""rvn-train's checks before any work: every path and setting that would otherwise fail after
minutes of training (or, for nomad_neg, after its first member is trained).

`preflight` checks the device, the model size, the out_dir (writable, not another model's
checkpoints), the datasets of every member (``data.root``; ``data.negative_root`` for
nomad_neg) with the setting that names them and the kind of trajectories each holds (`check_kinds`: no negatives but
NoMaD_n's), ``data.depth_root``, ``train.expert_from``, ``data.val_root`` and the
loop settings, and raises `rvn_data.cli.common.ConfigError` (exit status 2) with one line
naming the setting. Every trajectory a dataset's split lists must be whole (`rvn_data.dataset.verify`:
folder, pose file, every frame's header and end, depth maps when the model uses them); the
line names the first that is not and the rvn-gen command that redoes it. Nothing is written.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Mapping

import torch

from rvn_data.benchmark.trained_scenes import dataset_scenes
from rvn_data.cache_root import cache_root
from rvn_data.dataset.reader import list_trajectories, load_gnm, read_meta, rvn_trajectories, split_file
from rvn_data.dataset.remake import remake_hint
from rvn_data.dataset.verify import MISSING, Expect, damaged
from rvn_data.cli.common import ConfigError, check_writable_dir, validating
from rvn_data.embodiment import dataset_embodiment, mismatches, resolve_agent

from ..data import check_waypoint_frames, crop_setting, depth_setting, entry_settings
from ..data.cache import cache_state
from ..data.sources import dataset_entries, single_entry
from ..data.depth import REGENERATE, has_depth
from ..models import resolve_size
from ..models.checkpoint import members_of, read_config
from ..models.nomad import check_prediction_type
from ..policies.loader import resolve_device
from .adopt import adopted_before, expert_source
from .choices import TRAIN_COMPILE_MODES, check_compile_mode, check_precision, check_precision_on

log = logging.getLogger(__name__)


def data_roots(cfg: Mapping) -> dict[str, str]:
    """Member → dataset folder: ``data.root`` (expert) and, for nomad_neg, ``data.negative_root``."""
    members = members_of(cfg["model"]["name"])
    if members == ["model"]:
        return {"model": cfg["data"]["root"]}
    neg = cfg["data"]["negative_root"]
    if not neg:
        raise ValueError("model=nomad_neg needs data.negative_root= (the negative GNM dataset for NoMaD_n) besides data.root=")
    return {"expert": cfg["data"]["root"], "negative": neg}


def preflight(cfg: Mapping) -> tuple[torch.device, dict | None, dict, list[dict]]:
    """Check a complete rvn-train config (`rvn_il.train.settings.complete_config`); returns the
    device, the data's embodiment record (None for data not written by rvn-gen), the agent to train
    for and the ``agent.*`` settings given that differ from the data's. `ConfigError` naming the
    setting on the first problem."""
    with validating():
        device = resolve_device(cfg["device"])
        name = resolve_size(cfg["model"])["name"]  # validates model.size
        check_settings(cfg)
        check_precision_on(cfg["train"]["precision"], device)
        check_datasets(cfg)
        check_kinds(cfg)
        check_out_dir(cfg, name)
        record = data_embodiment(cfg)
        agent, overrides = resolve_agent(cfg["agent"], record)
    return device, record, agent, overrides


def data_embodiment(cfg: Mapping) -> dict | None:
    """The embodiment rvn-gen recorded in the data the model learns from (`rvn_data.embodiment`; the first
    trajectory of the first dataset of each member, and of data.depth_root); these must agree. Other
    datasets of a ``data.datasets`` mixture may come from other robots (real data): not compared."""
    data, found = cfg["data"], {}
    for entries in member_entries(cfg, adopted=True).values():
        e = entries[0]
        first = first_trajectory(e)
        found[(e["key"], e["root"])] = dataset_embodiment(e["root"], first) if first else None
    if data["depth_root"] and Path(str(data["depth_root"])).expanduser().is_dir():  # frames of the depth head
        names = rvn_trajectories(data["depth_root"])
        found[("data.depth_root", data["depth_root"])] = dataset_embodiment(data["depth_root"], names[0]) if names else None
    ((first, first_root), record), *others = list(found.items()) or [((None, None), None)]
    for (key, root), other in others:
        diffs = mismatches(record, other or {})
        if diffs:
            d = diffs[0]
            raise ConfigError(f"{key}={root} was made with {d['setting']}={d['here']}, {first}={first_root} with "
                              f"{d['trained']}; generate both with one robot and camera")
    return record


def check_kinds(cfg: Mapping) -> None:
    """Each member learns from the trajectories it is for: NoMaD_n (``data.negative_root``) from rvn-gen's negatives,
    every other member from no negatives (they end in a collision: a model trained on them imitates it; rvn-train
    trained NoMaD-PointGoal on data.root=<negatives> without a word). A dataset without rvn-gen's sidecar (other GNM
    data) is not checked; each dataset's first trajectory names its kind."""
    model = cfg["model"]["name"]
    for member, entries in member_entries(cfg).items():
        for e in entries:
            first = first_trajectory(e)
            try:
                kind = read_meta(Path(e["root"]).expanduser() / first).get("kind") if first else None
            except ValueError:  # no sidecar: not rvn-gen's
                kind = None
            if member == "negative" and kind not in (None, "negative"):
                raise ConfigError(f"{e['key']}={e['root']} holds {kind} trajectories (rvn-gen dataset={kind}): NoMaD_n "
                                  "learns the collisions of rvn-gen dataset=negative; give a negative dataset")
            if member != "negative" and kind == "negative":
                raise ConfigError(f"{e['key']}={e['root']} holds negative trajectories (rvn-gen dataset=negative: each "
                                  f"ends in a collision), which model={model} would learn to drive; give an expert "
                                  "dataset (rvn-gen's default), and the negatives as data.negative_root with "
                                  "model=nomad_neg")


def val_training_scenes(cfg: Mapping) -> list[str]:
    """The scenes of ``data.val_root`` (its ``data.val_split``) that the training data's GNM train splits hold, by name
    (`rvn_data.benchmark.trained_scenes.dataset_scenes`; datasets without rvn-gen's manifest.json are not compared):
    validation on them is not held out (rvn-train validated on data.val_root=data.root without a word)."""
    val_root = cfg["data"]["val_root"]
    val = dataset_scenes(val_root, cfg["data"]["val_split"]) if val_root else None
    if not val:
        return []
    trained = set()
    for entries in member_entries(cfg).values():
        for e in entries:
            trained |= set(dataset_scenes(e["root"]) or {})
    return sorted(trained & set(val))


def first_trajectory(entry: Mapping) -> str | None:
    """The first trajectory a resolved dataset entry's split lists, or None."""
    _, names = list_trajectories(Path(entry["root"]).expanduser(), entry["split"],
                                 Path(entry["splits_dir"]) if entry["splits_dir"] else None, entry["name"],
                                 folders=False)
    return names[0] if names else None


def member_entries(cfg: Mapping, adopted: bool = False) -> dict[str, list[dict]]:
    """Member → its resolved datasets (`rvn_il.data.sources`): ``data.datasets`` / ``data.official_config`` /
    ``data.root`` for the model (NoMaD_e), ``data.negative_root`` for NoMaD_n. NoMaD_e adopted from
    ``train.expert_from`` reads no data: left out, unless ``adopted`` and its data.root exists."""
    data, out = cfg["data"], {}
    for member in data_roots(cfg):
        if member == "negative":
            out[member] = [single_entry(data["negative_root"], data, "data.negative_root")]
        elif member == "expert" and cfg["train"]["expert_from"]:
            if adopted and not data.get("datasets") and not data.get("official_config") \
                    and Path(str(data["root"])).expanduser().is_dir():
                out[member] = [single_entry(data["root"], data, "data.root")]
        else:
            out[member] = dataset_entries(data)
    return out


def check_out_dir(cfg: Mapping, name: str) -> None:
    """out_dir writable, and not holding checkpoints of another model or size."""
    out_dir = Path(cfg["out_dir"]).expanduser()
    trained = any((out_dir / m / "latest").is_file() for m in ("model", "expert", "negative"))
    if trained and (out_dir / "config.yaml").is_file():
        old = read_config(out_dir)["model"]
        size = cfg["model"].get("size", "full")
        if old["name"] != name or old.get("size", "full") != size:
            raise ValueError(f"{out_dir} holds a checkpoint of model {old['name']!r} (size {old.get('size', 'full')}), not "
                             f"{name!r} (size {size}); choose another out_dir=")
    check_writable_dir(out_dir)


def check_settings(cfg: Mapping) -> None:
    """Loop and validation settings."""
    tcfg, data, model = cfg["train"], cfg["data"], cfg["model"]
    if "prediction_type" in model:
        check_prediction_type(model["prediction_type"])
    check_waypoint_frames(data["waypoint_frames"])
    check_precision(tcfg["precision"])
    check_compile_mode(tcfg["compile_mode"], TRAIN_COMPILE_MODES)
    val_root = data["val_root"]
    if val_root and not Path(val_root).expanduser().is_dir():
        raise ValueError(f"data.val_root={val_root} does not exist; generate an expert dataset on other scenes "
                         "(rvn-gen split=val out_dir=...) or set data.val_root=null")
    for key in ("val_batches", "val_trajectories"):
        if val_root and not int(tcfg[key]) > 0:
            raise ValueError(f"train.{key}={tcfg[key]} must be a positive integer")
    for key in ("log_every", "ckpt_every", "val_every"):  # the loop takes each step modulo them (0: it failed there)
        if not int(tcfg[key]) > 0:
            raise ValueError(f"train.{key}={tcfg[key]} must be a positive integer")
    if tcfg["warmup_steps"] is not None and not int(tcfg["warmup_steps"]) >= 0:
        raise ValueError(f"train.warmup_steps={tcfg['warmup_steps']} must be an integer >= 0 (null: train.warmup_frac)")


def check_datasets(cfg: Mapping) -> None:
    """Every member's datasets exist and list trajectories (and have depth sidecars when the
    depth loss is on); ``train.expert_from`` (and ``train.expert_step``) for nomad_neg."""
    data, tcfg = cfg["data"], cfg["train"]
    depth = depth_setting(resolve_size(cfg["model"])) is not None  # the depth loss reads rvn-gen's depth.npy
    if (tcfg["expert_from"] or tcfg.get("expert_step") is not None) and "expert" in members_of(cfg["model"]["name"]):
        ckpt = expert_source(tcfg["expert_from"], resolve_size(cfg["model"]), tcfg.get("expert_step"))
        adopted_before(Path(str(cfg["out_dir"])).expanduser() / "expert", ckpt)  # a rerun adopts the same NoMaD_e
    for member, entries in member_entries(cfg).items():
        for e in entries:
            names = whole_split(e["key"], e["root"], e["split"], e["splits_dir"], e["name"], depth,
                                packed=packed_current(cfg, e))
            if depth and not has_depth(Path(e["root"]).expanduser(), names):
                raise ConfigError(f"{e['key']}={e['root']} has no depth.npy sidecars; {REGENERATE}")
    if data["val_root"]:
        whole_split("data.val_root", data["val_root"], data["val_split"] or "all", None, None, False)
    check_depth_root(data, depth)


def whole_split(key: str, root: str, split: str, splits_dir: str | None, name: str | None, depth: bool,
                packed: bool = False) -> list[str]:
    """The trajectories of a dataset's split, each folder checked whole (``packed``: the packed cache of exactly
    these files is current, so they were whole when it was built and its frames are not read again);
    `ConfigError` naming the setting, the first trajectory that is not (and how many more) and the command
    that redoes it."""
    path = Path(str(root)).expanduser()
    splits = Path(splits_dir) if splits_dir else None
    try:
        _, names = list_trajectories(path, split, splits, name, folders=False)
    except ValueError as err:
        raise ConfigError(f"{key}={root}: {err}") from None
    if packed:
        log.info("%s=%s: %d trajectories unchanged since their packed cache was built; frames not read again",
                 key, root, len(names))
        return names
    bad = damaged(path, names, Expect.of_dataset(path, depth))
    if bad:
        first, problem = next(iter(bad.items()))
        if problem == MISSING:
            listing = split_file(path, split, splits, name)
            problem += f" (listed in {listing.relative_to(path) if listing.is_relative_to(path) else listing})"
        more = f", and {len(bad) - 1} more {'trajectory' if len(bad) == 2 else 'trajectories'} damaged" if len(bad) > 1 else ""
        raise ConfigError(f"{key}={root}: trajectory {first}: {problem}{more}; {remake_hint(path)}")
    return names


def packed_current(cfg: Mapping, entry: Mapping) -> bool:
    """Whether the packed cache rvn-train will read for this dataset is current (`rvn_il.data.cache.cache_state`:
    built from exactly these files with these settings); False when it is missing, stale or the poses do not load
    (the full check then names the problem)."""
    model_cfg, data = resolve_size(cfg["model"]), entry_settings(entry, cfg["data"])
    try:
        source = load_gnm(entry["root"], data["split"], data["splits_dir"], data["name"], data["metric_waypoint_spacing"])
    except (ValueError, OSError):
        return False
    cache_dir = cfg["data"]["cache_dir"] or cache_root(cfg["cache_dir"], Path(str(cfg["out_dir"])).expanduser()) / "packed"
    return cache_state(source, model_cfg["image_size"], crop_setting(data, model_cfg), cache_dir,
                       depth_setting(model_cfg))[2]


def check_depth_root(data: Mapping, depth: bool) -> None:
    """``data.depth_root`` (frames for the depth head alone): needs the depth loss, an existing GNM
    folder with depth sidecars and a positive ``data.depth_batch``."""
    root = data["depth_root"]
    if not root:
        return
    if not depth:
        raise ConfigError(f"data.depth_root={root} trains the depth head, which model.depth_aux_weight=0 turns off; "
                          "set model.depth_aux_weight > 0 or data.depth_root=null")
    if not int(data["depth_batch"]) > 0:
        raise ConfigError(f"data.depth_batch={data['depth_batch']} must be a positive integer")
    path = Path(str(root)).expanduser()
    names = whole_split("data.depth_root", root, "all", None, None, True)
    if not has_depth(path, names):
        raise ConfigError(f"data.depth_root={root} has no depth.npy sidecars; regenerate it with rvn-gen "
                          "dataset.save_depth=true (e.g. dataset=negative on the train scenes) or set data.depth_root=null")


__all__ = ["check_datasets", "check_depth_root", "check_out_dir", "check_settings", "data_roots", "preflight",
           "whole_split"]

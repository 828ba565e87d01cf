"""Which GNM datasets a model learns from: ``data.root`` alone, a ``data.datasets`` list, or
visualnav-transformer's own training config (``data.official_config`` + ``data.official_data_config``).

Every source becomes a list of resolved entries (plain dicts: ``setting`` names the list item for
messages, ``root``, ``split``, ``splits_dir``, ``name``, ``metric_waypoint_spacing``,
``waypoint_spacing``, ``goal_offset``, ``end_slack``, ``crop``, ``weight``), checked before any work:
a missing folder, a bad weight or stride is a one-line error naming ``data.datasets[i].<key>``.

The official config (train/config/nomad.yaml) names each dataset with ``data_folder``, ``train``
(the split folder holding traj_names.txt), ``end_slack``, ``waypoint_spacing`` (frames, default 1),
``goals_per_obs`` and ``negative_mining``; its data_config.yaml gives ``metric_waypoint_spacing``.
Read here: data_folder, train, end_slack, waypoint_spacing and the spacing, with ``crop: official``
(the official loader crops every image to 4:3, then resizes), weights in proportion to samples (its
ConcatDataset). ``goals_per_obs`` is not read by its ViNT_Dataset and ``negative_mining`` feeds the
image-goal distance head the PointGoal models lack: both are reported and left out.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

import yaml

from .images import check_crop

ENTRY_KEYS = ("root", "name", "split", "splits_dir", "split_dir", "weight", "metric_waypoint_spacing",
              "waypoint_spacing", "goal_offset", "end_slack", "crop")
IGNORED_OFFICIAL = ("goals_per_obs", "negative_mining")


def dataset_entries(data: Mapping[str, Any]) -> list[dict]:
    """The resolved datasets of rvn-train's ``data`` settings (the expert's, for nomad_neg)."""
    if data.get("official_config"):
        if data.get("datasets"):
            raise ValueError("give data.datasets or data.official_config, not both")
        raw = official_entries(data["official_config"], data.get("official_data_config"))
        prefix = f"data.official_config={data['official_config']}: dataset"
    elif data.get("datasets"):
        raw, prefix = [dict(e) for e in data["datasets"]], "data.datasets"
    else:
        return [single_entry(data["root"], data, "data.root")]
    entries = [_resolve(e, data, f"{prefix}[{i}]") for i, e in enumerate(raw)]
    weights = [e["weight"] for e in entries]
    if len(entries) > 1 and any(w is None for w in weights) and any(w is not None for w in weights):
        raise ValueError("data.datasets: give a weight for every dataset or for none (none: in proportion to samples)")
    return entries


def single_entry(root: str, data: Mapping[str, Any], setting: str) -> dict:
    """The one dataset ``setting`` (data.root, data.negative_root) with the ``data.*`` split, name and spacing."""
    return _resolve({"root": root, "splits_dir": data.get("splits_dir"), "name": data.get("name"),
                     "metric_waypoint_spacing": data.get("metric_waypoint_spacing")}, data, setting, whole=True)


def _resolve(entry: Mapping[str, Any], data: Mapping[str, Any], setting: str, whole: bool = False) -> dict:
    """A resolved entry; ``whole``: the setting names the folder itself (data.root), not a list item."""
    unknown = sorted(set(entry) - set(ENTRY_KEYS))
    if unknown:
        raise ValueError(f"{setting}.{unknown[0]} is not a dataset setting; choose among {', '.join(ENTRY_KEYS)}")
    root = entry.get("root")
    if root in (None, "", "???"):
        raise ValueError(f"{setting}.root is missing: give the GNM dataset folder")
    if not Path(str(root)).expanduser().is_dir():
        key = setting if whole else f"{setting}.root"
        how = "rvn-gen dataset=negative (out_dir=...)" if setting == "data.negative_root" else "rvn-gen (out_dir=...)"
        raise ValueError(f"{key}={root} does not exist; generate it with {how} or set {key}= to a GNM dataset folder")
    out = {"setting": setting, "root": str(root), "key": setting if whole else f"{setting}.root"}
    split, splits_dir, name = entry.get("split") or data.get("split", "train"), entry.get("splits_dir"), entry.get("name")
    if entry.get("split_dir"):  # <splits_dir>/<name>/<split>/traj_names.txt with the folder given whole
        folder = Path(str(entry["split_dir"])).expanduser()
        if not (folder / "traj_names.txt").is_file():
            raise ValueError(f"{setting}.split_dir={entry['split_dir']} holds no traj_names.txt")
        split, name, splits_dir = folder.name, folder.parent.name, str(folder.parent.parent)
    spacing = entry.get("metric_waypoint_spacing")
    if spacing is not None and not (isinstance(spacing, (int, float)) and math.isfinite(spacing) and spacing > 0):
        raise ValueError(f"{setting}.metric_waypoint_spacing={spacing!r} must be a positive number of metres")
    stride = entry.get("waypoint_spacing", 1)
    if isinstance(stride, bool) or not isinstance(stride, int) or stride < 1:
        raise ValueError(f"{setting}.waypoint_spacing={stride!r} must be a whole number of frames >= 1")
    weight = entry.get("weight")
    if weight is not None and not (isinstance(weight, (int, float)) and math.isfinite(weight) and weight > 0):
        raise ValueError(f"{setting}.weight={weight!r} must be a positive number (its share of each batch)")
    slack = entry.get("end_slack")
    slack = data.get("end_slack", 0) if slack is None else slack
    if isinstance(slack, bool) or not isinstance(slack, int) or slack < 0:
        raise ValueError(f"{setting}.end_slack={slack!r} must be a whole number of frames >= 0")
    crop = entry.get("crop")
    out.update(split=str(split), splits_dir=splits_dir, name=name, metric_waypoint_spacing=spacing,
               waypoint_spacing=int(stride), weight=None if weight is None else float(weight),
               goal_offset=list(entry.get("goal_offset") or data.get("goal_offset") or (1, 20)), end_slack=int(slack),
               crop=None if crop is None else check_crop(crop, f"{setting}.crop"))
    return out


def official_entries(config: str | Path, data_config: str | Path | None) -> list[dict]:
    """``data.datasets`` entries from visualnav-transformer's training config and data_config.yaml."""
    cfg = _read_yaml(config, "data.official_config")
    sets = cfg.get("datasets") if isinstance(cfg, dict) else None
    if not isinstance(sets, dict) or not sets:
        raise ValueError(f"data.official_config={config} has no datasets: block (visualnav-transformer's train/config/*.yaml)")
    spacings = _read_yaml(data_config, "data.official_data_config") if data_config else {}
    out = []
    for name, d in sets.items():
        if not isinstance(d, dict) or "data_folder" not in d or "train" not in d:
            raise ValueError(f"data.official_config={config}: dataset {name!r} needs data_folder and train")
        spacing = (spacings.get(name) or {}).get("metric_waypoint_spacing") if isinstance(spacings, dict) else None
        if spacing is None:
            raise ValueError(f"data.official_config={config}: dataset {name!r} has no metric_waypoint_spacing in "
                             f"{data_config or 'data.official_data_config (not given)'}; give its data_config.yaml")
        out.append({"root": d["data_folder"], "name": name, "split_dir": d["train"], "metric_waypoint_spacing": spacing,
                    "waypoint_spacing": d.get("waypoint_spacing", 1), "end_slack": d.get("end_slack", 0),
                    "crop": "official"})
    return out


def ignored_official_keys(config: str | Path) -> list[str]:
    """``name.key`` of the official settings RVN reads but does not apply (reported at start-up)."""
    sets = (_read_yaml(config, "data.official_config") or {}).get("datasets") or {}
    return [f"{n}.{k}" for n, d in sets.items() if isinstance(d, dict) for k in IGNORED_OFFICIAL if k in d]


def _read_yaml(path: str | Path, setting: str) -> Any:
    p = Path(str(path)).expanduser()
    if not p.is_file():
        raise ValueError(f"{setting}={path} does not exist")
    try:
        return yaml.safe_load(p.read_text())
    except yaml.YAMLError as e:
        raise ValueError(f"{setting}={path} is not YAML ({type(e).__name__}: {str(e).splitlines()[0]})") from None

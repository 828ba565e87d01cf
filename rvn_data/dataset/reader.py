"""The one reader of GNM trajectory folders (ours and third-party); every consumer uses it:
rvn-gen on resume, the clip inspector, rvn_il's packed cache and training, the agreement tool.

``<root>/<traj>/{0..T-1}.jpg`` + ``traj_data.pkl`` (``position`` [T,2] metres, ``yaw`` [T]
radians), and for rvn-gen's folders the sidecar ``rvn_meta.json``. Splits from
``<splits_dir>/<name>/<split>/traj_names.txt`` when present, else (split ``all``, or no split files at all)
every folder holding ``traj_data.pkl``. ``metric_waypoint_spacing`` from the config, else ``<root>/data_config.yaml``
(top level or under the dataset name), else ``d_step`` (0.25 m). Third-party pickles are
coerced: position → float64 [T,2], yaw → float64 [T] (a [T,1] yaw is squeezed), as
GoStanford2 needs.
"""
from __future__ import annotations

import json
import os
import pickle
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import yaml

from rvn_data.conventions import AgentConfig

DEFAULT_SPACING = AgentConfig.d_step  # m, the default d_step
TRAJ_DATA = "traj_data.pkl"
DEPTH_NAME = "depth.npy"  # optional sidecar (dataset.save_depth): float16 [T, S, S] metres
META_NAME = "rvn_meta.json"  # rvn-gen's sidecar: scene, start, goal, actions, collision


@dataclass
class GNMSource:
    """A resolved GNM split: trajectory names in order, their poses and the waypoint spacing."""

    root: Path
    name: str
    split: str
    names: list[str]
    positions: list[np.ndarray] = field(repr=False)
    yaws: list[np.ndarray] = field(repr=False)
    spacing: float

    @property
    def lengths(self) -> np.ndarray:
        return np.array([len(p) for p in self.positions], dtype=np.int64)

    def frame_path(self, traj: int, t: int) -> Path:
        return self.root / self.names[traj] / f"{t}.jpg"


def load_traj_data(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """(position float64 [T,2], yaw float64 [T]) of one trajectory folder; ValueError if corrupt."""
    pkl = Path(folder) / TRAJ_DATA
    try:
        with open(pkl, "rb") as f:
            data = pickle.load(f)
        position = np.asarray(data["position"], dtype=np.float64)
        yaw = np.asarray(data["yaw"], dtype=np.float64)
    except FileNotFoundError:
        raise ValueError(f"trajectory {folder} has no traj_data.pkl; remove it from the split or regenerate it") from None
    except Exception as e:  # unpickling errors come in many types
        raise ValueError(f"corrupt trajectory file {pkl}: {type(e).__name__}: {e}; regenerate it or remove the folder") from None
    if yaw.ndim == 2 and yaw.shape[1] == 1:
        yaw = yaw[:, 0]
    if position.ndim != 2 or position.shape[1] < 2 or yaw.ndim != 1 or len(yaw) != len(position):
        raise ValueError(f"corrupt trajectory file {pkl}: position {position.shape} / yaw {yaw.shape}, expected [T,2] / [T]")
    position = np.ascontiguousarray(position[:, :2])
    if not (np.isfinite(position).all() and np.isfinite(yaw).all()):
        raise ValueError(f"corrupt trajectory file {pkl}: non-finite position or yaw")
    return position, yaw


def _splits_name(splits_dir: Path, name: str | None, root: Path) -> str:
    if name:
        return name
    if splits_dir.is_dir():
        subs = sorted(p.name for p in splits_dir.iterdir() if p.is_dir())
        if len(subs) == 1:
            return subs[0]
    return root.name


def split_file(root: Path, split: str, splits_dir: Path | None = None, name: str | None = None) -> Path:
    """``<splits_dir>/<name>/<split>/traj_names.txt`` of a dataset (it may not exist)."""
    splits_dir = Path(splits_dir) if splits_dir else Path(root) / "data_splits"
    return splits_dir / _splits_name(splits_dir, name, Path(root)) / split / "traj_names.txt"


def list_trajectories(root: Path, split: str, splits_dir: Path | None = None,
                      name: str | None = None, folders: bool = True) -> tuple[str, list[str]]:
    """(dataset name, trajectory folder names) of a split; see the module docstring. ``folders``:
    a name in the split file without its folder is an error (else the caller checks them)."""
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"GNM dataset folder {root} does not exist; generate it with rvn-gen or set data.root=")
    listing = split_file(root, split, splits_dir, name)
    name = listing.parent.parent.name
    if listing.is_file():
        names = [ln.strip() for ln in listing.read_text().splitlines() if ln.strip()]
        if not names:
            raise ValueError(f"split file {listing} lists no trajectories")
        missing = [n for n in names if folders and not (root / n).is_dir()]
        if missing:
            raise ValueError(f"split file {listing} names {len(missing)} missing trajectory folder(s) under {root}, e.g. {missing[0]!r}")
        return name, names
    splits = listing.parents[2]  # <splits_dir>
    have = sorted(str(f.relative_to(splits)) for f in splits.glob("*/*/traj_names.txt")) if split != "all" else []
    if have:  # splits of other names or sets, not this one: every folder would hold the others' trajectories too
        raise ValueError(f"split file {listing} does not exist; {splits} holds {', '.join(have)}: name one "
                         "of them (rvn-train: data.split=, data.name=), or split all for every trajectory folder")
    names = sorted(e.name for e in os.scandir(root)
                   if e.is_dir() and not e.name.startswith(".") and (Path(e.path) / "traj_data.pkl").is_file())
    if not names:
        raise ValueError(f"GNM dataset folder {root} holds no trajectory (no <traj>/traj_data.pkl); "
                         "generate it with rvn-gen or point data.root= at a GNM dataset")
    return name, names


def read_spacing(root: Path, name: str, configured: float | None) -> float:
    """metric_waypoint_spacing: config value, else data_config.yaml, else DEFAULT_SPACING."""
    if configured is not None:
        value = configured
    else:
        value = DEFAULT_SPACING
        cfg_file = Path(root) / "data_config.yaml"
        if cfg_file.is_file():
            try:
                data = yaml.safe_load(cfg_file.read_text()) or {}
            except yaml.YAMLError as e:
                raise ValueError(f"corrupt {cfg_file}: {e}") from None
            if "metric_waypoint_spacing" in data:
                value = data["metric_waypoint_spacing"]
            elif isinstance(data.get(name), dict) and "metric_waypoint_spacing" in data[name]:
                value = data[name]["metric_waypoint_spacing"]
    value = float(value)
    if not value > 0:
        raise ValueError(f"metric_waypoint_spacing={value} for dataset {root} must be positive")
    return value


def load_gnm(root: str | Path, split: str = "train", splits_dir: str | Path | None = None,
             name: str | None = None, spacing: float | None = None) -> GNMSource:
    """Resolve a split of a GNM dataset and load every trajectory's poses."""
    root = Path(root).expanduser().resolve()
    name, names = list_trajectories(root, split, Path(splits_dir) if splits_dir else None, name)
    positions, yaws = [], []
    for n in names:
        p, y = load_traj_data(root / n)
        positions.append(p)
        yaws.append(y)
    return GNMSource(root, name, split, names, positions, yaws, read_spacing(root, name, spacing))


def read_rgb(path: str | Path) -> np.ndarray:
    """Decode an image file to uint8 RGB [h,w,3]; ValueError naming the file if unreadable."""
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"cannot decode image {path}: the file is missing or corrupt; regenerate the trajectory or remove it from the split")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def read_meta(folder: str | Path) -> dict:
    """rvn-gen's sidecar ``rvn_meta.json`` of one trajectory folder; ValueError if missing or corrupt."""
    path = Path(folder) / META_NAME
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"trajectory {folder} has no {META_NAME}: not written by rvn-gen, or incomplete") from None
    except (OSError, ValueError) as e:
        raise ValueError(f"corrupt {path}: {e}; regenerate the trajectory") from None


def is_complete(folder: str | Path) -> bool:
    """An rvn-gen trajectory folder with both its pose file and its sidecar (written last)."""
    folder = Path(folder)
    return not folder.name.startswith(".") and (folder / TRAJ_DATA).is_file() and (folder / META_NAME).is_file()


def rvn_trajectories(root: str | Path) -> list[str]:
    """Names of the complete rvn-gen trajectory folders under ``root``, sorted."""
    return sorted(p.parent.name for p in Path(root).glob(f"*/{META_NAME}") if is_complete(p.parent))

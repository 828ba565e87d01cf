"""What rvn-train learns from, before it trains: one line per dataset (name, trajectories, frames, samples,
metres per step, image sizes, share of each batch, trajectories skipped and why) and the odd cases real
data brings, found from the poses: frames much farther apart or closer than metric_waypoint_spacing
says, and yaw that never changes while the path turns (its labels would sit in a fixed frame).
Logged at start-up (rvn-train.log) and, for a mixture, kept in the checkpoint's stats (``datasets``)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping, Sequence

import cv2
import numpy as np

from .dataset import GNMDataset, MOVE_EPS
from .mixture import MixtureDataset

SPACING_TOLERANCE = 0.5  # a median move this far (relative) from the declared spacing is reported
TURN_RAD = math.radians(30)  # a path whose motion heading changes this much "turns"


def _image_sizes(root: Path, names: Sequence[str], probe: int = 3) -> list[str]:
    sizes = []
    for n in list(names)[:probe]:
        img = cv2.imread(str(root / n / "0.jpg"), cv2.IMREAD_UNCHANGED)
        if img is not None:
            sizes.append(f"{img.shape[1]}x{img.shape[0]}")
    return sorted(set(sizes))


def _pose_checks(ds: GNMDataset) -> list[str]:
    """Odd cases in the poses of a dataset's trajectories (empty: none); vectorised over the whole cache."""
    cache, notes = ds.cache, []
    starts, lengths = np.asarray(cache.traj_start, np.int64), np.asarray(cache.traj_len, np.int64)
    pos, yaw = np.asarray(cache.position), np.asarray(cache.yaw)
    dist = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    inside = np.ones(len(dist), bool)
    inside[(starts + lengths - 1)[:-1]] = False  # the step from one trajectory's last frame to the next's first
    moved = dist[inside & (dist > MOVE_EPS)]
    per_frame = cache.spacing  # metric_waypoint_spacing of one frame (before the stride)
    if len(moved):
        median = float(np.median(moved))
        if abs(median - per_frame) > SPACING_TOLERANCE * per_frame:
            notes.append(f"frames that move are {median:.3f} m apart (median), metric_waypoint_spacing says "
                         f"{per_frame:.3f}: check the dataset's data_config.yaml or its metric_waypoint_spacing")
    constant = (np.maximum.reduceat(yaw, starts) - np.minimum.reduceat(yaw, starts)) < 1e-6
    fixed_yaw = 0
    for start, length in zip(starts[constant].tolist(), lengths[constant].tolist()):  # rare: look closer
        step = np.diff(pos[start:start + length], axis=0)
        step = step[np.linalg.norm(step, axis=1) > MOVE_EPS]
        heading = np.unwrap(np.arctan2(step[:, 1], step[:, 0])) if len(step) > 1 else np.zeros(1)
        fixed_yaw += int(np.ptp(heading) > TURN_RAD)
    if fixed_yaw:
        notes.append(f"{fixed_yaw} trajectories turn with a constant yaw: their waypoint labels stay in the first "
                     "frame's heading; record the yaw (e.g. from the motion direction) before training on them")
    return notes


def dataset_report(dataset: GNMDataset | MixtureDataset, entries: Sequence[Mapping]) -> dict:
    """``{"text": lines for the log, "datasets": one dict per dataset}``."""
    parts = dataset.datasets if isinstance(dataset, MixtureDataset) else [dataset]
    shares = dataset.weights if isinstance(dataset, MixtureDataset) else np.ones(1)
    rows, lines = [], []
    for ds, e, share in zip(parts, entries, shares.tolist()):
        cache = ds.cache
        root = Path(str(e["root"])).expanduser()
        row = {"name": e.get("name") or cache.name or root.name, "root": str(root.resolve()),
               "trajectories": len(cache.names), "frames": int(cache.traj_len.sum()), "samples": len(ds),
               "metric_waypoint_spacing": float(cache.spacing), "waypoint_spacing": int(ds.stride),
               "step_m": float(ds.spacing), "image_sizes": _image_sizes(root, cache.names), "share": round(share, 4),
               "skipped_short": len(ds.skipped), "notes": _pose_checks(ds)}
        rows.append(row)
        skipped = f", {row['skipped_short']} skipped (too short for the context and the first goal)" \
            if row["skipped_short"] else ""
        lines.append(f"  {row['name']}: {row['trajectories']} trajectories, {row['frames']} frames, {row['samples']} "
                     f"samples, {row['step_m']:.3f} m per step ({row['metric_waypoint_spacing']:.3f} m x "
                     f"{row['waypoint_spacing']} frames), images {', '.join(row['image_sizes']) or '?'}, "
                     f"{100 * share:.1f} % of each batch{skipped} ({row['root']})")
        lines += [f"    note: {n}" for n in row["notes"]]
    return {"text": "\n".join(lines), "datasets": rows}

"""Collision clips of an `rvn-gen` dataset: list trajectories, collisions by scene, load a
clip, dataset statistics (notebooks/collision_clips.ipynb).

A trajectory is a GNM folder ``<root>/<name>/`` with ``0.jpg … (T−1).jpg``,
``traj_data.pkl`` and the sidecar ``rvn_meta.json`` (scene, spec, start, goal, A* waypoints,
``t_c`` = index of the collision frame in the clip, ``contact``, settings). Drawing lives in
`rvn_data.inspect.maps` and `rvn_data.inspect.plots`.
"""
from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvn_data.dataset.reader import META_NAME, TRAJ_DATA, is_complete, load_traj_data, read_meta, read_rgb, rvn_trajectories


@dataclass
class Clip:
    """One trajectory: frames (uint8 [T,H,W,3] RGB), planar poses [T,2], yaws [T], its sidecar."""

    name: str
    frames: np.ndarray
    planar: np.ndarray
    yaw: np.ndarray
    meta: dict

    @property
    def t_c(self) -> int | None:
        """Index of the collision frame within the clip (None for an expert trajectory)."""
        return self.meta.get("t_c")

    @property
    def scene(self) -> str:
        return str(self.meta.get("scene", "?"))

    def __len__(self) -> int:
        return len(self.frames)


def _check_root(root: str | Path) -> Path:
    root = Path(root).expanduser()
    if not root.is_dir():
        raise ValueError(f"dataset folder {root} does not exist; generate one with "
                         f"`rvn-gen dataset=negative out_dir={root}` or set RVN_DATASET")
    return root


def list_trajectories(root: str | Path) -> list[dict]:
    """Sidecars (``rvn_meta.json``) of every complete trajectory under ``root``, sorted by name."""
    root = _check_root(root)
    metas = [read_meta(root / name) for name in rvn_trajectories(root)]
    if not metas:
        raise ValueError(f"dataset folder {root} holds no trajectory (no <name>/{META_NAME} with {TRAJ_DATA}); "
                         "is it an rvn-gen output directory?")
    return metas


def collisions(metas: list[dict]) -> list[dict]:
    """The trajectories that end in a collision: one row per clip (name, scene, frames, t_c,
    t_c_episode, path_length, collision point)."""
    rows = []
    for m in metas:
        if m.get("t_c") is None:
            continue
        rows.append({"name": m["name"], "scene": m["scene"], "frames": m["frames"], "t_c": m["t_c"],
                     "t_c_episode": m.get("t_c_episode"), "path_length": m["path_length"],
                     "collision_planar": m.get("collision_planar")})
    return rows


def collisions_by_scene(metas: list[dict]) -> list[dict]:
    """One row per scene: trajectories, collisions, mean t_c_episode (steps from the start
    to the collision), mean frames, mean A* path length (m)."""
    groups: dict[str, list[dict]] = defaultdict(list)
    for m in metas:
        groups[m["scene"]].append(m)
    rows = []
    for scene in sorted(groups):
        ms = groups[scene]
        hits = [m for m in ms if m.get("t_c") is not None]
        steps = [m["t_c_episode"] for m in hits if m.get("t_c_episode") is not None]
        rows.append({"scene": scene, "trajectories": len(ms), "collisions": len(hits),
                     "mean_steps_to_collision": round(float(np.mean(steps)), 2) if steps else None,
                     "mean_frames": round(float(np.mean([m["frames"] for m in ms])), 2),
                     "mean_path_length": round(float(np.mean([m["path_length"] for m in ms])), 3)})
    return rows


def markdown_table(rows: list[dict], columns: list[str] | None = None) -> str:
    """Rows of dicts as a markdown table (floats with 3 decimals, None as '-')."""
    if not rows:
        return "(no rows)\n"
    columns = columns or list(rows[0])

    def cell(v) -> str:
        if v is None:
            return "-"
        if isinstance(v, float):
            return f"{v:.3f}"
        if isinstance(v, (list, tuple)):
            return "(" + ", ".join(f"{x:.2f}" if isinstance(x, float) else str(x) for x in v) + ")"
        return str(v)

    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(cell(r.get(c)) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def load_clip(root: str | Path, name: str) -> Clip:
    """Frames, poses and sidecar of trajectory ``name``."""
    root = _check_root(root)
    folder = root / name
    if not is_complete(folder):
        raise ValueError(f"{folder} is not a complete trajectory (needs {TRAJ_DATA} and {META_NAME}); "
                         "pick a name from list_trajectories()")
    meta = read_meta(folder)
    planar, yaw = load_traj_data(folder)
    frames = [read_rgb(folder / f"{i}.jpg") for i in range(len(planar))]
    return Clip(name, np.stack(frames), planar, yaw, meta)


def first_collision(metas: list[dict]) -> str:
    """Name of the first trajectory (by name) that ends in a collision."""
    for m in metas:
        if m.get("t_c") is not None:
            return m["name"]
    raise ValueError("no trajectory of this dataset ends in a collision; open a negative dataset "
                     "(rvn-gen dataset=negative)")


def dataset_stats(metas: list[dict]) -> dict[str, np.ndarray | dict]:
    """Arrays for the statistics plots: ``frames`` per trajectory, ``t_c`` (collision frame in
    the clip), ``t_c_episode`` (steps before the collision), ``path_length`` (A*, m),
    ``geodesic`` (start → goal, m) and ``per_scene`` = scene → collisions."""
    hits = [m for m in metas if m.get("t_c") is not None]
    per_scene: dict[str, int] = {}
    for m in metas:
        per_scene[m["scene"]] = per_scene.get(m["scene"], 0) + int(m.get("t_c") is not None)
    return {
        "frames": np.array([m["frames"] for m in metas], np.int64),
        "t_c": np.array([m["t_c"] for m in hits], np.int64),
        "t_c_episode": np.array([m["t_c_episode"] for m in hits if m.get("t_c_episode") is not None], np.int64),
        "path_length": np.array([m["path_length"] for m in metas], np.float64),
        "geodesic": np.array([m["geodesic"] for m in metas if m.get("geodesic") is not None], np.float64),
        "per_scene": dict(sorted(per_scene.items())),
    }


__all__ = ["Clip", "collisions", "collisions_by_scene", "dataset_stats", "first_collision", "list_trajectories",
           "load_clip", "markdown_table"]

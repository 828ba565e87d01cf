"""GNM datasets for the models: the packed HDF5 cache and the torch Dataset (folders are read
with `rvn_data.dataset.reader`)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping

from .cache import PackedCache, cache_path, ensure_cache
from .dataset import BatchView, EpochSampler, GNMDataset, check_waypoint_frames
from .mixture import MixtureDataset, dataset_seed
from .depth import depth_setting
from .depth_frames import DepthFrames, depth_seed
from rvn_data.dataset.reader import GNMSource, load_gnm, read_meta
from .images import crop_setting, preprocess_image


def packed_cache(source: GNMSource, model_cfg: Mapping, d: Mapping, crop: str, depth: int | None,
                 build: bool) -> PackedCache:
    """The packed cache of ``source`` at the model's image size (``data_cfg`` ``d``: cache_dir, cache_threads,
    progress), built when missing or stale; ``build=False`` only opens it (DDP non-zero ranks)."""
    if build:
        path = ensure_cache(source, model_cfg["image_size"], crop, d.get("cache_dir"), int(d.get("cache_threads", 4)),
                            progress=bool(d.get("progress", True)), depth=depth)
    else:
        path = cache_path(source, model_cfg["image_size"], crop, d.get("cache_dir"), depth)
    return PackedCache(path)


def make_dataset(root: str | Path, model_cfg: Mapping, data_cfg: Mapping | None = None, seed: int = 0,
                 build: bool = True, depth: bool = True) -> GNMDataset:
    """GNM folder → (cached) GNMDataset for a size-resolved model config. ``data_cfg`` keys:
    split, splits_dir, name, metric_waypoint_spacing, crop (aspect | official | none; see
    :mod:`.images`), cache_dir, cache_threads, goal_offset, end_slack, skip_short, waypoint_frames (all | moving),
    pad_context, waypoint_spacing (frames between steps, default 1).
    ``build=False`` only opens an existing cache (DDP non-zero ranks). Items carry the depth
    target when ``model.depth_aux_weight`` > 0, unless ``depth=False``."""
    d = dict(data_cfg or {})
    crop = crop_setting(d, model_cfg)  # checked before anything is read
    waypoint_frames = check_waypoint_frames(d.get("waypoint_frames", "all"))
    size = depth_setting(model_cfg) if depth else None
    source = load_gnm(root, d.get("split", "train"), d.get("splits_dir"), d.get("name"), d.get("metric_waypoint_spacing"))
    return GNMDataset(packed_cache(source, model_cfg, d, crop, size, build), model_cfg["context_size"], model_cfg["len_traj_pred"],
                      d.get("goal_offset", (1, 20)), float(model_cfg.get("goal_mask_prob", 0.0)),
                      int(d.get("end_slack", 0)), seed, bool(d.get("skip_short", False)), waypoint_frames,
                      bool(d.get("pad_context", False)), int(d.get("waypoint_spacing", 1)))


def entry_settings(entry: Mapping, data_cfg: Mapping | None) -> dict:
    """``data_cfg`` with one resolved dataset entry's settings (`.sources`) in place of the ``data.*`` ones."""
    d = dict(data_cfg or {})
    for key in ("split", "splits_dir", "name", "metric_waypoint_spacing", "waypoint_spacing", "goal_offset", "end_slack"):
        d[key] = entry[key]
    if entry.get("crop") is not None:
        d["crop"] = entry["crop"]
    return d


def make_training_data(entries: list[Mapping], model_cfg: Mapping, data_cfg: Mapping | None = None, seed: int = 0,
                       build: bool = True, depth: bool = True) -> GNMDataset | MixtureDataset:
    """The resolved datasets of `.sources.dataset_entries` → one GNMDataset, or a MixtureDataset of several."""
    sets = [make_dataset(e["root"], model_cfg, entry_settings(e, data_cfg), dataset_seed(seed, d), build, depth)
            for d, e in enumerate(entries)]
    if len(sets) == 1:
        return sets[0]
    return MixtureDataset(sets, [e["weight"] for e in entries], [e.get("name") or Path(e["root"]).name for e in entries])


def recorded_hfov(root: str | Path, trajectory: str) -> float | None:
    """The horizontal field of view (degrees) of the camera rvn-gen recorded in ``<root>/<trajectory>/rvn_meta.json``:
    from its fx where given (it overrides hfov_deg); None for datasets not written by rvn-gen (the policy's swept
    depth veto then needs policy.depth_veto_hfov)."""
    from rvn_data.render.camera import CameraConfig

    try:
        cam = CameraConfig.from_dict(read_meta(Path(root).expanduser() / trajectory)["settings"]["camera"])
    except (ValueError, KeyError, TypeError):
        return None
    if cam.fx is None and cam.fy is None:
        return float(cam.hfov_deg)
    return math.degrees(2 * math.atan(cam.width / 2 / cam.focal[0]))


def make_depth_frames(root: str | Path, model_cfg: Mapping, data_cfg: Mapping | None = None,
                      build: bool = True) -> DepthFrames:
    """``data.depth_root`` (a GNM folder with depth sidecars) → its (cached) frames for the depth loss
    alone (:mod:`.depth_frames`): every trajectory folder under it, cropped and sized as the model's frames."""
    d = dict(data_cfg or {})
    crop = crop_setting(d, model_cfg)
    size = depth_setting(model_cfg)
    if size is None:
        raise ValueError("data.depth_root trains the depth head: set model.depth_aux_weight > 0 or data.depth_root=null")
    source = load_gnm(root, "all", None, None, d.get("metric_waypoint_spacing"))
    return DepthFrames(packed_cache(source, model_cfg, d, crop, size, build))


__all__ = ["make_dataset", "make_depth_frames", "recorded_hfov", "DepthFrames", "depth_seed", "check_waypoint_frames", "BatchView", "load_gnm", "ensure_cache", "PackedCache", "GNMDataset",
           "EpochSampler", "GNMSource", "preprocess_image", "crop_setting", "depth_setting"]

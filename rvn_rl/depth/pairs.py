"""(RGB, exact depth) pairs for the depth model: camera poses sampled on the navmesh of a
split's scenes, rendered with `rvn_data.render.make_renderer`, stored in one HDF5 file.

Pose k of scene s: a point uniform over the navmesh's sampled islands (the main island unless
navmesh.islands=all) and a yaw uniform in
[-pi, pi), both drawn from ``np.random.default_rng([seed, split_code, scene_index])`` in
that order, so a file is reproducible from its settings. The camera is the robot's (the
``camera`` group: height above the floor, field of view) at ``image_size`` pixels square. Scenes
load with the ``scenes`` group's options (``up_axis``, ``unit_scale``, ``level``), as rvn-gen's and rvn-rl's envs.

File layout: ``rgb`` uint8 [N, H, W, 3], ``depth`` float32 [N, H, W] (planar metres, 0
where nothing was hit), ``scene_index`` int32 [N]; attribute ``meta`` (JSON) holds the
settings that produced it and the code's ``dataset_version`` (`rvn_data.dataset.settings.DATASET_VERSION`, bumped
when the same settings render other frames: a renderer or navmesh fix). A file whose ``meta`` matches the request is
reused; one made by other code is made anew.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path

import numpy as np

from rvn_data.atomic import atomic_path
from rvn_data.dataset.settings import DATASET_VERSION
from rvn_data.navmesh.settings import SAMPLING, NavMeshSettings
from rvn_data.render import RendererConfig
from rvn_data.render.base import CALL_VIEWS
from rvn_data.render.camera import CameraConfig
from rvn_data.scenes.sets import ScenesConfig

SCENE_OPTIONS = ("up_axis", "unit_scale", "level")  # the ``scenes`` group's options of how a mesh loads


def scene_options(scenes: ScenesConfig | dict | None = None) -> dict:
    """``{up_axis, unit_scale, level}`` of a ``scenes`` group (None: the defaults: y-up, metres, not levelled)."""
    scenes = asdict(ScenesConfig()) if scenes is None else scenes if isinstance(scenes, dict) else asdict(scenes)
    return {"up_axis": str(scenes["up_axis"]), "unit_scale": float(scenes["unit_scale"]), "level": bool(scenes["level"])}


def pair_meta(split: str, specs: list[tuple[str, int]], per_scene: int, seed: int, camera: CameraConfig,
              renderer: RendererConfig, navmesh_settings: NavMeshSettings | None = None,
              scenes: dict | None = None) -> dict:
    """The settings that determine a pairs file (compared to decide whether to reuse it); how the scenes load
    (`scene_options`), the navmesh's build settings (its poses are drawn on it) only when they are not the defaults,
    and its islands only when they are not the main island's alone, so files made with the defaults before any of
    them was named keep their meta; the code's ``dataset_version``, so a file rendered before a renderer or navmesh
    fix is made anew."""
    meta = {"dataset_version": DATASET_VERSION, "split": split, "scenes": [[s, int(i)] for s, i in specs],
            "per_scene": int(per_scene),
            "seed": int(seed), "camera": asdict(camera), "renderer_backend": str(renderer.backend)}
    if scenes is not None and scene_options(scenes) != scene_options():
        meta["scene_options"] = scene_options(scenes)
    if navmesh_settings is None:
        return meta
    def build(settings: NavMeshSettings) -> dict:
        return {k: v for k, v in settings.to_dict().items() if k not in SAMPLING}

    if build(navmesh_settings) != build(NavMeshSettings()):
        meta["navmesh"] = build(navmesh_settings)
    if navmesh_settings.islands != "main":
        meta["navmesh_islands"] = [navmesh_settings.islands, navmesh_settings.min_island_radius]
    return meta


def split_scenes(source: str, split: str, num_scenes: int, first_scene: int = 0, root=None) -> list[tuple[str, int]]:
    """(spec, scene index within the split) of ``num_scenes`` scenes from ``first_scene`` on."""
    from rvn_data.scenes.sets import scene_specs

    specs = list(scene_specs(source, split, root=root, num_scenes=num_scenes, first_scene=first_scene))
    if len(specs) < num_scenes:
        raise ValueError(f"pairs: the {split} split has only {len(specs)} scenes from scene {first_scene} on, "
                         f"{num_scenes} requested; lower pairs.{split}_scenes")
    return [(spec, first_scene + i) for i, spec in enumerate(specs)]


def render_scene_pairs(spec: str, scene_index: int, split: str, per_scene: int, seed: int, camera: CameraConfig,
                       navmesh_settings: NavMeshSettings, renderer: RendererConfig,
                       scenes: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(rgb uint8 [K, H, W, 3], depth float32 [K, H, W]) of ``per_scene`` poses in one scene, loaded with the
    ``scenes`` options (`scene_options`; None: the defaults)."""
    from rvn_data.benchmark.episodes import split_code
    from rvn_data.navmesh.source import open_scene
    from rvn_data.render import make_renderer

    scene, navmesh = open_scene(spec, scene_options(scenes), navmesh_settings)
    rng = np.random.default_rng([int(seed), split_code(split), int(scene_index)])
    rgb = np.empty((per_scene, camera.height, camera.width, 3), np.uint8)
    depth = np.empty((per_scene, camera.height, camera.width), np.float32)
    poses = [(navmesh.sample(rng), float(rng.uniform(-math.pi, math.pi))) for _ in range(per_scene)]
    with make_renderer(scene, camera, backend=renderer.backend, device=renderer.device) as r:
        for k in range(0, per_scene, CALL_VIEWS):
            rgb[k:k + CALL_VIEWS], depth[k:k + CALL_VIEWS] = r.render_batch(poses[k:k + CALL_VIEWS])
    return rgb, depth


def read_meta(path: Path) -> dict | None:
    """The ``meta`` of a pairs file, or None when it is missing or unreadable."""
    import h5py

    if not path.is_file():
        return None
    try:
        with h5py.File(path, "r") as f:
            return json.loads(f.attrs["meta"])
    except (OSError, KeyError, ValueError):
        return None


def make_pairs(path: str | Path, split: str, specs: list[tuple[str, int]], per_scene: int, seed: int,
               camera: CameraConfig, navmesh_settings: NavMeshSettings, renderer: RendererConfig,
               progress: bool = False, scenes: dict | None = None) -> tuple[Path, bool]:
    """Render the pairs of ``specs`` into ``path`` (atomic), the scenes loaded with the ``scenes`` options
    (`scene_options`; None: the defaults); returns (path, reused) where ``reused`` says an existing file with the
    same settings was kept."""
    import h5py
    from tqdm import tqdm

    path = Path(path)
    meta = pair_meta(split, specs, per_scene, seed, camera, renderer, navmesh_settings, scenes)
    if read_meta(path) == meta:
        return path, True
    n, h, w = len(specs) * per_scene, camera.height, camera.width
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            d_rgb = f.create_dataset("rgb", (n, h, w, 3), np.uint8, chunks=(1, h, w, 3))
            d_depth = f.create_dataset("depth", (n, h, w), np.float32, chunks=(1, h, w))
            f.create_dataset("scene_index", data=np.repeat([i for _, i in specs], per_scene).astype(np.int32))
            for j, (spec, index) in enumerate(tqdm(specs, desc=f"pairs {split}", unit="scene", disable=not progress)):
                rgb, depth = render_scene_pairs(spec, index, split, per_scene, seed, camera, navmesh_settings, renderer,
                                                scenes)
                d_rgb[j * per_scene:(j + 1) * per_scene] = rgb
                d_depth[j * per_scene:(j + 1) * per_scene] = depth
            f.attrs["meta"] = json.dumps(meta)
    return path, False


def read_pairs(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(rgb uint8 [N, H, W, 3], depth float32 [N, H, W]) of a pairs file."""
    import h5py

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"pairs file {path} not found; create it with python -m rvn_rl.depth.cli")
    with h5py.File(path, "r") as f:
        if "rgb" not in f or "depth" not in f:
            raise ValueError(f"pairs file {path} has no rgb/depth datasets; delete it and run the CLI again")
        return f["rgb"][:], f["depth"][:]

"""First-person sample views of a scene from random navigable poses (`rvn-scene views`)."""
from __future__ import annotations

import json
import math
import os
from dataclasses import asdict
from pathlib import Path

import cv2
import numpy as np

from rvn_data.atomic import write_bytes_atomic
from rvn_data.render.camera import CameraConfig
from rvn_data.scenes.scene import Scene

DEPTH_VIS_MAX = 10.0  # m: depth PNGs map 0..DEPTH_VIS_MAX onto the colour map, misses are black


def depth_to_color(depth: np.ndarray, max_depth: float = DEPTH_VIS_MAX) -> np.ndarray:
    """Planar depth [H, W] (0 = no hit) -> uint8 RGB [H, W, 3] with the turbo colour map."""
    d = np.clip(np.asarray(depth, np.float32) / max_depth, 0.0, 1.0)
    bgr = cv2.applyColorMap((d * 255.0 + 0.5).astype(np.uint8), cv2.COLORMAP_TURBO)
    bgr[depth <= 0] = 0
    return bgr[:, :, ::-1].copy()


def _write_png(path: Path, rgb: np.ndarray) -> None:
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(rgb[:, :, ::-1]))
    if not ok:
        raise OSError(f"could not encode {path}")
    write_bytes_atomic(path, buf.tobytes())


def write_views(scene: Scene | str, out_dir, n: int = 8, seed: int = 0, backend: str = "auto",
                camera: CameraConfig | None = None, navmesh=None) -> list[Path]:
    """Render `n` views from navigable poses drawn with seed `seed`; return the PNG paths.

    Writes `view_XX_rgb.png`, `view_XX_depth.png` (turbo colour map, 0..10 m) and
    `views.json` (scene, seed, camera, poses) into `out_dir`. `scene` may be a spec for
    `load_scene`; `navmesh` defaults to `NavMesh.build(scene, NavMeshSettings())`.
    """
    from rvn_data.render import make_renderer

    if isinstance(n, bool) or not isinstance(n, int) or n <= 0:
        raise ValueError(f"n={n!r}: the number of views must be a positive integer")
    if isinstance(scene, (str, os.PathLike)):
        from rvn_data.scenes.loader import load_scene

        scene = load_scene(scene)
    if navmesh is None:
        from rvn_data.navmesh import NavMesh, NavMeshSettings

        navmesh = NavMesh.build(scene, NavMeshSettings())
    camera = camera or CameraConfig()
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise OSError(f"views output {out} exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng([int(seed), 0x56494557])  # "VIEW"
    poses = [(navmesh.sample(rng), float(rng.uniform(-math.pi, math.pi))) for _ in range(n)]
    paths: list[Path] = []
    with make_renderer(scene, camera, backend=backend) as renderer:
        rgbs, depths = renderer.render_batch(poses)
        for i, (rgb, depth) in enumerate(zip(rgbs, depths)):
            for kind, image in (("rgb", rgb), ("depth", depth_to_color(depth))):
                path = out / f"view_{i:02d}_{kind}.png"
                _write_png(path, image)
                paths.append(path)
        meta = {"scene": scene.scene_id, "seed": int(seed), "backend": renderer.backend,
                "renderer": renderer.info, "camera": asdict(camera), "depth_png_max_m": DEPTH_VIS_MAX,
                "poses": [{"position": [float(x) for x in p], "yaw": y} for p, y in poses]}
    write_bytes_atomic(out / "views.json", json.dumps(meta, indent=1).encode())
    return paths

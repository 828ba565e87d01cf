"""GNM trajectory folders, written atomically (the layout visualnav-transformer's
training code reads).

``<out>/<name>/{0..T-1}.jpg`` (JPEG, fixed quality), ``traj_data.pkl`` = dict(position
float64 [T, 2] planar metres, yaw float64 [T]) pickled with protocol 4, and the sidecar
``rvn_meta.json`` (GNM readers ignore it). With ``dataset.save_depth`` the folder also holds
the sidecar ``depth.npy``: float16 [T, S, S], metres, row i the rendered depth of frame i
(`downsample_depth`; 0 where no pixel of the block hit anything). A folder is assembled under
``<out>/.rvn/tmp/<name>`` and moved into place with one `os.replace`, so it is either
complete or absent.
"""
from __future__ import annotations

import json
import os
import pickle
import shutil
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from rvn_data.atomic import write_text_atomic  # noqa: F401 (used as writer.write_text_atomic)
from rvn_data.dataset.reader import DEPTH_NAME, META_NAME, TRAJ_DATA

PICKLE_PROTOCOL = 4


def encode_jpeg(rgb: np.ndarray, quality: int) -> bytes:
    """RGB uint8 [H, W, 3] → JPEG bytes (OpenCV expects BGR, so channels are swapped)."""
    ok, buf = cv2.imencode(".jpg", np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("JPEG encoding failed")
    return buf.tobytes()


def downsample_depth(depth: np.ndarray, size: int) -> np.ndarray:
    """Rendered depth float32 [H, W] (metres, 0 = nothing hit) → float16 [size, size]: the mean
    over the block's pixels that hit something (area resampling of depth and hit mask), 0 where
    none did."""
    depth = np.asarray(depth, dtype=np.float32)
    hit = (depth > 0).astype(np.float32)
    total = cv2.resize(depth * hit, (size, size), interpolation=cv2.INTER_AREA)
    share = cv2.resize(hit, (size, size), interpolation=cv2.INTER_AREA)
    out = np.divide(total, share, out=np.zeros_like(total), where=share > 1e-6)
    return out.astype(np.float16)


def record_path(out_dir: Path, slug: str) -> Path:
    """A scene's record, written when the scene is done."""
    return Path(out_dir) / ".rvn" / "scenes" / f"{slug}.json"


def read_record(path: Path) -> dict | None:
    """A scene's record at ``path``; None where there is none, or it does not parse: a node that crashed after the
    rename, before the disk had the data, can leave it empty (the scene is done again from the trajectories on disk,
    as after an interrupted run, instead of failing every rerun and every shard's splits)."""
    try:
        return json.loads(Path(path).read_text())
    except (FileNotFoundError, ValueError):  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        return None


def dumps_json(obj: Any) -> str:
    """Stable JSON text (sorted keys, fixed float repr) for files compared byte for byte."""
    return json.dumps(obj, indent=1, sort_keys=True, allow_nan=False) + "\n"


def write_trajectory(out_dir: Path, name: str, jpegs: list[bytes], position: np.ndarray, yaw: np.ndarray,
                     meta: dict, depth: np.ndarray | None = None) -> None:
    """Write one GNM trajectory folder atomically. `jpegs[i]` is frame i; `depth` (float16
    [T, S, S] or None) is written as the sidecar depth.npy."""
    position = np.ascontiguousarray(position, dtype=np.float64).reshape(-1, 2)
    yaw = np.ascontiguousarray(yaw, dtype=np.float64).reshape(-1)
    if not len(jpegs) == len(position) == len(yaw) > 0:
        raise ValueError(f"trajectory {name}: {len(jpegs)} images, {len(position)} positions, {len(yaw)} yaws")
    if depth is not None and len(depth) != len(jpegs):
        raise ValueError(f"trajectory {name}: {len(jpegs)} images, {len(depth)} depth maps")
    out_dir = Path(out_dir)
    tmp = out_dir / ".rvn" / "tmp" / name
    if tmp.exists():
        shutil.rmtree(tmp)  # left over by an interrupted run
    tmp.mkdir(parents=True)
    for i, data in enumerate(jpegs):
        (tmp / f"{i}.jpg").write_bytes(data)
    with open(tmp / TRAJ_DATA, "wb") as fh:
        pickle.dump({"position": position, "yaw": yaw}, fh, protocol=PICKLE_PROTOCOL)
    (tmp / META_NAME).write_text(dumps_json(meta))
    if depth is not None:
        np.save(tmp / DEPTH_NAME, np.ascontiguousarray(depth, dtype=np.float16))
    os.replace(tmp, out_dir / name)

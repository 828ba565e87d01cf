"""GNM trajectory folders, written atomically (SPEC.md "GNM format").

``<out>/<name>/{0..T-1}.jpg`` (JPEG, fixed quality), ``traj_data.pkl`` = dict(position
float64 [T, 2] planar metres, yaw float64 [T]) pickled with protocol 4, and the sidecar
``rvn_meta.json`` (GNM readers ignore it). A folder is assembled under
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

PICKLE_PROTOCOL = 4
META_NAME = "rvn_meta.json"
TRAJ_DATA = "traj_data.pkl"


def encode_jpeg(rgb: np.ndarray, quality: int) -> bytes:
    """RGB uint8 [H, W, 3] → JPEG bytes (OpenCV expects BGR, so channels are swapped)."""
    ok, buf = cv2.imencode(".jpg", np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("JPEG encoding failed")
    return buf.tobytes()


def dumps_json(obj: Any) -> str:
    """Stable JSON text (sorted keys, fixed float repr) for files compared byte for byte."""
    return json.dumps(obj, indent=1, sort_keys=True, allow_nan=False) + "\n"


def is_complete(out_dir: Path, name: str) -> bool:
    """True when the trajectory folder exists (folders only appear complete)."""
    d = Path(out_dir) / name
    return (d / TRAJ_DATA).is_file() and (d / META_NAME).is_file()


def read_meta(out_dir: Path, name: str) -> dict:
    return json.loads((Path(out_dir) / name / META_NAME).read_text())


def write_trajectory(out_dir: Path, name: str, jpegs: list[bytes], position: np.ndarray, yaw: np.ndarray,
                     meta: dict) -> None:
    """Write one GNM trajectory folder atomically. `jpegs[i]` is frame i."""
    position = np.ascontiguousarray(position, dtype=np.float64).reshape(-1, 2)
    yaw = np.ascontiguousarray(yaw, dtype=np.float64).reshape(-1)
    if not len(jpegs) == len(position) == len(yaw) > 0:
        raise ValueError(f"trajectory {name}: {len(jpegs)} images, {len(position)} positions, {len(yaw)} yaws")
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
    os.replace(tmp, out_dir / name)

"""Image preprocessing shared by the HDF5 cache (training) and the policies (deployment).

One function, so that a policy feeds its model exactly what the model saw in training:
centre-crop to the target aspect ratio (optional, as visualnav-transformer's training
crop), then resize with OpenCV's INTER_AREA to ``image_size = (W, H)``; uint8 RGB in and out.
ImageNet normalisation happens inside the models, not here.
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import cv2
import numpy as np


def center_crop_to_aspect(rgb: np.ndarray, aspect: float) -> np.ndarray:
    """Largest centred crop of ``rgb`` [h,w,3] whose width/height equals ``aspect``."""
    h, w = rgb.shape[:2]
    if abs(w / h - aspect) < 1e-6:
        return rgb
    if w / h > aspect:  # too wide: crop columns
        new_w = max(1, int(round(h * aspect)))
        x0 = (w - new_w) // 2
        return rgb[:, x0:x0 + new_w]
    new_h = max(1, int(round(w / aspect)))
    y0 = (h - new_h) // 2
    return rgb[y0:y0 + new_h]


def preprocess_image(rgb: np.ndarray, image_size: Sequence[int], crop_to_aspect: bool = True) -> np.ndarray:
    """uint8 RGB [h,w,3] → uint8 RGB [H,W,3] with ``image_size = (W, H)``."""
    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"expected a uint8 RGB image [H,W,3], got {rgb.dtype} {rgb.shape}")
    w, h = int(image_size[0]), int(image_size[1])
    if crop_to_aspect:
        rgb = center_crop_to_aspect(rgb, w / h)
    if rgb.shape[0] == h and rgb.shape[1] == w:
        return np.ascontiguousarray(rgb)
    return cv2.resize(rgb, (w, h), interpolation=cv2.INTER_AREA)


def read_rgb(path: str | Path) -> np.ndarray:
    """Decode an image file to uint8 RGB [h,w,3]; ValueError naming the file if unreadable."""
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"cannot decode image {path}: the file is missing or corrupt; regenerate the trajectory or remove it from the split")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)

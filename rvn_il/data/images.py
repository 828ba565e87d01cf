"""Image preprocessing shared by the HDF5 cache (training) and the policies (deployment).

One function, so that a policy feeds its model exactly what the model saw in training: a
centre crop chosen by the ``data.crop`` setting, then a resize with OpenCV's INTER_AREA to
``image_size = (W, H)``; uint8 RGB in and out. ImageNet normalisation happens inside the
models, not here. The crops:

- ``aspect`` (default): the largest centred crop with the aspect ratio W/H of ``image_size``,
  so the resize does not distort the frame. This is RVN's own choice, not the official one.
- ``official``: the crop of visualnav-transformer's data loader (``resize_and_aspect_crop`` in
  vint_train/data/data_utils.py): every frame is centre-cropped to 4:3 (width:height)
  whatever ``image_size`` is, then stretched to ``image_size``. A frame wider than tall keeps
  its height and is cut to width ``int(h·4/3)``; any other frame keeps its width and is cut to
  height ``int(w·3/4)`` (a square frame loses 12.5 % at the top and at the bottom). Offsets
  and padding follow torchvision's ``center_crop``, which that loader calls. Use it to train
  or evaluate checkpoints as the official code does; the resize stays INTER_AREA (the official
  loader uses PIL's default resampling).
- ``none``: no crop; the resize stretches the frame to ``image_size``.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import cv2
import numpy as np

CROPS = ("aspect", "official", "none")
OFFICIAL_ASPECT = 4 / 3  # visualnav-transformer's IMAGE_ASPECT_RATIO, width / height


def check_crop(crop: object, setting: str = "data.crop") -> str:
    """``crop`` as one of :data:`CROPS`; ``True``/``False`` (the former ``crop_to_aspect``) mean
    aspect/none. A ValueError names ``setting`` for anything else."""
    if isinstance(crop, (bool, np.bool_)):
        return "aspect" if crop else "none"
    if crop not in CROPS:
        raise ValueError(f"{setting}={crop!r}; choose aspect, official or none")
    return str(crop)


def crop_setting(*sources: Mapping | None, setting: str = "data.crop") -> str:
    """The crop named by the first of ``sources`` (configs or checkpoint stats) that holds one:
    its ``crop`` key, or the ``crop_to_aspect`` flag of configs and stats written before that key
    existed (true → aspect, false → none). ``aspect`` when none does."""
    for src in sources:
        if not src:
            continue
        if src.get("crop") is not None:
            return check_crop(src["crop"], setting)
        if src.get("crop_to_aspect") is not None:
            return check_crop(bool(src["crop_to_aspect"]), setting)
    return "aspect"


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


def official_crop(rgb: np.ndarray) -> np.ndarray:
    """visualnav-transformer's 4:3 centre crop of ``rgb`` [h,w,3] (see the module docstring):
    crop size ``(h, int(h·4/3))`` if w > h else ``(int(w/(4/3)), w)``, then torchvision's
    ``center_crop``: zero padding where the crop is larger than the frame, offsets
    ``round((size - crop) / 2)``."""
    h, w = rgb.shape[:2]
    ch, cw = (h, int(h * OFFICIAL_ASPECT)) if w > h else (int(w / OFFICIAL_ASPECT), w)
    if cw > w or ch > h:
        pad_w, pad_h = max(cw - w, 0), max(ch - h, 0)
        rgb = np.pad(rgb, ((pad_h // 2, (pad_h + 1) // 2), (pad_w // 2, (pad_w + 1) // 2), (0, 0)))
        h, w = rgb.shape[:2]
    top, left = int(round((h - ch) / 2.0)), int(round((w - cw) / 2.0))
    return rgb[top:top + ch, left:left + cw]


def preprocess_image(rgb: np.ndarray, image_size: Sequence[int], crop: str | bool = "aspect") -> np.ndarray:
    """uint8 RGB [h,w,3] → uint8 RGB [H,W,3] with ``image_size = (W, H)``, cropped by ``crop``
    (aspect | official | none; True/False mean aspect/none)."""
    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"expected a uint8 RGB image [H,W,3], got {rgb.dtype} {rgb.shape}")
    crop = check_crop(crop)
    w, h = int(image_size[0]), int(image_size[1])
    if crop == "aspect":
        rgb = center_crop_to_aspect(rgb, w / h)
    elif crop == "official":
        rgb = official_crop(rgb)
    if rgb.shape[0] == h and rgb.shape[1] == w:
        return np.ascontiguousarray(rgb)
    return cv2.resize(rgb, (w, h), interpolation=cv2.INTER_AREA)

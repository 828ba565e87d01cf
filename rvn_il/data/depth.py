"""Depth sidecars of a GNM dataset for the auxiliary depth loss (``model.depth_aux_weight``).

``rvn-gen dataset.save_depth=true`` writes ``<traj>/depth.npy`` beside the frames: float16
[T, S, S], metres, row i the rendered depth of frame ``i.jpg`` averaged over S×S blocks (0
where nothing was hit). Third-party GNM datasets have none. The packed cache copies them
when the model asks for depth (:func:`depth_setting`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Mapping

import numpy as np


from rvn_data.dataset.reader import DEPTH_NAME, GNMSource

REGENERATE = "regenerate with rvn-gen dataset.save_depth=true or set model.depth_aux_weight=0"


def depth_setting(model_cfg: Mapping) -> int | None:
    """Side S of the depth targets when ``model.depth_aux_weight`` > 0, else None (no depth)."""
    weight = model_cfg.get("depth_aux_weight") or 0.0
    if isinstance(weight, bool) or not isinstance(weight, (int, float)) or not np.isfinite(weight) or weight < 0:
        raise ValueError(f"model.depth_aux_weight={weight!r} must be a finite number >= 0 (0: no depth loss)")
    if weight == 0:
        return None
    size = model_cfg.get("depth_size", 16)
    if isinstance(size, bool) or not isinstance(size, int) or size < 1:
        raise ValueError(f"model.depth_size={size!r} must be a positive integer")
    return size


def has_depth(root: str | Path, names: list[str]) -> bool:
    """True when the first trajectory of ``names`` under ``root`` has a depth sidecar (rvn-gen writes
    all or none; the cache build checks every one)."""
    return bool(names) and (Path(root) / names[0] / DEPTH_NAME).is_file()


def require_depth(source: GNMSource) -> None:
    """ValueError naming the dataset and the first trajectory without a depth sidecar, if any."""
    for name in source.names:
        if not (source.root / name / DEPTH_NAME).is_file():
            raise ValueError(f"dataset {source.root}: trajectory {name} has no {DEPTH_NAME}; {REGENERATE}")


def load_traj_depth(source: GNMSource, i: int, size: int) -> np.ndarray:
    """float16 [T, size, size] of trajectory ``i``; ValueError naming the file when it is absent
    or does not fit the trajectory."""
    path = source.root / source.names[i] / DEPTH_NAME
    try:
        depth = np.load(path)
    except FileNotFoundError:
        raise ValueError(f"dataset {source.root}: trajectory {source.names[i]} has no {DEPTH_NAME}; {REGENERATE}") from None
    except (OSError, ValueError) as e:
        raise ValueError(f"corrupt depth sidecar {path} ({e}); regenerate the dataset") from None
    expected = (len(source.positions[i]), size, size)
    if depth.shape != expected:
        raise ValueError(f"depth sidecar {path} is {list(depth.shape)}, expected [T, S, S] = {list(expected)} "
                         f"(model.depth_size={size}; rvn-gen dataset.depth_size must match)")
    return depth.astype(np.float16)

"""Forward veto by the model's own depth head (``policy.depth_veto``; a departure, off by default).

A checkpoint trained with the auxiliary depth loss (``model.depth_aux_weight`` > 0,
:mod:`rvn_il.models.base`) has a head that predicts the current frame's depth on an S×S grid
from the same RGB token the policy encodes anyway. With ``depth_veto = z`` (metres), when the
policy's action is MOVE_FORWARD but the predicted clearance ahead (the nearest predicted depth
in the central half of the grid's columns) is below ``z``, the policy turns instead: to the side
more of its samples turn to, else to the side its depth grid sees more open. Nothing outside the
RGB frame is used: the depth is predicted, as in the paper's "DD-PPO + predicted depth" row.

The default camera (90° hfov) sees ±z/2 across the central half of its columns at depth z: at
z = 0.45 m, ±0.23 m, the robot's half-width (r_robot 0.18 m) with a margin. A MOVE_FORWARD of
d_step 0.25 m hits what lies within d_step + r_robot = 0.43 m ahead in that band; the expert
keeps more clearance (``docs/results/2026-11-25_small_experiment_7`` measures it and the head).
"""
from __future__ import annotations

import math

import numpy as np
import torch

from rvn_data.conventions import Action

BAND = 0.5  # central share of the depth grid's columns that a forward step sweeps


def check_depth_veto(value: object, has_depth_head: bool) -> float | None:
    """``policy.depth_veto`` as metres > 0, or None (off); a ValueError naming it otherwise."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"policy.depth_veto={value!r}: give the clearance in metres (> 0, e.g. 0.5) or null (off)")
    if not has_depth_head:
        raise ValueError(f"policy.depth_veto={value}: this checkpoint has no depth head; it needs a model trained with "
                         "model.depth_aux_weight > 0 (rvn-gen dataset.save_depth=true data)")
    return float(value)


@torch.no_grad()
def predicted_depth(depth_head: torch.nn.Module, token: torch.Tensor) -> np.ndarray:
    """Metres [S,S] predicted from the current frame's token [D] (the head predicts log depth)."""
    out = depth_head(token.reshape(1, -1)).float().exp()[0]
    side = math.isqrt(out.numel())
    return out.view(side, side).cpu().numpy()


def clearance(depth: np.ndarray) -> float:
    """Nearest depth (metres) in the central :data:`BAND` of the columns of ``depth`` [S,S]."""
    s = depth.shape[1]
    lo = int(round(s * (1 - BAND) / 2))
    return float(depth[:, lo:s - lo].min())


def turn_instead(sample_actions: list[int], depth: np.ndarray) -> int:
    """TURN_LEFT or TURN_RIGHT: the one more samples lead to; on a tie the side whose half of the
    depth grid is deeper (image left = robot left)."""
    left = sum(a == Action.TURN_LEFT for a in sample_actions)
    right = sum(a == Action.TURN_RIGHT for a in sample_actions)
    if left == right:
        half = depth.shape[1] // 2
        left, right = np.log(depth[:, :half]).mean(), np.log(depth[:, -half:]).mean()
    return int(Action.TURN_LEFT if left > right else Action.TURN_RIGHT)

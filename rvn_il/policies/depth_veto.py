"""Forward veto by the model's own depth head (``policy.depth_veto``; a departure, off by default).

A checkpoint trained with the auxiliary depth loss (``model.depth_aux_weight`` > 0,
:mod:`rvn_il.models.base`) has a head that predicts the current frame's depth on an S×S grid
from the same RGB token the policy encodes anyway. With ``depth_veto = z`` (metres), when the
policy's action is MOVE_FORWARD but the predicted depth shows an obstacle nearer than ``z`` where the
step goes, the policy turns instead: to the side more of its samples turn to, else to the side its
depth grid sees more open. Nothing outside the RGB frame is used: the depth is predicted, as in the
paper's "DD-PPO + predicted depth" row.

Where the step goes (``policy.depth_veto_rule``):
- ``band`` (default): the central half of the grid's columns. The default camera (90° hfov) sees ±z/2
  across them at depth z: at z = 0.45 m, ±0.23 m, the robot's half-width (r_robot 0.18 m) with a margin.
- ``swept``: the rectangle the step sweeps, |x| ≤ r_robot + m and depth < z, with the margin
  m = max(0, z − d_step − r_robot), each column's lateral offset x = depth · tan of its angle. It needs
  the camera's hfov (``policy.depth_veto_hfov``, else what the checkpoint recorded from its training data).
Both look past the bare floor that the grid's lower rows see (`Floor`, from the camera the checkpoint's data was
rendered with: a cell counts where it reads under 80 % of its row's bare-floor depth; a checkpoint without that
record is read as before).
A MOVE_FORWARD of d_step 0.25 m hits what lies within d_step + r_robot = 0.43 m ahead; the expert keeps
more clearance (``docs/results/2026-11-25_small_experiment_7`` and ``_8`` measure both rules and the head).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Mapping

import numpy as np
import torch

from rvn_data.conventions import Action, AgentConfig
from rvn_data.render.camera import CameraConfig

BAND = 0.5  # central share of the depth grid's columns that the band rule checks
RULES = ("band", "swept")
FLOOR_SHARE = 0.8  # a cell reading under this share of its row's bare-floor depth sees something standing there


@dataclass(frozen=True)
class DepthVeto:
    """When a forward step counts as blocked: ``rule`` band or swept (module docstring), ``clearance``
    metres; the swept rule also uses the camera's ``hfov_deg`` and the robot's ``r_robot``, ``d_step``."""

    clearance: float
    rule: str = "band"
    hfov_deg: float | None = None
    r_robot: float = AgentConfig.r_robot
    d_step: float = AgentConfig.d_step

    def __post_init__(self):
        """A ValueError naming the setting (policy.depth_veto / _rule / _hfov) for a bad value."""
        value, hfov_deg = self.clearance, self.hfov_deg
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise ValueError(f"policy.depth_veto={value!r}: give the clearance in metres (> 0, e.g. 0.5) or null (off)")
        if self.rule not in RULES:
            raise ValueError(f"policy.depth_veto_rule={self.rule!r}; choose band (the central half of the columns) or swept "
                             "(the rectangle the forward step sweeps)")
        if self.rule == "swept":
            if hfov_deg is None:
                raise ValueError("policy.depth_veto_rule=swept needs the camera's hfov: this checkpoint does not record "
                                 "it (trained before rvn-train recorded it, or on data not written by rvn-gen); give "
                                 "policy.depth_veto_hfov=<degrees>")
            if isinstance(hfov_deg, bool) or not isinstance(hfov_deg, (int, float)) or not 0 < hfov_deg < 180:
                raise ValueError(f"policy.depth_veto_hfov={hfov_deg!r}: give the camera's horizontal field of view in "
                                 "degrees (0 < hfov < 180)")
            object.__setattr__(self, "hfov_deg", float(hfov_deg))
        for name in ("clearance", "r_robot", "d_step"):
            object.__setattr__(self, name, float(getattr(self, name)))

    def blocked(self, depth: np.ndarray) -> bool:
        """True when the predicted ``depth`` [S,S] (metres) blocks a forward step."""
        if self.rule == "band":
            return clearance(depth) < self.clearance
        tan = (np.arange(depth.shape[1]) + 0.5) / depth.shape[1] * 2 - 1
        tan = tan * math.tan(math.radians(self.hfov_deg) / 2)
        half_width = self.r_robot + max(0.0, self.clearance - self.d_step - self.r_robot)
        return bool(((np.abs(depth * tan[None]) <= half_width) & (depth < self.clearance)).any())


def check_depth_veto(value: object, has_depth_head: bool, rule: object = "band", hfov_deg: object = None,
                     r_robot: float = AgentConfig.r_robot, d_step: float = AgentConfig.d_step) -> DepthVeto | None:
    """``policy.depth_veto`` (metres > 0, a :class:`DepthVeto`, or None: off) as a checked :class:`DepthVeto`
    (its other settings from the arguments when ``value`` is metres); a ValueError naming the setting
    otherwise (``hfov_deg`` is needed by the swept rule only)."""
    if value is None:
        return None
    veto = value if isinstance(value, DepthVeto) else DepthVeto(value, rule, hfov_deg, r_robot, d_step)
    if not has_depth_head:
        shown = veto.clearance if isinstance(value, DepthVeto) else value
        raise ValueError(f"policy.depth_veto={shown}: this checkpoint has no depth head; it needs a model "
                         "trained with model.depth_aux_weight > 0 (rvn-gen dataset.save_depth=true data)")
    return veto


@torch.no_grad()
def predicted_depth(depth_head: torch.nn.Module, token: torch.Tensor) -> np.ndarray:
    """Metres [S,S] predicted from the current frame's token [D] (the head predicts log depth)."""
    out = depth_head(token.reshape(1, -1)).float().exp()[0]
    side = math.isqrt(out.numel())
    return out.view(side, side).cpu().numpy()


def clearance(depth: np.ndarray) -> float:
    """Nearest depth (metres) in the central :data:`BAND` of the columns of ``depth`` [S,S] (inf: none)."""
    s = depth.shape[1]
    lo = int(round(s * (1 - BAND) / 2))
    return float(depth[:, lo:s - lo].min())


@dataclass(frozen=True)
class Floor:
    """Where the depth grid sees bare floor, for the camera the depth head learned from. Its lower rows see the floor
    a little ahead whatever stands beyond: with the default camera (0.6 m high, level, 90 degrees) the bottom row of a
    16 x 16 grid reads ~0.64 m in an empty room, so the nearest depth of a column was never above that, and a clearance
    of 0.65 m or more (`Escape`'s 1 m) found nothing free. `standing` keeps the cells that read less than
    :data:`FLOOR_SHARE` of their row's bare-floor depth (something stands on the floor there)."""

    h_camera: float
    pitch_deg: float
    fy: float  # pixels
    cy: float
    height: int

    @classmethod
    def of(cls, camera: Mapping) -> "Floor":
        """From a camera record (`rvn_data.embodiment`; the settings it lacks at `CameraConfig`'s defaults)."""
        cam = CameraConfig.from_dict(camera)
        return cls(cam.h_camera, cam.pitch_deg, cam.focal[1], cam.principal[1], cam.height)

    @lru_cache(maxsize=4)
    def depths(self, side: int) -> np.ndarray:
        """[side] Each grid row's depth on bare floor: the mean, over its block of pixel rows (as
        `rvn_data.dataset.writer.downsample_depth` pools the rendered frame), of the planar depth at which a pixel
        row's ray meets the floor h_camera below; inf for a block that reaches the horizon."""
        up = -(np.arange(self.height) + 0.5 - self.cy) / self.fy  # camera frame, per metre of planar depth
        pitch = math.radians(self.pitch_deg)
        drop = -(up * math.cos(pitch) + math.sin(pitch))  # metres down in the world per metre of planar depth
        rows = np.where(drop > 1e-9, self.h_camera / np.maximum(drop, 1e-9), np.inf)
        edges = np.linspace(0, self.height, side + 1)
        return np.array([rows[int(a):max(int(math.ceil(b)), int(a) + 1)].mean() for a, b in zip(edges[:-1], edges[1:])])

    def standing(self, depth: np.ndarray) -> np.ndarray:
        """``depth`` [S,S] with the cells that read bare floor set to inf."""
        return np.where(depth < FLOOR_SHARE * self.depths(depth.shape[0])[:, None], depth, np.inf)


def turn_instead(sample_actions: list[int], depth: np.ndarray) -> int:
    """TURN_LEFT or TURN_RIGHT: the one more samples lead to; on a tie the side whose half of the
    depth grid is deeper (image left = robot left)."""
    left = sum(a == Action.TURN_LEFT for a in sample_actions)
    right = sum(a == Action.TURN_RIGHT for a in sample_actions)
    if left == right:
        half = depth.shape[1] // 2
        left, right = np.log(depth[:, :half]).mean(), np.log(depth[:, -half:]).mean()
    return int(Action.TURN_LEFT if left > right else Action.TURN_RIGHT)

"""Frames, poses and actions shared by every module (SPEC.md "Conventions", "GNM format").

World frame: metres, **y up**. The robot moves on the floor plane (x, z).

Planar (GNM) frame: ``planar = (x, -z)``. Yaw ``θ`` is counter-clockwise seen from
above (a right-handed rotation about +y), so the heading of yaw θ is
``(cos θ, 0, -sin θ)`` in the world and ``(cos θ, sin θ)`` in the planar frame.
A MOVE_FORWARD of ``d_step`` from yaw θ changes the planar position by
``d_step·(cos θ, sin θ)``; TURN_LEFT adds ``+θ_step`` to the yaw.

Robot-relative goal (``pointgoal``): ``(x_g, y_g)`` with x forward and y left, metres.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np


class Action(IntEnum):
    """Discrete actions, numbered as in Habitat's PointNav task."""

    STOP = 0
    MOVE_FORWARD = 1
    TURN_LEFT = 2
    TURN_RIGHT = 3


@dataclass(frozen=True)
class AgentConfig:
    """The robot of SPEC.md "Task": a cylinder with a forward camera."""

    r_robot: float = 0.18
    h_robot: float = 1.0
    d_step: float = 0.25
    theta_step_deg: float = 30.0
    allow_sliding: bool = False

    def __post_init__(self) -> None:
        for name in ("r_robot", "h_robot", "d_step", "theta_step_deg"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"agent setting {name}={value!r} must be a positive number")

    @property
    def theta_step(self) -> float:
        """Turn angle in radians."""
        return math.radians(self.theta_step_deg)


@dataclass(frozen=True)
class Pose:
    """Agent pose: ``position`` on the floor (world frame, [3]) and ``yaw`` (radians)."""

    position: np.ndarray
    yaw: float

    def planar(self) -> np.ndarray:
        return to_planar(self.position)


def wrap_angle(a: float | np.ndarray) -> float | np.ndarray:
    """Wrap an angle (or array of angles) to [-π, π)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi if isinstance(a, np.ndarray) else (a + math.pi) % (2 * math.pi) - math.pi


def to_planar(position: np.ndarray) -> np.ndarray:
    """World position(s) [..., 3] → planar GNM position(s) [..., 2] = (x, -z)."""
    p = np.asarray(position, dtype=np.float64)
    return np.stack([p[..., 0], -p[..., 2]], axis=-1)


def from_planar(planar: np.ndarray, height: float | np.ndarray = 0.0) -> np.ndarray:
    """Planar position(s) [..., 2] → world position(s) [..., 3] at the given floor height."""
    q = np.asarray(planar, dtype=np.float64)
    h = np.broadcast_to(np.asarray(height, dtype=np.float64), q.shape[:-1])
    return np.stack([q[..., 0], h, -q[..., 1]], axis=-1)


def heading(yaw: float) -> np.ndarray:
    """Unit heading [3] in the world frame for a yaw."""
    return np.array([math.cos(yaw), 0.0, -math.sin(yaw)])


def relative_goal(position: np.ndarray, yaw: float, goal: np.ndarray) -> np.ndarray:
    """Goal in the robot frame: (x forward, y left), metres, float32 [2]."""
    d = to_planar(goal) - to_planar(position)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]], dtype=np.float32)

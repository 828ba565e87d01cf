"""Frames, poses and actions shared by every module (and the GNM format's
planar frame).

World frame: metres, **y up**. The robot moves on the floor plane (x, z).

Planar (GNM) frame: ``planar = (x, -z)``. Yaw ``θ`` is counter-clockwise seen from
above (a right-handed rotation about +y), so the heading of yaw θ is
``(cos θ, 0, -sin θ)`` in the world and ``(cos θ, sin θ)`` in the planar frame.
A MOVE_FORWARD of ``d_step`` from yaw θ changes the planar position by
``d_step·(cos θ, sin θ)``; TURN_LEFT adds ``+θ_step`` to the yaw.

Robot-relative goal (``pointgoal``): ``(x_g, y_g)`` with x forward and y left, metres.

A goal lies on its start's floor: within ``SAME_FLOOR`` of its height (habitat-lab's PointNav generator,
`is_compatible_episode`: "check height difference to assure s and t are from same floor"). Stairs the navmesh climbs
join two floors into one island, and the point goal (x_g, y_g) of a goal upstairs could lie right above the robot.
rvn-gen's trajectories, the benchmark's episodes and the RL env's goals keep it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np


SAME_FLOOR = 0.5  # m, the largest height between a start (or the robot) and its goal


class Action(IntEnum):
    """Discrete actions, numbered as in Habitat's PointNav task."""

    STOP = 0
    MOVE_FORWARD = 1
    TURN_LEFT = 2
    TURN_RIGHT = 3


@dataclass(frozen=True)
class AgentConfig:
    """The robot: a cylinder of radius r_robot and height h_robot with a forward camera, moving
    d_step forward or turning theta_step_deg per action."""

    r_robot: float = 0.18  # m, cylinder radius
    h_robot: float = 1.0  # m, cylinder height
    d_step: float = 0.25  # m, MOVE_FORWARD
    theta_step_deg: float = 30.0  # deg, TURN_LEFT / TURN_RIGHT
    allow_sliding: bool = False  # paper: a short displacement is a collision, no sliding along walls

    def __post_init__(self) -> None:
        for name in ("r_robot", "h_robot", "d_step", "theta_step_deg"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"agent setting {name}={value!r} must be a positive number")

    @property
    def theta_step(self) -> float:
        """Turn angle in radians."""
        return math.radians(self.theta_step_deg)

    @property
    def success_distance(self) -> float:
        """The success radius (m), 2·r_robot: a STOP this close to the goal reaches it (the
        benchmark's default ``success_distance``, the expert's and the IL policies' ``stop_radius``)."""
        return 2.0 * self.r_robot


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


def to_local(points: np.ndarray, origin: np.ndarray, yaw: float | np.ndarray) -> np.ndarray:
    """Planar point(s) [..., 2] in the robot frame of planar pose (``origin`` [..., 2], ``yaw``):
    x forward, y left, metres, float64. ``yaw`` broadcasts against ``points[..., 0]``. The
    one frame change behind both the training labels (waypoints, image goals) and the
    benchmark's point goal (`relative_goal`)."""
    d = np.asarray(points, dtype=np.float64) - origin
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)


def relative_goal(position: np.ndarray, yaw: float, goal: np.ndarray) -> np.ndarray:
    """World ``goal`` [3] in the robot frame of the world pose (``position`` [3], ``yaw``):
    the observation ``pointgoal``, (x forward, y left), metres, float32 [2]. `to_local`'s arithmetic on
    `to_planar`'s coordinates, written out for one pose (every env step makes one: 1.7 against 17 us through the
    array functions, the same float32 bits: tests/test_conventions.py)."""
    f = np.float64  # to_planar's dtype: (x, -z)
    d0, d1 = f(goal[0]) - f(position[0]), -f(goal[2]) - -f(position[2])
    c, s = np.cos(yaw), np.sin(yaw)  # numpy's, as to_local's, in the yaw's own precision
    return np.array([c * d0 + s * d1, -s * d0 + c * d1], dtype=np.float32)


def turn_toward(bearing: float, theta_step: float) -> Action:
    """The discrete action steering toward a point at ``bearing`` (radians, counter-clockwise
    from the heading, in [-π, π)): turn by θ_step while the bearing exceeds θ_step/2, else
    MOVE_FORWARD. A turn brings a bearing above θ_step/2 closer to zero, so this never
    oscillates between left and right. The expert's path follower, the IL policies' action
    adapter and the blind goal follower all steer with it."""
    if bearing > theta_step / 2:
        return Action.TURN_LEFT
    if bearing < -theta_step / 2:
        return Action.TURN_RIGHT
    return Action.MOVE_FORWARD


class StopRule:
    """STOP within ``stop_radius`` of the point goal (planar, as the policy sees it), except at a STOP the env
    did not count: the env tests a STOP by the geodesic distance, which is never shorter than the straight line
    (about a millimetre longer on open floor), so a STOP between the two repeats, a no-op each time, until the
    timeout. A STOP that changed nothing (the next point goal is the same vector) marks its distance refused;
    while the agent stands there (turns leave the distance as it is) it steers toward the goal instead
    (`turn_toward`), and STOPs again once a step has changed the distance. Shared by the blind goal follower and
    the IL policies' action adapter; one per policy, ``reset()`` at each episode start."""

    def __init__(self, stop_radius: float, theta_step: float):
        self.stop_radius, self.theta_step = float(stop_radius), float(theta_step)
        self.reset()

    def reset(self) -> None:
        self._stopped_at: np.ndarray | None = None  # the point goal of the last STOP, until the next call
        self._refused: float | None = None  # the distance at which a STOP was not counted

    def act(self, pointgoal: np.ndarray) -> Action | None:
        """STOP, a step toward the goal after a STOP that was not counted here, or None: farther than
        ``stop_radius``, the policy decides."""
        goal = np.asarray(pointgoal, dtype=np.float64)
        dist = float(np.hypot(goal[0], goal[1]))
        if self._stopped_at is not None and np.array_equal(self._stopped_at, goal):
            self._refused = dist
        self._stopped_at = None
        if dist >= self.stop_radius:
            self._refused = None
            return None
        if self._refused is not None and abs(dist - self._refused) < 1e-9:
            return turn_toward(math.atan2(goal[1], goal[0]), self.theta_step)
        self._refused, self._stopped_at = None, goal.copy()
        return Action.STOP

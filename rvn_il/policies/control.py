"""Predicted waypoints → one discrete action (the paper's baselines: the action that best follows
a lookahead point chosen on the predicted trajectory).

Rule, with waypoints in metres in the robot frame (x forward, y left):
1. STOP when the point goal is closer than ``stop_radius`` (default `AgentConfig.success_distance`,
   2·r_robot: the success radius). The policies (`policy.py`, `trajectory_oracle.py`) apply it through
   `rvn_data.conventions.StopRule`, which steps toward the goal after a STOP the env did not count (its
   geodesic distance, never shorter than the planar one the policy sees, at least the radius).
2. Lookahead point: the first waypoint at least ``lookahead_min_dist`` from the robot
   (d_step/2: the first one a MOVE_FORWARD can approach; ``waypoint_index: null``, the
   default), or waypoint ``waypoint_index`` if set (negative counts from the end). When
   no waypoint is that far (the model predicts staying in place), the point goal itself.
   Why the first: with the true future poses (`trajectory_oracle.py`: the expert's next 8
   poses, replanned every step) this rule reproduces every expert action, and on the
   benchmark it reaches SR_1 0.980, E(G) 25.9, CPK 1.86 (the recipe's 200 val episodes, 32
   goals, expert A* with the soft clearance, goals inside the expert's margin reached from the
   free cell nearest them, a tighter margin where the expert's leaves no path, `StopRule`; before those,
   2026-12-06, 0.750 / 3.96 / 38.3: it steered at such goals blind and hit the wall). The
   last waypoint (-1) cuts corners toward a point 2 m ahead: SR_1 0.07,
   CPK 334 with the same perfect predictions; waypoint 1: 0.75 on 20 episodes, 0 (a turn
   has no displacement, so it falls back to the point goal): 0.10. An under-trained model
   blurs "turn, then go" into a short step straight ahead, so its first waypoint says
   MOVE_FORWARD too often; that is the model's shortfall, and no lookahead choice repairs
   it without breaking the perfect case (`python -m rvn_il.eval.agreement` measures both).
3. Heading error e = atan2(y, x) of the lookahead, steered with `rvn_data.conventions.turn_toward`
   (TURN_LEFT if e > θ_step/2, TURN_RIGHT if e < -θ_step/2, else MOVE_FORWARD). This is the
   expert's own following rule (rvn-gen), so a perfectly imitated trajectory reproduces the
   expert's actions.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvn_data.conventions import Action, AgentConfig, turn_toward


@dataclass(frozen=True)
class ControlConfig:
    """Settings of the waypoint → action rule (``model.policy`` in the config); `from_agent`
    fills what is not set from the agent."""

    theta_step: float  # rad
    stop_radius: float  # m
    lookahead_min_dist: float  # m
    waypoint_index: int | None = None

    @classmethod
    def from_agent(cls, agent: AgentConfig, stop_radius: float | None = None, lookahead_min_dist: float | None = None,
                   waypoint_index: int | None = None) -> "ControlConfig":
        return cls(theta_step=agent.theta_step,
                   stop_radius=agent.success_distance if stop_radius is None else float(stop_radius),
                   lookahead_min_dist=agent.d_step / 2 if lookahead_min_dist is None else float(lookahead_min_dist),
                   waypoint_index=None if waypoint_index is None else int(waypoint_index))


def lookahead_point(waypoints: np.ndarray, pointgoal: np.ndarray, cfg: ControlConfig) -> np.ndarray:
    """The point [2] to steer to, chosen on ``waypoints`` [len,2] (metres, robot frame)."""
    wp = np.asarray(waypoints, dtype=np.float64)
    if cfg.waypoint_index is not None:
        k = cfg.waypoint_index + len(wp) if cfg.waypoint_index < 0 else cfg.waypoint_index
        point = wp[min(max(k, 0), len(wp) - 1)]
        return point if np.linalg.norm(point) >= cfg.lookahead_min_dist else np.asarray(pointgoal, dtype=np.float64)
    far = np.flatnonzero(np.linalg.norm(wp, axis=1) >= cfg.lookahead_min_dist)
    return wp[far[0]] if len(far) else np.asarray(pointgoal, dtype=np.float64)


def waypoints_to_action(waypoints: np.ndarray, pointgoal: np.ndarray, cfg: ControlConfig) -> Action:
    """The discrete action following ``waypoints`` toward ``pointgoal`` (see module docstring)."""
    if float(np.linalg.norm(pointgoal)) < cfg.stop_radius:
        return Action.STOP
    point = lookahead_point(waypoints, pointgoal, cfg)
    return turn_toward(math.atan2(float(point[1]), float(point[0])), cfg.theta_step)

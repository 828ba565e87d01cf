"""The action adapter's ceiling: perfect trajectory predictions through the IL control rule.

`TrajectoryOraclePolicy` replaces the network of an IL policy by the expert that made its
training labels: every step it replans the expert path with the planner ``rvn-gen`` uses
(`rvn_data.planning.ExpertPlanner`: A* on the occupancy grid inflated by the expert margin,
built with the env's navmesh ``max_climb`` / ``max_slope_deg``, leaving the margin first when
the agent is inside it), rolls the path follower forward ``len_traj_pred`` steps without obstacles, and feeds
those future positions (robot frame, exactly the training labels' waypoints) to the same
waypoint → action rule as the learned policies (`control.py`). Its benchmark score is what a
model that predicts its labels perfectly would get with these adapter settings, so it tells
a weak adapter from a weak model. Privileged (bound to the env); evaluation only:

    rvn-eval policy=trajectory_oracle method="Trajectory oracle" [policy.waypoint_index=-1] [policy.stop_radius=0.35]

``stop_radius`` is the IL policies' ``model.policy.stop_radius`` (null: the success distance, 2·r_robot): the
policies see the planar point goal, the env counts a STOP by the geodesic distance, which is never shorter (about a
millimetre longer on open floor), so a STOP issued between the two repeats until the timeout.
"""
from __future__ import annotations

import numpy as np

from rvn_data.conventions import Action, AgentConfig, to_local, to_planar
from rvn_data.dataset.settings import DatasetConfig
from rvn_data.planning import ExpertPlanner, PathFollower
from rvn_data.planning.follower import integrate

from .control import ControlConfig, waypoints_to_action

_EXPERT = DatasetConfig  # the expert's planning defaults (rvn-gen's dataset group): the oracle plans as it does


class TrajectoryOraclePolicy:
    """Expert's next ``len_traj_pred`` poses → `waypoints_to_action` (see module docstring)."""

    def __init__(self, waypoint_index: int | None = None, len_traj_pred: int = 8,
                 margin_offset: float = _EXPERT.margin_offset, resolution: float = _EXPERT.resolution,
                 lookahead_min_dist: float | None = None, clearance_pref: float | None = _EXPERT.clearance_pref,
                 clearance_weight: float = _EXPERT.clearance_weight, stop_radius: float | None = None):
        self.waypoint_index = None if waypoint_index is None else int(waypoint_index)
        self.len_traj_pred, self.margin_offset = int(len_traj_pred), float(margin_offset)
        self.resolution, self.lookahead_min_dist = float(resolution), lookahead_min_dist
        self.clearance_pref = None if clearance_pref is None else float(clearance_pref)
        self.clearance_weight = float(clearance_weight)
        self.stop_radius = None if stop_radius is None else float(stop_radius)
        if self.stop_radius is not None and not self.stop_radius > 0:
            raise ValueError(f"trajectory_oracle: stop_radius={stop_radius} must be > 0 (metres; null: the success distance)")
        if self.len_traj_pred < 1 or self.resolution <= 0:
            raise ValueError(f"trajectory_oracle: len_traj_pred={len_traj_pred} must be >= 1 and resolution={resolution} > 0")
        self.env = None
        self.planner: ExpertPlanner | None = None
        self.last_waypoints: np.ndarray | None = None

    def bind(self, env) -> None:
        self.env = env.unwrapped
        agent = self.env.agent
        self.agent = agent if isinstance(agent, AgentConfig) else AgentConfig(**dict(agent))
        self.margin = self.agent.r_robot + self.margin_offset
        if not self.margin >= 0:
            raise ValueError(f"trajectory_oracle: margin_offset={self.margin_offset} puts the expert margin "
                             f"r_robot + margin_offset = {self.margin} below 0; raise it")
        self.control = ControlConfig.from_agent(self.agent, stop_radius=self.stop_radius,
                                                lookahead_min_dist=self.lookahead_min_dist, waypoint_index=self.waypoint_index)
        self.planner = None

    def reset(self) -> None:
        self.last_waypoints = None

    def _planner(self) -> ExpertPlanner:
        """The expert planner of the env's current scene (made again when the scene changes)."""
        scene = self.env.scene
        if self.planner is None or self.planner.scene is not scene:
            nav = self.env.config.navmesh
            self.planner = ExpertPlanner(scene, self.agent, self.margin, self.resolution, nav.max_climb, nav.max_slope_deg,
                                         self.clearance_pref, self.clearance_weight)
        return self.planner

    def predict(self, position: np.ndarray, yaw: float, goal: np.ndarray) -> np.ndarray:
        """The expert's next ``len_traj_pred`` positions in the robot frame [len, 2] (metres);
        zeros when no expert path exists from here."""
        plan = self._planner().plan(position, goal)
        if plan is None:
            return np.zeros((self.len_traj_pred, 2))
        follower = PathFollower(plan.waypoints, self.agent)
        p, y, future = np.asarray(position, np.float64), float(yaw), []
        for _ in range(self.len_traj_pred):
            action = follower.act(p, y)
            if action != Action.STOP:
                p, y = integrate(p, y, action, self.agent)
            future.append(to_planar(p))
        return to_local(np.asarray(future), to_planar(position), float(yaw))

    def act(self, obs) -> int:
        if self.env is None:
            raise RuntimeError("TrajectoryOraclePolicy needs privileged state: call policy.bind(env) first")
        pointgoal = np.asarray(obs["pointgoal"], np.float64)
        self.last_waypoints = self.predict(np.asarray(self.env.position, np.float64), float(self.env.yaw),
                                           np.asarray(self.env.goal, np.float64))
        return int(waypoints_to_action(self.last_waypoints, pointgoal, self.control))

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

Where the expert's margin leaves no path (a passage narrower than twice it, a goal in a nook of furniture: rvn-gen
rejects such start and goal pairs) it plans with the margin r_robot + ``fallback_margin_offset`` (default 0.02 m; null:
none, and then it predicts staying in place, and the adapter steers at the goal itself). On the recipe's 200 val
episodes the fallback lifts it from SR_1 0.955, E(G) 22.1, CPK 3.1 to 0.980 / 25.1 / 1.85; on the real apartment
(20 episodes) from 0.55 / 3.2 / 38 to 0.80 / 5.5 / 14 (docs/results/2026-12-06_trajectory_oracle); with the STOP
rule below, 0.980 / 25.9 / 1.86 on the 200 episodes (docs/results/2026-12-06_rl_main).

``stop_radius`` is the IL policies' ``model.policy.stop_radius`` (null: the success distance, 2·r_robot): the
policies see the planar point goal, the env counts a STOP by the geodesic distance, which is never shorter (about a
millimetre longer on open floor). A STOP issued between the two repeated until the timeout (13 of the 8ffc2da row's
200 episodes); since `rvn_data.conventions.StopRule`, a STOP the env did not count is followed by a step toward the goal.
"""
from __future__ import annotations

import numpy as np

from rvn_data.conventions import Action, AgentConfig, StopRule, to_local, to_planar
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
                 clearance_weight: float = _EXPERT.clearance_weight, stop_radius: float | None = None,
                 fallback_margin_offset: float | None = 0.02):
        self.waypoint_index = None if waypoint_index is None else int(waypoint_index)
        self.len_traj_pred, self.margin_offset = int(len_traj_pred), float(margin_offset)
        self.resolution, self.lookahead_min_dist = float(resolution), lookahead_min_dist
        self.clearance_pref = None if clearance_pref is None else float(clearance_pref)
        self.clearance_weight = float(clearance_weight)
        self.stop_radius = None if stop_radius is None else float(stop_radius)
        if self.stop_radius is not None and not self.stop_radius > 0:
            raise ValueError(f"trajectory_oracle: stop_radius={stop_radius} must be > 0 (metres; null: the success distance)")
        self.fallback_margin_offset = None if fallback_margin_offset is None else float(fallback_margin_offset)
        if self.fallback_margin_offset is not None and not 0 <= self.fallback_margin_offset < self.margin_offset:
            raise ValueError(f"trajectory_oracle: fallback_margin_offset={fallback_margin_offset} must be >= 0 and below "
                             f"margin_offset={self.margin_offset} (metres; null: no fallback)")
        if self.len_traj_pred < 1 or self.resolution <= 0:
            raise ValueError(f"trajectory_oracle: len_traj_pred={len_traj_pred} must be >= 1 and resolution={resolution} > 0")
        self.env = None
        self.planner: ExpertPlanner | None = None
        self.fallback: ExpertPlanner | None = None
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
        self.stop = StopRule(self.control.stop_radius, self.control.theta_step)
        self.planner = self.fallback = None

    def reset(self) -> None:
        self.last_waypoints = None
        if self.env is not None:
            self.stop.reset()

    def _planner(self, fallback: bool = False) -> ExpertPlanner:
        """The expert planner of the env's current scene (made again when the scene changes); ``fallback``: the one
        with the margin r_robot + fallback_margin_offset."""
        scene, current = self.env.scene, self.fallback if fallback else self.planner
        if current is None or current.scene is not scene:
            nav = self.env.config.navmesh
            margin = self.agent.r_robot + self.fallback_margin_offset if fallback else self.margin
            current = ExpertPlanner(scene, self.agent, margin, self.resolution, nav.max_climb, nav.max_slope_deg,
                                    self.clearance_pref, self.clearance_weight)
            if fallback:
                self.fallback = current
            else:
                self.planner = current
        return current

    def predict(self, position: np.ndarray, yaw: float, goal: np.ndarray) -> np.ndarray:
        """The expert's next ``len_traj_pred`` positions in the robot frame [len, 2] (metres);
        zeros when no expert path exists from here."""
        plan = self._planner().plan(position, goal)
        if plan is None and self.fallback_margin_offset is not None:
            plan = self._planner(fallback=True).plan(position, goal)
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
        near = self.stop.act(pointgoal)  # as the IL policies: STOP within stop_radius, a step on if not counted
        if near is not None:
            return int(near)
        self.last_waypoints = self.predict(np.asarray(self.env.position, np.float64), float(self.env.yaw),
                                           np.asarray(self.env.goal, np.float64))
        return int(waypoints_to_action(self.last_waypoints, pointgoal, self.control))

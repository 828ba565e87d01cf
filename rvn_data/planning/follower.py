"""Follow a planned path with the discrete actions (the expert of rvn-gen).

Rule, in the planar frame: STOP within `stop_radius` (default `AgentConfig.success_distance`,
2·r_robot) of the goal; otherwise advance to the next waypoint when the current one is within
d_step/2 or has been passed (the agent is beyond it along its segment); then steer to it with
`turn_toward` (turn by θ_step while the heading error exceeds θ_step/2, else MOVE_FORWARD), so
the follower never oscillates between turns.
"""
from __future__ import annotations

import math

import numpy as np

from rvn_data.conventions import Action, AgentConfig, to_planar, turn_toward, wrap_angle


class PathFollower:
    """Greedy waypoint follower; `act(position, yaw)` gives the next `Action`."""

    def __init__(self, waypoints: np.ndarray, agent: AgentConfig, stop_radius: float | None = None):
        pts = to_planar(np.asarray(waypoints, dtype=np.float64).reshape(-1, 3))
        if len(pts) == 0:
            raise ValueError("PathFollower needs at least one waypoint (the goal)")
        self.points = pts
        self.agent = agent
        self.stop_radius = agent.success_distance if stop_radius is None else float(stop_radius)
        self.index = min(1, len(pts) - 1)

    @property
    def goal(self) -> np.ndarray:
        return self.points[-1]

    def _advance(self, p: np.ndarray) -> None:
        last = len(self.points) - 1
        while self.index < last:
            wp = self.points[self.index]
            prev = self.points[self.index - 1]
            near = np.hypot(*(wp - p)) < 0.5 * self.agent.d_step
            passed = float(np.dot(p - wp, wp - prev)) > 0.0
            if not (near or passed):
                break
            self.index += 1

    def act(self, position: np.ndarray, yaw: float) -> Action:
        """Next action for the agent at world `position` [3] with `yaw`."""
        p = to_planar(position)
        if math.hypot(*(self.goal - p)) <= self.stop_radius:
            return Action.STOP
        self._advance(p)
        d = self.points[self.index] - p
        return turn_toward(wrap_angle(math.atan2(d[1], d[0]) - yaw), self.agent.theta_step)


def integrate(position: np.ndarray, yaw: float, action: Action, agent: AgentConfig) -> tuple[np.ndarray, float]:
    """The pose an action commands, ignoring obstacles (world [3], wrapped yaw)."""
    p = np.array(position, dtype=np.float64)
    if action == Action.MOVE_FORWARD:
        p[0] += agent.d_step * math.cos(yaw)
        p[2] -= agent.d_step * math.sin(yaw)
    elif action == Action.TURN_LEFT:
        yaw = yaw + agent.theta_step
    elif action == Action.TURN_RIGHT:
        yaw = yaw - agent.theta_step
    return p, float(wrap_angle(yaw))

"""Discrete-action simulator with collision detection (Habitat-style: the
move is constrained to the navmesh; a short move is a collision).

MOVE_FORWARD asks for `d_step` along the heading; the target is constrained to the
navigable surface (which already includes the agent-radius margin): the robot marches
along the segment (steps of cell_size/5, then bisection to ~1e-6 m) and stops at the last
navigable point (`allow_sliding=False`, the paper), or additionally slides along the
obstacle by the tangential part of the remaining motion (`allow_sliding=True`). A collision
is registered when the planar displacement is shorter than `d_step - 1e-3`; `contact` is
where the robot's body meets the obstacle (the stop point moved by its clearance down the
clearance gradient). Turns and STOP never collide. The robot's y follows the floor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvn_data.conventions import Action, AgentConfig, wrap_angle
from rvn_data.navmesh import kernels as K
from rvn_data.navmesh.navmesh import NavMesh

COLLISION_EPS = 1e-3  # m


@dataclass
class StepResult:
    """Outcome of one action: new pose, collision flag, contact point, commanded target."""

    position: np.ndarray  # [3]
    yaw: float
    collided: bool
    contact: np.ndarray | None  # [3], where the body met the obstacle
    commanded: np.ndarray  # [3], the target the action asked for
    displacement: float  # planar metres moved


class Simulator:
    """Agent state (position on the navmesh, yaw) and the discrete actions."""

    def __init__(self, navmesh: NavMesh, agent: AgentConfig | None = None):
        self.navmesh = navmesh
        self.agent = agent or AgentConfig()
        if abs(self.agent.r_robot - navmesh.settings.agent_radius) > 1e-6:
            raise ValueError(f"agent r_robot={self.agent.r_robot} differs from the navmesh's "
                             f"agent_radius={navmesh.settings.agent_radius}; build the navmesh "
                             "with the agent's radius")
        P, st = navmesh.packed, navmesh.settings
        self._args = (P.meta, P.height, P.clearance, P.island, P.x0, P.z0, P.cs)
        self._r = st.agent_radius
        self._tol = st.step_tolerance
        self._step = 0.2 * st.cell_size
        self.position = np.full(3, np.nan)
        self.yaw = 0.0

    def reset(self, position: np.ndarray, yaw: float) -> None:
        """Place the agent; a position off the navmesh is snapped to it (ValueError if it cannot be)."""
        p = np.asarray(position, dtype=np.float64).reshape(3)
        q = self.navmesh.snap(p)
        if np.isnan(q).any():
            raise ValueError(f"reset position {p.tolist()} is not near the navigable surface of "
                             f"scene {self.navmesh.scene_id!r}")
        self.position = q
        self.yaw = float(wrap_angle(float(yaw)))

    def step(self, action: int) -> StepResult:
        action = Action(int(action))
        p = self.position
        if action == Action.MOVE_FORWARD:
            return self._forward(p)
        if action == Action.TURN_LEFT:
            self.yaw = wrap_angle(self.yaw + self.agent.theta_step)
        elif action == Action.TURN_RIGHT:
            self.yaw = wrap_angle(self.yaw - self.agent.theta_step)
        return StepResult(p.copy(), self.yaw, False, None, p.copy(), 0.0)

    def _forward(self, p: np.ndarray) -> StepResult:
        d = self.agent.d_step
        dx, dz = math.cos(self.yaw), -math.sin(self.yaw)
        commanded = np.array([p[0] + d * dx, p[1], p[2] + d * dz])
        t, y = K.march(*self._args, p[0], p[1], p[2], dx, dz, d, self._r, self._tol, self._step)
        x, z = p[0] + t * dx, p[2] + t * dz
        contact = None
        if t < d - COLLISION_EPS:
            gx, gz = K.clearance_gradient(*self._args[:3], *self._args[4:], x, y, z, self._tol)
            g = math.hypot(gx, gz)
            nx, nz = (gx / g, gz / g) if g > 1e-9 else (-dx, -dz)
            contact = np.array([x - nx * self._r, y, z - nz * self._r])
            if self.agent.allow_sliding:
                rx, rz = commanded[0] - x, commanded[2] - z
                into = rx * nx + rz * nz
                if into < 0:
                    rx, rz = rx - into * nx, rz - into * nz
                rem = math.hypot(rx, rz)
                if rem > 1e-9:
                    s, y = K.march(*self._args, x, y, z, rx / rem, rz / rem, rem, self._r, self._tol, self._step)
                    x, z = x + s * rx / rem, z + s * rz / rem
        disp = math.hypot(x - p[0], z - p[2])
        collided = disp < d - COLLISION_EPS
        self.position = np.array([x, y, z])
        return StepResult(self.position.copy(), self.yaw, collided, contact if collided else None, commanded, disp)

"""The expert planner: the one definition of the paths behind the expert datasets.

`ExpertPlanner` rasterises a scene into an occupancy grid at a floor height (cells a robot
of height ``h_robot`` cannot stand in, with the navmesh's ``max_climb`` / ``max_slope_deg``),
inflates it by the expert ``margin``, and plans on it with A* (optionally with the soft
clearance ``clearance_pref`` / ``clearance_weight``). A start inside the margin (on the
navmesh but closer to an obstacle than ``margin``) is planned from the nearest free cell
within ``margin - r_robot + 2·resolution`` (never negative: an expert margin below the
robot radius still looks two cells around), and the true start is put in front of the
plan, so the path first leaves the margin. A goal inside the margin is reached the same way:
the plan ends at the free cell nearest to it within that reach, then the true goal. rvn-gen
draws its goals outside the margin; the benchmark's goals are anywhere on the navmesh (any
point at least r_robot from an obstacle), a fifth of them inside the expert's margin, which
the trajectory oracle had no plan to until 2026-12-06 (it then steered at the goal itself).

``rvn-gen`` (`rvn_data.dataset.trajectory`) plans its trajectories with it, and the
trajectory oracle (`rvn_il.policies.trajectory_oracle`) replans the same expert every step.
"""
from __future__ import annotations

import numpy as np

from rvn_data.conventions import AgentConfig
from rvn_data.planning.astar import Plan, append_goal, exit_point, plan_path, prepend_start
from rvn_data.planning.occupancy import OccupancyGrid, occupancy_grid

FLOOR_LEVEL = 0.05  # m: floor heights closer than this share one grid


class ExpertPlanner:
    """Expert A* on one scene's inflated occupancy grids (one grid per floor level, cached)."""

    def __init__(self, scene, agent: AgentConfig, margin: float, resolution: float = 0.05,
                 max_climb: float = 0.2, max_slope_deg: float = 45.0,
                 clearance_pref: float | None = None, clearance_weight: float = 0.0):
        if not (margin >= 0 and resolution > 0):
            raise ValueError(f"expert planner: margin={margin} must be >= 0 and resolution={resolution} > 0")
        self.scene, self.agent = scene, agent
        self.margin, self.resolution = float(margin), float(resolution)
        self.max_climb, self.max_slope_deg = float(max_climb), float(max_slope_deg)
        self.clearance_pref = None if clearance_pref is None else float(clearance_pref)
        self.clearance_weight = float(clearance_weight)
        self._grids: dict[int, tuple[OccupancyGrid, np.ndarray]] = {}

    @property
    def exit_reach(self) -> float:
        """How far (m) a start inside the margin may be moved to leave it."""
        return max(self.margin - self.agent.r_robot, 0.0) + 2.0 * self.resolution

    def grid_at(self, floor_y: float) -> tuple[OccupancyGrid, np.ndarray]:
        """(occupancy grid, free mask inflated by the margin) at a floor height."""
        key = int(round(floor_y / FLOOR_LEVEL))
        if key not in self._grids:
            grid = occupancy_grid(self.scene, key * FLOOR_LEVEL, self.resolution, self.agent.h_robot,
                                  self.max_climb, self.max_slope_deg)
            self._grids[key] = (grid, grid.inflate(self.margin))
        return self._grids[key]

    def is_free(self, point: np.ndarray, floor_y: float | None = None) -> bool:
        """Whether world ``point`` lies outside the margin on the grid of ``floor_y`` (default: its own height)."""
        grid, free = self.grid_at(float(point[1] if floor_y is None else floor_y))
        cell = grid.to_cell(point)
        return grid.contains(cell) and bool(free[cell[0], cell[1]])

    def entry(self, start: np.ndarray, leave_margin: bool = True) -> np.ndarray | None:
        """Where the plan from ``start`` begins: ``start`` itself (the same object) when it is
        outside the margin, else the nearest free cell within `exit_reach` (None if there is
        none, or if ``leave_margin`` is False)."""
        if self.is_free(start):
            return start
        if not leave_margin:
            return None
        grid, free = self.grid_at(float(start[1]))
        return exit_point(grid, free, start, self.exit_reach)

    def plan(self, start: np.ndarray, goal: np.ndarray, entry: np.ndarray | None = None) -> Plan | None:
        """The expert path from world ``start`` to ``goal`` on the grid of the start's floor,
        starting with ``start`` itself and ending with ``goal``; None when no path exists (or
        the start cannot leave the margin, or no free cell is within `exit_reach` of a goal
        inside it). ``entry``: a precomputed `entry(start)`."""
        entry = self.entry(start) if entry is None else entry
        if entry is None:
            return None
        grid, free = self.grid_at(float(start[1]))
        arrival = goal if self.is_free(goal, floor_y=float(start[1])) else exit_point(grid, free, goal, self.exit_reach)
        if arrival is None:
            return None
        plan = plan_path(grid, free, entry, arrival, self.clearance_pref, self.clearance_weight)
        if plan is None:
            return None
        if entry is not start:
            plan = prepend_start(plan, start)
        return plan if arrival is goal else append_goal(plan, goal)

"""Planning for dataset generation: occupancy grid, A*, the expert planner, path follower."""
from rvn_data.planning.astar import Plan, append_goal, astar, exit_point, plan_path, prepend_start, prune_path
from rvn_data.planning.expert import ExpertPlanner
from rvn_data.planning.follower import PathFollower
from rvn_data.planning.occupancy import OccupancyGrid, occupancy_grid

__all__ = ["ExpertPlanner", "OccupancyGrid", "PathFollower", "Plan", "append_goal", "astar", "exit_point", "occupancy_grid",
           "plan_path", "prepend_start", "prune_path"]

"""One trajectory attempt: sample start and goal, plan, follow (an expert or a
negative trajectory of rvn-gen).

An attempt is a pure function of its `numpy.random.Generator`. It returns a `Rollout`
(poses to record, how many of them to render, the collision step) or the name of the
reason it was discarded (`REASONS`). Nothing is rendered here.

Time indices: frame t shows pose p_t; action a_t is issued at p_t. For a negative
trajectory t_c is the frame whose MOVE_FORWARD collided: p_{t_c} and I_{t_c} are real,
p_t for t > t_c are the poses the follower commands from there with no obstacle in the
way (the intended motion through the obstacle), and I_t = I_{t_c}. The clip kept is
t_i = max(0, t_c − k_pre) … t_f = min(T − 1, t_c + k_post).

Starts are drawn like the benchmark's: any navigable pose of the navmesh's sampled islands (the main
island unless navmesh.islands=all), any yaw; goal candidates on the start's island and floor: within
`SAME_FLOOR` = 0.5 m of its height, Habitat's PointNav rule (a goal up a flight of stairs is on the same island,
but the expert plans on the start floor's occupancy grid, so it would be planned to, and recorded at, the point
below it). A start inside the
expert margin (closer to an obstacle than `margin`, e.g. facing a wall at 0.2 m) is planned
from the nearest cell outside it, so the trajectory first leaves the margin; such states
are where a learned policy most often collides, and without them the expert data never
shows them (`start_anywhere=False` restores "start_blocked" rejection).

Heading perturbations (expert, ``perturb_prob`` > 0; off by default): before a step the
follower would move or turn, with probability ``perturb_prob`` it is made to turn 1 to
``perturb_max_turns`` times θ_step to a random side instead, and then recovers by itself
(DART-style noise injection, Laskey et al. 2017). A turn does not move the robot, so the
recorded positions, the labels of every frame, stay those of the expert's path; the frames
show it off-heading, often facing a wall or furniture, with the path going elsewhere: the
states a learned policy drifts into and the expert data otherwise never shows.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rvn_data.conventions import SAME_FLOOR, Action, to_planar, wrap_angle
from rvn_data.dataset.settings import GenSettings
from rvn_data.planning.astar import Plan
from rvn_data.planning.expert import ExpertPlanner
from rvn_data.planning.follower import PathFollower, integrate
from rvn_data.planning.occupancy import OccupancyGrid

REASONS = ("start_blocked", "no_goal", "no_path", "path_length", "collided", "timeout", "no_collision")


@dataclass
class Rollout:
    """A kept trajectory before rendering. positions: world [T, 3]; yaws [T] wrapped;
    `num_render` first frames are rendered, later ones repeat the last rendered image."""

    positions: np.ndarray
    yaws: np.ndarray
    actions: list[int]
    num_render: int
    start: np.ndarray
    start_yaw: float
    goal: np.ndarray
    geodesic: float
    plan: Plan
    t_c: int | None = None  # index of the collision frame within the clip
    t_c_episode: int | None = None  # the same, counted from the start of the rollout
    contact: np.ndarray | None = None
    steps: int = 0  # actions taken by the follower before STOP / collision

    @property
    def planar(self) -> np.ndarray:
        return to_planar(self.positions)


@dataclass
class SceneContext:
    """What attempts in one scene share: navmesh, simulator, the expert planner (its occupancy
    grids per floor)."""

    navmesh: object
    sim: object
    scene: object
    settings: GenSettings
    stats: dict = field(default_factory=lambda: {"max_geodesic_seen": 0.0})
    planner: ExpertPlanner = field(init=False)

    def __post_init__(self) -> None:
        s = self.settings
        self.planner = ExpertPlanner(self.scene, s.agent, s.margin, s.resolution,
                                     s.navmesh.max_climb, s.navmesh.max_slope_deg,
                                     s.clearance_pref, s.clearance_weight)

    def grid_at(self, floor_y: float) -> tuple[OccupancyGrid, np.ndarray]:
        """(grid, inflated free mask) at a floor height (`ExpertPlanner.grid_at`)."""
        return self.planner.grid_at(floor_y)


def attempt(ctx: SceneContext, rng: np.random.Generator) -> Rollout | str:
    """One start/goal draw, plan and rollout; a `Rollout` or a reason from `REASONS`."""
    s, planner = ctx.settings, ctx.planner
    start = np.asarray(ctx.navmesh.sample(rng), dtype=np.float64)
    start_yaw = float(rng.uniform(-math.pi, math.pi))
    entry = planner.entry(start, leave_margin=s.start_anywhere)
    if entry is None:
        return "start_blocked"
    island = ctx.navmesh.goal_island(start)  # the start's (navmesh.islands=all: any of several)
    candidates = np.array([ctx.navmesh.sample(rng, island) for _ in range(s.goal_candidates)], dtype=np.float64)
    dists = np.asarray(ctx.navmesh.distance_field(start, keep=False).distance(candidates),
                       dtype=np.float64).reshape(-1)
    finite = dists[np.isfinite(dists)]
    if finite.size:
        ctx.stats["max_geodesic_seen"] = max(ctx.stats["max_geodesic_seen"], float(finite.max()))
    goal, geodesic = None, math.inf
    for g, d in zip(candidates, dists):  # the first candidate in range, on the start's floor, free under the margin
        same_floor = abs(g[1] - start[1]) <= SAME_FLOOR
        if s.d_min <= d <= s.d_max and same_floor and planner.is_free(g, floor_y=float(start[1])):
            goal, geodesic = g, float(d)
            break
    if goal is None:
        return "no_goal"
    plan = planner.plan(start, goal, entry)
    if plan is None:
        return "no_path"
    if not s.d_min <= plan.length <= s.d_max:
        return "path_length"
    return _follow(ctx, plan, start, start_yaw, goal, geodesic, rng)


def _perturbed(follower: PathFollower, pos, yaw, s: GenSettings, rng: np.random.Generator, queue: list) -> Action:
    """The follower's action, or a perturbing turn (module docstring); ``queue`` holds the
    turns still to come of a perturbation."""
    if queue:
        return queue.pop()
    action = follower.act(pos, yaw)
    if s.kind == "expert" and s.perturb_prob > 0 and action != Action.STOP and rng.random() < s.perturb_prob:
        turn = Action.TURN_LEFT if rng.random() < 0.5 else Action.TURN_RIGHT
        queue.extend([turn] * int(rng.integers(0, s.perturb_max_turns)))
        return turn
    return action


def _follow(ctx: SceneContext, plan: Plan, start, start_yaw, goal, geodesic, rng: np.random.Generator) -> Rollout | str:
    s = ctx.settings
    follower = PathFollower(plan.waypoints, s.agent, s.stop_radius)
    ctx.sim.reset(start, start_yaw)
    pos, yaw = np.array(start, dtype=np.float64), float(wrap_angle(start_yaw))
    positions, yaws, actions, queue = [], [], [], []
    t_c = contact = None
    for t in range(s.max_steps):
        positions.append(pos)
        yaws.append(yaw)
        action = _perturbed(follower, pos, yaw, s, rng, queue)
        actions.append(int(action))
        if action == Action.STOP:
            break
        result = ctx.sim.step(action)
        if result.collided:
            t_c = t
            contact = None if result.contact is None else np.asarray(result.contact, dtype=np.float64)
            break
        pos, yaw = np.asarray(result.position, dtype=np.float64), float(wrap_angle(result.yaw))
    else:
        return "timeout"
    steps = len(actions) - 1 if actions[-1] == Action.STOP else len(actions)
    common = dict(start=np.asarray(start, np.float64), start_yaw=float(start_yaw), goal=goal,
                  geodesic=geodesic, plan=plan, contact=contact, steps=steps)
    if s.kind == "expert":
        if t_c is not None:
            return "collided"
        return Rollout(np.array(positions), np.array(yaws), actions, num_render=len(positions), **common)
    if t_c is None:
        return "no_collision"
    # negative: continue the intended motion from p_{t_c} without the navmesh
    for _ in range(s.k_post):
        pos, yaw = integrate(pos, yaw, Action(actions[-1]), s.agent)
        positions.append(pos)
        yaws.append(yaw)
        action = follower.act(pos, yaw)
        actions.append(int(action))
        if action == Action.STOP:
            break
    t_i = max(0, t_c - s.k_pre)
    t_f = min(len(positions) - 1, t_c + s.k_post)
    return Rollout(np.array(positions[t_i:t_f + 1]), np.array(yaws[t_i:t_f + 1]), actions[t_i:t_f + 1],
                   num_render=t_c - t_i + 1, t_c=t_c - t_i, t_c_episode=t_c, **common)

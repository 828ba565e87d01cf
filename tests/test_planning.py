"""Planning: occupancy grid from a mesh, inflation, A*, pruning, the expert planner, follower (synthetic data)."""
import math

import numpy as np
import pytest

from rvn_data.conventions import Action, AgentConfig, from_planar, to_planar
from rvn_data.planning import ExpertPlanner, PathFollower, astar, occupancy_grid, plan_path, prune_path
from rvn_data.planning.follower import integrate
from rvn_data.scenes.scene import Part, Scene


def box(x0, x1, y0, y1, z0, z1):
    v = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], np.float32)
    f = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    return v, np.array(f, np.int32)


def make_scene(boxes):
    parts = [Part("floor", np.array([[0, 0, 0], [6, 0, 0], [6, 0, 4], [0, 0, 4]], np.float32),
                  np.array([[0, 2, 1], [0, 3, 2]], np.int32))]
    for i, b in enumerate(boxes):
        v, f = box(*b)
        parts.append(Part(f"box{i}", v, f))
    return Scene("test:room", parts)


# a 6 x 4 m room, 0.1 m walls, a dividing wall at x = 3 with a 0.6 m door at z in [1.7, 2.3],
# a 0.7 m table (blocks the 1.0 m robot) and a 1.2 m overhang (does not)
WALLS = [(0, 6, 0, 2.5, 0, 0.1), (0, 6, 0, 2.5, 3.9, 4), (0, 0.1, 0, 2.5, 0, 4), (5.9, 6, 0, 2.5, 0, 4),
         (2.95, 3.05, 0, 2.5, 0, 1.7), (2.95, 3.05, 0, 2.5, 2.3, 4)]
TABLE = (0.8, 1.6, 0.68, 0.72, 0.8, 1.6)
OVERHANG = (4.0, 5.0, 1.2, 1.25, 2.5, 3.5)


@pytest.fixture(scope="module")
def grid():
    return occupancy_grid(make_scene(WALLS + [TABLE, OVERHANG]), floor_height=0.0, resolution=0.05)


def occ_at(grid, x, z):
    r, c = grid.to_cell(np.array([x, 0.0, z]))
    return bool(grid.occupied[r, c])


def test_occupancy_walls_table_overhang(grid):
    assert occ_at(grid, 3.0, 1.0)  # thin dividing wall (0.1 m = 2 cells)
    assert not occ_at(grid, 3.0, 2.0)  # door
    assert occ_at(grid, 1.2, 1.2)  # inside the table top: interior filled, not just its outline
    assert not occ_at(grid, 4.5, 3.0)  # under the overhang
    assert not occ_at(grid, 2.0, 3.0)
    assert not grid.contains(grid.to_cell(np.array([7.0, 0, 2.0])))
    # no floor outside the room: occupied
    r, c = grid.to_cell(np.array([-0.02, 0.0, 2.0]))
    assert grid.occupied[r, c]


def test_inflation_closes_narrow_door(grid):
    s, g = np.array([1.5, 0, 3.0]), np.array([4.5, 0, 1.0])
    open_plan = plan_path(grid, grid.inflate(0.2), s, g)
    assert open_plan is not None and math.hypot(3, 2) - 1e-6 <= open_plan.length < 3.8  # through the door
    assert plan_path(grid, grid.inflate(0.35), s, g) is None  # 0.6 m door closed by 0.35 m margin


def test_astar_optimal_and_pruned():
    free = np.ones((50, 60), bool)
    cells, length = astar(free, (5, 5), (45, 55))
    dr, dc = 40, 50
    assert math.isclose(length, max(dr, dc) + (math.sqrt(2) - 1) * min(dr, dc), rel_tol=1e-9)
    assert (np.abs(np.diff(cells, axis=0)) <= 1).all()
    assert len(prune_path(free, cells)) == 2  # open field: straight line
    free[:, 30] = False
    assert not np.isfinite(astar(free, (5, 5), (45, 55))[1])
    free[25, 30] = True  # one-cell gap: reachable, but never across a corner diagonally
    cells, length = astar(free, (5, 5), (45, 55))
    assert np.isfinite(length) and [25, 30] in cells.tolist()
    pruned = prune_path(free, cells)
    assert 2 < len(pruned) <= 4
    assert any(r == 25 and abs(c - 30) <= 1 for r, c in pruned.tolist())  # goes through the gap
    for (r0, c0), (r1, c1) in zip(pruned[:-1], pruned[1:]):  # every pruned segment stays free
        t = np.linspace(0, 1, 200)
        assert free[np.floor(r0 + 0.5 + t * (r1 - r0)).astype(int), np.floor(c0 + 0.5 + t * (c1 - c0)).astype(int)].all()
    assert astar(free, (5, 30), (45, 55))[0].size == 0  # start blocked


def run_follower(plan_pts, start_yaw, agent, max_steps=300):
    follower = PathFollower(plan_pts, agent)
    p, yaw = plan_pts[0].copy(), start_yaw
    actions = []
    for _ in range(max_steps):
        a = follower.act(p, yaw)
        actions.append(a)
        if a == Action.STOP:
            break
        p, yaw = integrate(p, yaw, a, agent)
    return p, actions


def test_follower_reaches_goal_without_zigzag():
    agent = AgentConfig()
    pts = from_planar(np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]]))
    p, actions = run_follower(pts, start_yaw=math.pi, agent=agent)
    assert actions[-1] == Action.STOP
    assert np.hypot(*(to_planar(p) - [3, 3])) <= 2 * agent.r_robot
    # turn around (6 turns of 30 deg), go straight, one 90 deg corner: few turns in total
    turns = sum(a in (Action.TURN_LEFT, Action.TURN_RIGHT) for a in actions)
    assert turns <= 6 + 3 + 2
    forward = sum(a == Action.MOVE_FORWARD for a in actions)
    assert 20 <= forward <= 26
    for a, b in zip(actions, actions[1:]):  # never undoes a turn
        assert {a, b} != {Action.TURN_LEFT, Action.TURN_RIGHT}


def test_integrate_planar_convention():
    agent = AgentConfig()
    p, yaw = integrate(np.zeros(3), math.radians(60), Action.MOVE_FORWARD, agent)
    assert np.allclose(to_planar(p), 0.25 * np.array([math.cos(math.radians(60)), math.sin(math.radians(60))]))
    _, yaw2 = integrate(p, yaw, Action.TURN_LEFT, agent)
    assert math.isclose(yaw2, math.radians(90))


def path_clearance(grid, plan):
    """Clearance (m) of the occupancy grid sampled every 1 cm along a plan's waypoints."""
    pts = plan.waypoints[:, [0, 2]]
    dense = np.concatenate([np.linspace(a, b, max(2, int(np.hypot(*(b - a)) / 0.01))) for a, b in zip(pts[:-1], pts[1:])])
    cells = grid.to_cell(np.stack([dense[:, 0], np.zeros(len(dense)), dense[:, 1]], axis=1))
    return grid.clearance()[cells[:, 0], cells[:, 1]]


def test_soft_clearance_keeps_paths_off_the_margin(grid):
    """With clearance_pref the path passes the table and the door jambs farther than the margin
    that the plain shortest path grazes, for a little more length; the hard margin is unchanged."""
    free = grid.inflate(0.2)
    s, g = np.array([1.2, 0, 3.5]), np.array([2.5, 0, 0.4])  # past the table's corner
    plain, soft = plan_path(grid, free, s, g), plan_path(grid, free, s, g, clearance_pref=0.5, clearance_weight=4.0)
    c_plain, c_soft = path_clearance(grid, plain).min(), path_clearance(grid, soft).min()
    assert c_plain < 0.23 and c_soft > c_plain + 0.05, (c_plain, c_soft)
    assert plain.length <= soft.length < 1.05 * plain.length
    s, g = np.array([1.5, 0, 3.4]), np.array([4.5, 0, 0.6])  # through the 0.6 m door
    plain, soft = plan_path(grid, free, s, g), plan_path(grid, free, s, g, clearance_pref=0.5, clearance_weight=4.0)
    c_plain, c_soft = path_clearance(grid, plain), path_clearance(grid, soft)
    assert c_soft.min() > c_plain.min() and c_soft.mean() > c_plain.mean() + 0.05
    assert plain.length <= soft.length < 1.1 * plain.length
    # weight 0 or no preference: the plain plan
    assert np.array_equal(plan_path(grid, free, s, g, 0.5, 0.0).waypoints, plain.waypoints)
    assert plan_path(grid, grid.inflate(0.35), s, g, 0.5, 4.0) is None  # still closed by the hard margin
    with pytest.raises(ValueError, match="clearance_pref"):
        plan_path(grid, free, s, g, clearance_pref=-1.0, clearance_weight=4.0)


def test_expert_planner_plans_on_the_inflated_grid_and_leaves_the_margin():
    """ExpertPlanner (rvn-gen's and the trajectory oracle's expert): from a start outside the
    margin it is A* on the grid inflated by the margin; from a start inside it (0.18 m from the
    table, margin 0.2) the plan begins at the true start, then the nearest free cell; with
    ``leave_margin=False`` there is no entry."""
    scene, agent = make_scene(WALLS + [TABLE, OVERHANG]), AgentConfig()
    planner = ExpertPlanner(scene, agent, margin=0.2, clearance_pref=0.5, clearance_weight=4.0)
    grid, free = planner.grid_at(0.01)  # floor heights within 2.5 cm share the grid of level 0
    assert planner.grid_at(0.0)[0] is grid and np.array_equal(free, grid.inflate(0.2))
    s, g = np.array([1.5, 0, 3.0]), np.array([4.5, 0, 1.0])
    assert planner.is_free(s) and planner.entry(s) is s
    direct = plan_path(grid, free, s, g, 0.5, 4.0)
    assert np.array_equal(planner.plan(s, g).waypoints, direct.waypoints)
    near = np.array([1.78, 0.0, 1.2])  # 0.18 m right of the table
    assert not planner.is_free(near) and planner.entry(near, leave_margin=False) is None
    entry = planner.entry(near)
    assert planner.is_free(entry) and 0.05 < np.hypot(*(entry - near)[[0, 2]]) <= planner.exit_reach
    plan = planner.plan(near, g)
    assert np.array_equal(plan.waypoints[0], near) and np.allclose(plan.waypoints[1], entry)
    assert plan.length == pytest.approx(plan_path(grid, free, entry, g, 0.5, 4.0).length + np.hypot(*(entry - near)[[0, 2]]))
    assert planner.plan(near, np.array([1.2, 0.0, 1.2])) is None  # goal on the table
    # a goal inside the margin (the benchmark's goals are anywhere on the navmesh): the plan ends at the free cell
    # nearest to it, then the goal itself; a free goal's plan is unchanged (rvn-gen's goals are all free)
    arrive = planner.plan(s, near)
    assert np.array_equal(arrive.waypoints[-1], near) and np.allclose(arrive.waypoints[-2], planner.entry(near))
    to_exit = plan_path(grid, free, s, planner.entry(near), 0.5, 4.0)
    assert np.array_equal(arrive.waypoints[:-1], to_exit.waypoints)
    assert arrive.length == pytest.approx(to_exit.length + np.hypot(*(entry - near)[[0, 2]]))
    assert planner.plan(s, np.array([1.2, 0.0, 1.2])) is None  # no free cell within reach of a goal on the table


def test_expert_planner_margin_below_the_robot_radius_still_leaves_it():
    """A margin smaller than r_robot (negative datasets) still looks two cells around a start
    inside it: the reach is max(margin - r_robot, 0) + 2 cells, never less."""
    planner = ExpertPlanner(make_scene(WALLS), AgentConfig(r_robot=0.18), margin=0.08)
    near = np.array([1.5, 0.0, 0.16])  # 0.06 m from the wall at z = 0.1
    assert not planner.is_free(near)
    assert planner.exit_reach == pytest.approx(0.1)
    plan = planner.plan(near, np.array([1.5, 0.0, 3.0]))
    assert plan is not None and planner.is_free(plan.waypoints[1])


def test_expert_planner_uses_the_navmesh_step_settings():
    """A 0.15 m step: under max_climb 0.2 (the default) the robot stands on it; with max_climb
    0.1 it is an obstacle the expert plans around."""
    step = (1.0, 2.0, 0.0, 0.15, 1.5, 2.5)
    scene, agent = make_scene(WALLS + [step]), AgentConfig()
    on_step, s, g = np.array([1.5, 0.0, 2.0]), np.array([0.5, 0.0, 2.0]), np.array([2.5, 0.0, 2.0])
    low = ExpertPlanner(scene, agent, 0.28, max_climb=0.2)
    high = ExpertPlanner(scene, agent, 0.28, max_climb=0.1)
    assert low.is_free(on_step) and not high.is_free(on_step)
    assert low.plan(s, g).length == pytest.approx(2.0)  # straight over the step
    assert high.plan(s, g).length > 2.3  # around it

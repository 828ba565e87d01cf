"""One frame convention and one steering rule shared by the training labels, the expert and the benchmark."""
import math

import numpy as np
import pytest

from rvn_data.benchmark.episodes_source import EnvConfig
from rvn_data.benchmark.policies import GoalFollowerPolicy
from rvn_data.conventions import Action, AgentConfig, from_planar, relative_goal, to_local, turn_toward
from rvn_data.planning import PathFollower
from rvn_il.policies import ControlConfig, waypoints_to_action


def test_to_local_is_the_point_goal_frame():
    """The training labels' frame change (vectorised over poses) and the benchmark's point goal
    are one function: x forward, y left of the robot, yaw counter-clockwise from above."""
    # facing planar +y (world -z): a goal 2 m further along world -z is straight ahead, world -x is left
    assert relative_goal(np.zeros(3), math.pi / 2, np.array([0.0, 0.0, -2.0])) == pytest.approx([2.0, 0.0], abs=1e-6)
    assert relative_goal(np.zeros(3), math.pi / 2, np.array([-1.0, 0.0, 0.0])) == pytest.approx([0.0, 1.0], abs=1e-6)
    rng = np.random.default_rng(0)
    pos, goal = rng.uniform(-5, 5, (50, 2)), rng.uniform(-5, 5, (50, 2))
    yaw = rng.uniform(-math.pi, math.pi, 50)
    batch = to_local(goal[:, None], pos[:, None], yaw[:, None])[:, 0]  # as GNMDataset builds its goal labels
    assert batch.dtype == np.float64 and batch.shape == (50, 2)
    for k in range(50):
        pointgoal = relative_goal(from_planar(pos[k], 0.3), float(yaw[k]), from_planar(goal[k], 0.3))
        assert pointgoal.dtype == np.float32
        np.testing.assert_array_equal(pointgoal, batch[k].astype(np.float32))
        assert np.linalg.norm(batch[k]) == pytest.approx(np.linalg.norm(goal[k] - pos[k]))


def test_turn_toward_thresholds():
    theta = math.radians(30)
    assert turn_toward(0.0, theta) == Action.MOVE_FORWARD
    assert turn_toward(theta / 2, theta) == turn_toward(-theta / 2, theta) == Action.MOVE_FORWARD
    assert turn_toward(math.nextafter(theta / 2, 1), theta) == Action.TURN_LEFT
    assert turn_toward(-math.nextafter(theta / 2, 1), theta) == Action.TURN_RIGHT
    assert turn_toward(-3.0, theta) == Action.TURN_RIGHT and turn_toward(3.0, theta) == Action.TURN_LEFT


@pytest.mark.parametrize("agent", [AgentConfig(), AgentConfig(r_robot=0.25, theta_step_deg=45.0)])
def test_expert_adapter_and_goal_follower_steer_and_stop_alike(agent):
    """The expert's path follower, the IL action adapter and the blind goal follower turn toward a
    point 3 m away at any bearing exactly as `turn_toward` says, and all stop within the agent's
    success radius 2·r_robot, which is also the benchmark's default success distance."""
    assert agent.success_distance == pytest.approx(2 * agent.r_robot)
    control = ControlConfig.from_agent(agent)
    follower = GoalFollowerPolicy(theta_step_deg=agent.theta_step_deg, stop_radius=agent.success_distance)
    default_follower = GoalFollowerPolicy()  # unbound: the default agent's settings
    for bearing in np.linspace(-3.1, 3.1, 125):
        point = 3.0 * np.array([math.cos(bearing), math.sin(bearing)])
        expected = turn_toward(math.atan2(point[1], point[0]), agent.theta_step)
        expert = PathFollower(from_planar(np.array([[0.0, 0.0], point])), agent)
        assert expert.act(np.zeros(3), 0.0) == expected
        assert waypoints_to_action(point[None], point, control) == expected
        assert follower.act({"pointgoal": point}) == expected
        assert default_follower.act({"pointgoal": point}) == turn_toward(math.atan2(point[1], point[0]), math.radians(30))
    r = agent.success_distance
    inside, outside = np.array([0.97 * r, 0.0]), np.array([1.03 * r, 0.0])
    for goal, stops in ((inside, True), (outside, False)):
        expert = PathFollower(from_planar(np.array([[0.0, 0.0], goal])), agent)
        assert (expert.act(np.zeros(3), 0.0) == Action.STOP) == stops
        assert (waypoints_to_action(goal[None], goal, control) == Action.STOP) == stops
        assert (follower.act({"pointgoal": goal}) == Action.STOP) == stops
    assert EnvConfig.from_kwargs(agent=agent, split="val").success_distance == pytest.approx(r)


def test_stop_rule_steps_on_after_a_stop_the_env_did_not_count():
    """Within stop_radius: STOP; the same point goal again (the env did not count it: its geodesic distance is at
    least the radius) steers toward the goal instead, while turns leave the distance as it is; once a step changed
    it, STOP again. The goal follower steers so."""
    from rvn_data.conventions import StopRule

    theta = math.radians(30)
    rule, follower = StopRule(0.36, theta), GoalFollowerPolicy()
    ahead, left = np.array([0.3597, 0.0]), 0.3597 * np.array([math.cos(1.0), math.sin(1.0)])
    assert rule.act(np.array([2.0, 0.0])) is None and rule.act(ahead) == Action.STOP
    assert rule.act(ahead) == Action.MOVE_FORWARD  # not counted: step on toward the goal
    assert rule.act(np.array([0.11, 0.0])) == Action.STOP  # nearer: STOP again
    assert [rule.act(g) for g in (left, left, left * [1, 0.5] / np.hypot(*(left * [1, 0.5])) * 0.3597)] == \
        [Action.STOP, Action.TURN_LEFT, Action.TURN_LEFT]  # a turn later the same distance: still steering
    rule.reset()
    assert rule.act(left) == Action.STOP
    assert [follower.act({"pointgoal": g}) for g in (ahead, ahead, ahead)] == [Action.STOP, Action.MOVE_FORWARD,
                                                                              Action.MOVE_FORWARD]


def test_relative_goal_is_to_local_of_the_planar_points_to_the_bit():
    """`relative_goal` (one pose, written out for speed: every env step makes one) gives `to_local(to_planar(goal),
    to_planar(position), yaw)`'s float32 bits, for float64 and float32 poses, float32 and numpy yaws, and lists."""
    from rvn_data.conventions import to_planar

    rng = np.random.default_rng(0)
    for k in range(4000):
        p, g, yaw = rng.uniform(-60, 60, 3), rng.uniform(-60, 60, 3), float(rng.uniform(-7, 7))
        if k % 4 == 1:
            yaw = np.float32(yaw)
        elif k % 4 == 2:
            p, g = p.astype(np.float32), g.astype(np.float32)
        elif k % 4 == 3:
            p, g, yaw = list(p), list(g), np.float64(yaw)
        want = to_local(to_planar(g), to_planar(p), yaw).astype(np.float32)
        got = relative_goal(p, yaw, g)
        assert got.dtype == np.float32 and got.shape == (2,)
        assert np.array_equal(got.view(np.uint32), want.view(np.uint32)), (k, p, g, yaw, got, want)

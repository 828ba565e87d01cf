"""Waypoints → action rule and CoR selection of NoMaD-Neg (issue 6, policies part)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from rvn_data.conventions import Action, AgentConfig
from rvn_il.models import build_model, load_model_config
from rvn_il.policies import ControlConfig, Member, NoMaDNegPolicy, PointGoalPolicy, cor, select_expert, waypoints_to_action

CTRL = ControlConfig.from_agent(AgentConfig())


def test_control_rule():
    far_goal = np.array([3.0, 0.0])
    assert CTRL.stop_radius == pytest.approx(0.36) and CTRL.lookahead_min_dist == pytest.approx(0.125)
    ahead = np.array([[0.25, 0.0], [0.5, 0.0]])
    assert waypoints_to_action(ahead, far_goal, CTRL) == Action.MOVE_FORWARD
    assert waypoints_to_action(ahead, np.array([0.3, 0.1]), CTRL) == Action.STOP
    # first waypoint is (almost) in place: the lookahead is the next one, 45 deg left
    left = np.array([[0.01, 0.0], [0.2, 0.2], [0.4, 0.4]])
    assert waypoints_to_action(left, far_goal, CTRL) == Action.TURN_LEFT
    assert waypoints_to_action(left * [1, -1], far_goal, CTRL) == Action.TURN_RIGHT
    # within theta_step/2 = 15 deg: forward
    small = np.array([[0.25, 0.25 * math.tan(math.radians(14))]])
    assert waypoints_to_action(small, far_goal, CTRL) == Action.MOVE_FORWARD
    # nothing beyond the lookahead distance: steer to the point goal itself
    still = np.zeros((5, 2))
    assert waypoints_to_action(still, np.array([0.0, -2.0]), CTRL) == Action.TURN_RIGHT
    fixed = ControlConfig.from_agent(AgentConfig(), waypoint_index=0)
    assert waypoints_to_action(left, far_goal, fixed) == Action.MOVE_FORWARD


def test_lookahead_at_the_last_waypoint():
    """waypoint_index=-1 (an option; the default is null, the first waypoint): a blurred "turn,
    then go" whose first waypoints creep straight ahead but whose end bends 60 deg left turns
    left; a prediction that stays in place steers to the point goal."""
    last = ControlConfig.from_agent(AgentConfig(), waypoint_index=-1)
    first = ControlConfig.from_agent(AgentConfig())
    bend = np.array([[0.15, 0.0], [0.25, 0.05], [0.3, 0.3], [0.35, 0.6]])
    far_goal = np.array([5.0, 0.0])
    assert waypoints_to_action(bend, far_goal, first) == Action.MOVE_FORWARD
    assert waypoints_to_action(bend, far_goal, last) == Action.TURN_LEFT
    assert waypoints_to_action(bend * [1, -1], far_goal, last) == Action.TURN_RIGHT
    assert waypoints_to_action(np.zeros((8, 2)), np.array([-1.0, -3.0]), last) == Action.TURN_RIGHT
    assert waypoints_to_action(bend, np.array([0.2, 0.1]), last) == Action.STOP


def hand_samples():
    """Expert samples: straight ahead, slightly left, far left; negatives: to the right."""
    straight = np.stack([np.arange(1, 9) * 0.25, np.zeros(8)], axis=1)
    expert = np.stack([straight + [0, 0.0], straight + [0, 0.3], straight + [0, 1.2], straight + [0, -0.2]])
    negative = np.stack([straight + [0, -0.6], straight + [0, -0.7], straight + [0, -0.5]])
    return expert, negative


def test_cor_selection_on_hand_made_samples():
    expert, negative = hand_samples()
    scores = cor(expert, negative, alpha=1.0).numpy()
    assert np.all((scores > 0) & (scores < 1))
    dist_to_neg = [np.sqrt(np.mean([np.sum((e - n) ** 2) for n in negative])) for e in expert]
    assert select_expert(expert, negative, 1.0, "argmax") == int(np.argmax(dist_to_neg)) == 2
    assert select_expert(expert, negative, 1.0, "argmin") == int(np.argmin(dist_to_neg)) == 3
    # the equation by hand for sample 0 (d_E over the whole expert set, self included)
    d_e = math.sqrt(np.mean([np.sum((expert[0] - x) ** 2) for x in expert]))
    d_n = math.sqrt(np.mean([np.sum((expert[0] - x) ** 2) for x in negative]))
    k = lambda d, a=1.0: (1 + d / a) ** (-(a + 1) / 2)  # noqa: E731
    assert scores[0] == pytest.approx(k(d_e) / (k(d_e) + k(d_n)))
    assert cor(expert, negative, 1.0, exclude_self=True)[0] != pytest.approx(scores[0])
    with pytest.raises(ValueError, match="argmax or argmin"):
        select_expert(expert, negative, 1.0, "max")
    with pytest.raises(ValueError, match="alpha"):
        cor(expert, negative, alpha=0.0)


def test_policies_are_deterministic_and_validate_obs():
    torch.manual_seed(0)
    cfg = load_model_config("nomad_pointgoal", "small")
    members = [Member(build_model(cfg).eval(), 0.25), Member(build_model(cfg).eval(), 0.25)]
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 255, (6, 96, 128, 3), dtype=np.uint8)

    def run(policy):
        policy.reset()
        return [policy.act({"rgb": f, "pointgoal": np.array([2.0, 0.5], np.float32)}) for f in frames]

    for policy in (PointGoalPolicy(members[:1], CTRL, 8, seed=1), NoMaDNegPolicy(members, CTRL, 8, seed=1)):
        first = run(policy)
        assert first == run(policy) and all(a in (1, 2, 3) for a in first)
        assert policy.last_waypoints.shape == (8, 2)
        assert policy.act({"rgb": frames[0], "pointgoal": np.array([0.1, 0.0])}) == Action.STOP
        with pytest.raises(ValueError, match="pointgoal"):
            policy.act({"rgb": frames[0], "pointgoal": np.array([np.nan, 0.0])})
        with pytest.raises(ValueError, match="uint8 RGB"):
            policy.act({"rgb": frames[0].astype(np.float32), "pointgoal": np.array([2.0, 0.0])})
    with pytest.raises(ValueError, match="selection"):
        NoMaDNegPolicy(members, CTRL, selection="min")


def test_vote_follows_the_action_most_samples_lead_to():
    """aggregate=vote: of 5 samples, 3 lead to TURN_LEFT, one forward, one right: the majority
    action wins and its first sample is followed; a tie goes to the earliest sample's action."""
    straight = np.stack([np.arange(1, 9) * 0.25, np.zeros(8)], axis=1)
    left = np.stack([np.full(8, 0.1), np.arange(1, 9) * 0.25], axis=1)
    right = left * [1, -1]
    policy = PointGoalPolicy([], CTRL, aggregate="vote")  # choose() needs no network
    goal = np.array([4.0, 0.0])
    samples = np.stack([straight, left, right, left, left])
    np.testing.assert_array_equal(policy.choose([samples], goal), left)
    np.testing.assert_array_equal(policy.choose([np.stack([right, straight, straight, right])], goal), right)
    np.testing.assert_array_equal(PointGoalPolicy([], CTRL).choose([samples], goal), straight)  # first
    # an ensemble pools its members' samples: member 0 alone ties (straight first), the pool says left
    pooled = policy.choose([np.stack([straight, right]), np.stack([left, straight, left, left])], goal)
    np.testing.assert_array_equal(pooled, left)
    with pytest.raises(ValueError, match="aggregate"):
        PointGoalPolicy([], CTRL, aggregate="mean")
    # medoid: the sample nearest the others (CoR's expert term alone); here a slightly bent left one sits
    # between the straight ones and the left ones, and the lone right one is the farthest
    bent = (straight + left) / 2
    medoid = PointGoalPolicy([], CTRL, aggregate="medoid")
    np.testing.assert_array_equal(medoid.choose([np.stack([right, straight, bent, left, straight])], goal), bent)
    np.testing.assert_array_equal(medoid.choose([np.stack([left, left, right])], goal), left)
    np.testing.assert_array_equal(medoid.choose([np.stack([right])], goal), right)  # one sample (ViNT): itself


def test_trajectory_oracle_predicts_the_expert_planners_path(tmp_path):
    """The trajectory oracle replans with rvn-gen's `ExpertPlanner` on the env's scene (its public
    ``scene``), with the env's navmesh step settings and the expert margin r_robot + margin_offset:
    its waypoints are the expert follower's next poses along that plan, in the robot frame; the
    goal follower bound to the same env stops within the env agent's success radius."""
    from rvn_data.benchmark.env import RVNEnv
    from rvn_data.benchmark.policies import GoalFollowerPolicy
    from rvn_data.conventions import to_local, to_planar
    from rvn_data.planning import ExpertPlanner, PathFollower
    from rvn_data.planning.follower import integrate
    from rvn_il.policies.trajectory_oracle import TrajectoryOraclePolicy

    agent = AgentConfig(r_robot=0.15)
    env = RVNEnv(mode="eval", split="val", scenes={"num_scenes": 1}, per_scene=1, agent=agent,
                 navmesh={"max_climb": 0.15}, camera={"width": 16, "height": 12},
                 episodes={"n_goals": 1, "dir": str(tmp_path)})
    oracle = TrajectoryOraclePolicy(clearance_pref=0.5, clearance_weight=4.0)
    with pytest.raises(RuntimeError, match="bind"):
        oracle.act({"pointgoal": np.zeros(2)})
    oracle.bind(env)
    goal_follower = GoalFollowerPolicy()
    goal_follower.bind(env)
    assert goal_follower.stop_radius == pytest.approx(0.3)
    obs, _ = env.reset(seed=0)
    planner = ExpertPlanner(env.scene, agent, 0.25, 0.05, 0.15, env.config.navmesh.max_slope_deg, 0.5, 4.0)
    planned = 0
    for _ in range(12):
        position, yaw = np.array(env.position), float(env.yaw)
        plan = planner.plan(position, env.goal)
        planned += plan is not None
        future = [to_planar(position)] * 8  # no expert path: the oracle predicts staying in place
        if plan is not None:
            follower, p, y, future = PathFollower(plan.waypoints, agent), position, yaw, []
            for _ in range(8):
                action = follower.act(p, y)
                p, y = (p, y) if action == Action.STOP else integrate(p, y, action, agent)
                future.append(to_planar(p))
        action = oracle.act(obs)
        np.testing.assert_allclose(oracle.last_waypoints, to_local(np.array(future), to_planar(position), yaw), atol=1e-12)
        assert action == waypoints_to_action(oracle.last_waypoints, obs["pointgoal"], oracle.control)
        obs, _, terminated, truncated, _ = env.step(action)
        assert not terminated
    assert planned >= 10 and oracle.planner.scene is env.scene and oracle.planner.max_climb == 0.15
    env.close()
    with pytest.raises(ValueError, match="margin_offset"):
        TrajectoryOraclePolicy(margin_offset=-0.5).bind(env)
    with pytest.raises(ValueError, match="stop_radius=0"):
        TrajectoryOraclePolicy(stop_radius=0)
    near = TrajectoryOraclePolicy(stop_radius=0.25)  # as the IL policies' model.policy.stop_radius
    near.bind(env)
    assert near.control.stop_radius == 0.25 and oracle.control.stop_radius == pytest.approx(agent.success_distance)


def test_trajectory_oracle_reaches_a_goal_inside_the_experts_margin(tmp_path):
    """The benchmark draws goals anywhere on the navmesh, about a fifth of them closer to an obstacle than the expert's
    margin (r_robot + 0.1 m), where rvn-gen never puts one. The oracle plans to the free cell nearest to such a goal and
    reaches it; before 2026-12-06 it had no plan there and steered straight at the goal (every such first goal of the
    recipe's 200 val episodes ended in a collision: SR_1 0.750 instead of 0.955)."""
    from rvn_data.benchmark.env import RVNEnv
    from rvn_il.policies.trajectory_oracle import TrajectoryOraclePolicy

    env = RVNEnv(mode="eval", split="val", scenes={"num_scenes": 1, "first_scene": 1}, per_scene=2,
                 camera={"width": 16, "height": 12}, episodes={"n_goals": 8, "dir": str(tmp_path)})
    oracle = TrajectoryOraclePolicy()
    oracle.bind(env)
    ends = []  # (goal inside the margin, reached) of each goal the episodes got to
    for _ in range(2):
        obs, info = env.reset()
        oracle.reset()
        done, inside = False, None
        while not done:
            before = info["goals_reached"]
            if inside is None:
                inside = not oracle._planner().is_free(env.goal, floor_y=float(env.position[1]))
            obs, _, terminated, truncated, info = env.step(oracle.act(obs))
            done = terminated or truncated
            if info["goals_reached"] > before or done:
                ends.append((inside, info["goals_reached"] > before))
                inside = None
    # procedural:val/1's two episodes: 16 goals, 5 of them inside the margin, every one reached
    assert ends.count((True, True)) == 5 and len(ends) == 16 and all(reached for _, reached in ends)
    env.close()


def test_trajectory_oracle_falls_back_to_a_tighter_margin_where_the_experts_has_no_plan(tmp_path):
    """procedural:val/10's first episode: its first goal lies where the expert's margin (r_robot + 0.1 m) leaves no
    path from the start. Without a fallback the oracle predicts staying in place and the adapter steers at the goal
    into a wall; with the default fallback (r_robot + 0.02 m) it plans through and reaches it."""
    from rvn_data.benchmark.env import RVNEnv
    from rvn_il.policies.trajectory_oracle import TrajectoryOraclePolicy

    env = RVNEnv(mode="eval", split="val", scenes={"num_scenes": 1, "first_scene": 10}, per_scene=1,
                 camera={"width": 16, "height": 12}, episodes={"n_goals": 1, "dir": str(tmp_path)})
    ends = []
    for oracle in (TrajectoryOraclePolicy(fallback_margin_offset=None), TrajectoryOraclePolicy()):
        oracle.bind(env)
        obs, _ = env.reset(seed=0)
        assert oracle._planner().plan(env.position, env.goal) is None
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(oracle.act(obs))
            done = terminated or truncated
        ends.append(info["episode"]["termination"])
    assert ends == ["collision", "success"] and oracle.fallback.margin == pytest.approx(env.agent.r_robot + 0.02)
    with pytest.raises(ValueError, match="fallback_margin_offset=0.1 must be >= 0 and below margin_offset=0.1"):
        TrajectoryOraclePolicy(fallback_margin_offset=0.1)
    env.close()


def test_trajectory_oracle_steps_on_where_the_env_did_not_count_its_stop(tmp_path):
    """procedural:val/20's episode 1, fifth goal: the oracle stood 0.3597 m from it in the plane, inside the STOP
    radius (2 r_robot = 0.36 m), but 0.3603 m away along the navmesh, where the env counts a STOP: it repeated the
    STOP until the timeout (one of the 13 timeouts of the 8ffc2da row). It now steps on toward the goal and reaches it."""
    from rvn_data.benchmark.env import RVNEnv
    from rvn_il.policies.trajectory_oracle import TrajectoryOraclePolicy

    env = RVNEnv(mode="eval", split="val", scenes={"num_scenes": 1, "first_scene": 20}, per_scene=2,
                 camera={"width": 16, "height": 12}, t_max=500, episodes={"n_goals": 5, "dir": str(tmp_path)})
    oracle = TrajectoryOraclePolicy()
    oracle.bind(env)
    obs, info = env.reset(options={"scene_index": 20, "episode_index": 1})
    oracle.reset()
    stops, done = 0, False
    while not done:
        action = oracle.act(obs)
        stops += action == Action.STOP
        obs, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
    rec = info["episode"]
    assert (rec["termination"], rec["goals_reached"], rec["collisions"]) == ("success", 5, 0) and stops <= 7
    env.close()


def test_checkpoint_of_another_kind_loads_through_its_entry_point(tmp_path):
    """rvn-eval's policy=checkpoint finds another trainer's loader by the kind its config.yaml records, through
    the package entry points (group rvn.checkpoint_loaders): rvn-rl's is registered; an unknown kind is one line."""
    from importlib.metadata import entry_points

    from rvn_il.policies import load_policy
    from rvn_rl.policy import load_rl_policy

    loaders = {ep.name: ep.load() for ep in entry_points(group="rvn.checkpoint_loaders")}
    assert loaders.get("rl") is load_rl_policy
    (tmp_path / "config.yaml").write_text("kind: nonesuch\n")
    with pytest.raises(ValueError, match=r"kind 'nonesuch' and no installed package loads that kind .*rl"):
        load_policy(tmp_path)

"""RVNEnv: Gymnasium API, reward / cost / termination semantics on hand-driven steps."""
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from rvn_data.conventions import Action, relative_goal
from rvn_data.benchmark.env import RVNEnv
from rvn_data.benchmark.policies import OraclePolicy
from rvn_data.benchmark.wrappers import RGBFrameStack

F, L, R, STOP = Action.MOVE_FORWARD, Action.TURN_LEFT, Action.TURN_RIGHT, Action.STOP


def make_env(tmp_path, **kw):
    base = dict(mode="eval", split="val", scenes={"num_scenes": 1}, per_scene=2,
                camera={"width": 32, "height": 24}, episodes={"n_goals": 2, "dir": str(tmp_path)})
    base.update(kw)
    return RVNEnv(**base)


@pytest.fixture
def env(tmp_path):
    e = make_env(tmp_path)
    yield e
    e.close()


@pytest.mark.parametrize("mode", ["eval", "train"])
def test_check_env(tmp_path, mode):
    e = make_env(tmp_path, mode=mode, split="val", depth=True)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*infinity.*")  # pointgoal is unbounded by design
        check_env(e, skip_render_check=True)
    obs, _ = e.reset(seed=1)
    assert obs["rgb"].shape == (24, 32, 3) and obs["rgb"].dtype == np.uint8
    assert obs["depth"].shape == (24, 32) and obs["depth"].dtype == np.float32
    assert obs["pointgoal"].shape == (2,) and obs["pointgoal"].dtype == np.float32
    e.close()


def test_registered(tmp_path):
    e = gymnasium.make("RVN-v0", mode="eval", split="val", scenes={"num_scenes": 1}, per_scene=1,
                       camera={"width": 16, "height": 16}, episodes={"n_goals": 1, "dir": str(tmp_path)})
    obs, info = e.reset(seed=0)
    assert isinstance(e.unwrapped, RVNEnv) and info["episode_id"] == "procedural:val/0#0"
    e.close()


def test_typed_config_builds_the_same_env(env, tmp_path):
    """rvn-eval's workers hand RVNEnv its typed EnvConfig (config=): the same episodes as the keywords."""
    typed = RVNEnv(config=env.config)
    a, _ = env.reset(options={"episode": 1})
    b, _ = typed.reset(options={"episode": 1})
    assert np.array_equal(a["rgb"], b["rgb"]) and np.array_equal(a["pointgoal"], b["pointgoal"])
    typed.close()
    with pytest.raises(ValueError, match=r"config= or settings as keywords, not both \(got \['t_max'\]\)"):
        RVNEnv(config=env.config, t_max=3)


def test_wall_collision_terminates(env):
    obs, info = env.reset(seed=0)
    d = info["distance_to_goal"]
    for _ in range(200):
        obs, reward, terminated, truncated, info = env.step(F)
        if terminated:
            break
        assert reward == pytest.approx(-(info["distance_to_goal"] - d) - 0.01, abs=1e-9)
        assert info["cost"] == 0.0 and not info["collided"] and info["displacement"] == pytest.approx(0.25)
        d = info["distance_to_goal"]
    assert terminated and not truncated
    assert reward == pytest.approx(-0.1) and info["cost"] == 1.0 and info["collided"]
    assert info["termination"] == "collision" and not info["success"]
    rec = info["episode"]
    assert rec["collisions"] == 1 and rec["goals_reached"] == 0 and rec["termination"] == "collision"
    with pytest.raises(RuntimeError, match="reset"):
        env.step(F)


def test_far_stop_is_a_noop(env, tmp_path):
    obs, info = env.reset(seed=0)
    assert info["distance_to_goal"] > 4.0 - 1e-6
    obs2, reward, terminated, truncated, info2 = env.step(STOP)
    assert reward == pytest.approx(-0.01) and not terminated and not truncated
    assert np.array_equal(obs2["pointgoal"], obs["pointgoal"]) and info2["goals_reached"] == 0
    strict = make_env(tmp_path, stop_far_is_failure=True)
    strict.reset(seed=0)
    _, _, terminated, _, info = strict.step(STOP)
    assert terminated and info["termination"] == "stop_far" and not info["success"]
    strict.close()


def test_stop_near_goal_gives_next_goal_then_success(env):
    oracle = OraclePolicy()
    oracle.bind(env)
    obs, info = env.reset(seed=0)
    oracle.reset()
    episode = env.unwrapped._episode
    rewards = []
    for _ in range(500):
        action = oracle.act(obs)
        pos = env.position.copy()
        obs, reward, terminated, truncated, info = env.step(action)
        if action == STOP:
            break
        rewards.append(reward)
    assert reward == 1.0 and info["goals_reached"] == 1 and not terminated
    assert np.array_equal(env.position, pos)  # STOP does not move; the scene is not reset
    assert np.array_equal(env.goal, episode.goals[1])
    assert abs(info["distance_to_goal"] - episode.goal_distances[1]) <= 2 * 0.18 + 0.05
    assert obs["pointgoal"] == pytest.approx(relative_goal(pos, env.yaw, episode.goals[1]))
    assert all(r < 0.3 for r in rewards)
    for _ in range(500):
        obs, reward, terminated, truncated, info = env.step(oracle.act(obs))
        if terminated or truncated:
            break
    assert terminated and info["success"] and info["termination"] == "success" and reward == 1.0
    rec = info["episode"]
    assert rec["goals_reached"] == 2 and rec["first_goal_success"] and rec["collisions"] == 0


def test_oracle_plans_over_the_discrete_actions_where_its_greedy_rule_circles(tmp_path):
    """procedural:val/19's episode 3: its seventh goal lies where the navmesh's shortest route passes a gap that the
    discrete steps cannot, and the greedy rule circled there until the timeout (6 goals in the recipe's Oracle row).
    After ``replan_after`` steps without getting nearer, the oracle plans over the actions with A* and reaches it."""
    env = RVNEnv(mode="eval", split="val", scenes={"num_scenes": 1, "first_scene": 19}, per_scene=4,
                 camera={"width": 16, "height": 12}, t_max=500, episodes={"n_goals": 7, "dir": str(tmp_path)})
    ends = []
    for oracle in (OraclePolicy(replan_after=0), OraclePolicy()):
        oracle.bind(env)
        obs, _ = env.reset(options={"scene_index": 19, "episode_index": 3})
        oracle.reset()
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(oracle.act(obs))
            done = terminated or truncated
        ends.append((info["episode"]["termination"], info["episode"]["goals_reached"], info["episode"]["collisions"]))
    assert ends == [("timeout", 6, 0), ("success", 7, 0)]
    env.close()


def test_timeout_truncates(tmp_path):
    e = make_env(tmp_path, t_max=3)
    e.reset(seed=0)
    for i in range(3):
        _, reward, terminated, truncated, info = e.step(L)
        assert reward == pytest.approx(-0.01) and not terminated
    assert truncated and info["termination"] == "timeout"
    e.close()


def test_invalid_action(env):
    env.reset(seed=0)
    with pytest.raises(ValueError, match="invalid action 7"):
        env.step(7)
    with pytest.raises(ValueError, match="invalid action 1.0"):
        env.step(1.0)
    assert env.step(np.int64(2))[4]["goal_steps"] == 1
    with pytest.raises(ValueError, match="episode=5 out of range.*2 episodes"):
        env.reset(options={"episode": 5})


def test_frame_stack(env):
    stacked = RGBFrameStack(env, context=3)
    assert stacked.observation_space["rgb"].shape == (3, 24, 32, 3)
    obs, _ = stacked.reset(seed=0)
    assert obs["rgb"].shape == (3, 24, 32, 3)
    assert np.array_equal(obs["rgb"][0], obs["rgb"][2])
    obs2, *_ = stacked.step(L)
    assert np.array_equal(obs2["rgb"][1], obs["rgb"][2]) and not np.array_equal(obs2["rgb"][2], obs["rgb"][2])
    assert stacked.observation_space.contains(obs2)


def test_train_mode_switches_scene(tmp_path):
    e = make_env(tmp_path, mode="train", split="val", scene_specs=["procedural:val/0", "procedural:val/1"],
                 scene_switch_every=2, episodes={"n_goals": 2})
    scenes = []
    for i in range(8):
        _, info = e.reset() if i else e.reset(seed=4)
        # drawn on the start's distance field, reported on the goal's: the two agree to about a cell
        assert 4.0 - 0.05 <= info["distance_to_goal"] <= 8.0 + 0.05
        scenes.append(info["scene_id"])
    assert all(scenes[i] == scenes[i + 1] for i in range(0, 8, 2))  # K = 2 resets per scene
    assert set(scenes) == {"procedural:val/0", "procedural:val/1"}
    e.close()


def test_train_mode_switches_scene_after_a_step_budget(tmp_path):
    """scene_switch_steps=S (Habitat's max_scene_repeat_steps): a scene is drawn at the first reset after the visit's
    budget of steps, a budget within S +- 20 % drawn at each visit, and at no other reset (scene_switch_every=0); the
    same seed gives the same draws; both rules off is refused."""
    kw = dict(mode="train", split="val", scene_specs=[f"procedural:val/{i}" for i in range(3)], scene_switch_every=0,
              scene_switch_steps=5, episodes={"n_goals": 2})

    def run():
        e, steps, draws, resets = make_env(tmp_path, **kw), [0], [], []
        real = e._draw_scene
        e._draw_scene = lambda: (draws.append((steps[0], e._scene_budget)), real())[1]
        rng = np.random.default_rng(0)
        e.reset(seed=5)
        budgets = [e._scene_budget]
        for _ in range(600):
            *_, terminated, truncated, _ = e.step(int(rng.choice([0, 1, 1, 2, 3])))
            steps[0] += 1
            if terminated or truncated:
                n = len(draws)
                e.reset()
                resets.append((steps[0], len(draws) > n))
                if len(draws) > n:
                    budgets.append(e._scene_budget)
        e.close()
        return draws, resets, budgets

    draws, resets, budgets = run()
    assert len(draws) >= 10 and set(budgets) == {4, 5, 6}
    later, last, budget, exact = iter(budgets[1:]), 0, budgets[0], 0
    for t, drawn in resets:
        assert drawn == (t - last >= budget), (t, last, budget)
        exact += t - last == budget  # the boundary: a reset just as the budget is spent draws
        if drawn:
            last, budget = t, next(later)
    assert exact >= 1
    assert run() == (draws, resets, budgets)
    with pytest.raises(ValueError, match="scene_switch_every=0 and scene_switch_steps=0: .* never draw another scene"):
        make_env(tmp_path, mode="train", scene_switch_every=0)
    with pytest.raises(ValueError, match="scene_switch_steps=-1 must be a non-negative integer"):
        make_env(tmp_path, mode="train", scene_switch_steps=-1)


def test_train_mode_with_both_switch_rules_counts_each_visit_afresh(tmp_path):
    """scene_switch_every=N with scene_switch_steps=S: a scene is drawn after N episodes of the visit or at the first
    reset after its step budget, whichever comes first, both counts starting again at each switch, as Habitat's
    episode iterator. The episode count ran from the seeded reset, so after a switch by steps the next scene could be
    left after fewer than N episodes."""
    kw = dict(mode="train", split="val", scene_specs=[f"procedural:val/{i}" for i in range(3)], scene_switch_every=3,
              scene_switch_steps=25, episodes={"n_goals": 2})
    e, draws = make_env(tmp_path, **kw), []
    real = e._draw_scene
    e._draw_scene = lambda: (draws.append(1), real())[1]
    rng = np.random.default_rng(0)
    e.reset(seed=5)
    steps = episodes = 0
    budget, by = e._scene_budget, {"steps": 0, "episodes": 0}
    for _ in range(900):
        *_, terminated, truncated, _ = e.step(int(rng.choice([0, 1, 1, 2, 3])))
        steps += 1
        if terminated or truncated:
            episodes, n = episodes + 1, len(draws)
            e.reset()
            drawn = len(draws) > n
            assert drawn == (episodes >= 3 or steps >= budget), (episodes, steps, budget)
            if drawn:
                by["episodes" if episodes >= 3 and steps < budget else "steps"] += 1
                steps = episodes = 0
                budget = e._scene_budget
    e.close()
    assert by["steps"] >= 3 and by["episodes"] >= 3, by  # both rules switched, after each other


def test_train_goals_from_the_scene_pool(tmp_path):
    """goal_pool=G: every train goal is one of the scene's G pool points, 4-8 m from where
    it is given, its field equal to a fresh solve; the pool is a function of the scene alone."""
    kw = dict(mode="train", split="val", scene_specs=["procedural:val/0"], goal_pool=12, episodes={"n_goals": 2})
    a, b = make_env(tmp_path, **kw), make_env(tmp_path, **kw)
    a.reset(seed=3)
    pool = a._scene.goal_sampler(a.config).goals
    assert pool.shape == (12, 3)
    goals = []
    for i in range(6):
        _, info = a.reset() if i else a.reset(seed=3)
        _, info_b = b.reset() if i else b.reset(seed=3)
        assert info == info_b and np.array_equal(a.goal, b.goal)  # same seed, same draws
        assert np.min(np.linalg.norm(pool - a.goal, axis=1)) < 1e-9
        assert 4.0 - 1e-4 <= info["distance_to_goal"] <= 8.0 + 1e-4
        fresh = a.navmesh.distance_field(a.goal).distance(a.position)
        assert abs(a.goal_field.distance(a.position) - fresh) < 1e-4
        goals.append(tuple(a.goal))
    assert len(set(goals)) > 1
    a.close(), b.close()
    with pytest.raises(ValueError, match="goal_pool=-1 must be a non-negative integer"):
        make_env(tmp_path, mode="train", goal_pool=-1)


def test_goal_draws_read_the_pool_in_one_call_as_field_by_field(tmp_path):
    """A pool's goal draw reads all its fields in one call (`rvn_data.navmesh.field_sets.fields_distance`): the same
    distances bit for bit as each field's own lookup, at new points (smoothing on the way) and again; the fields share
    that smoothing with the stack."""
    from rvn_data.benchmark.goal_pool import GoalPool, PoolSampler
    from rvn_data.navmesh.field_sets import fields_distance

    e = make_env(tmp_path, mode="train", split="val", scene_specs=["procedural:val/0"], goal_pool=4)
    e.reset(seed=1)
    nav = e.navmesh
    stacked, apart = GoalPool.build(nav, 16, 2, 0), GoalPool.build(nav, 16, 2, 0)
    a, fields = PoolSampler(nav, stacked), apart.fields(nav)  # the other pool read field by field
    rng = np.random.default_rng(0)
    points = [nav.sample(rng, island=0) for _ in range(40)]
    for p in points + points[::-1]:
        d = fields_distance(nav, a.stack, p)
        assert d.shape == (16,) and np.array_equal(d, [f.distance(p) for f in fields])
    many = np.array(points)
    assert np.array_equal(fields_distance(nav, a.stack, many), [f.distance(many) for f in fields])
    for fa, fb, ta, tb in zip(a.fields, fields, stacked.stack.trees, apart.stack.trees):  # the fields read the stack's state
        assert np.array_equal(fa.values, fb.values) and np.array_equal(ta.out, tb.out)
        assert fa.distance(points[0]) == fb.distance(points[0])
    drawn = [a.sample(p, np.random.default_rng(7), 4.0, 8.0) for p in points]
    assert any(x is not None for x in drawn)
    for p, x in zip(points, drawn):
        assert x is None or (any(np.array_equal(x[0], g) for g in stacked.goals) and 4.0 <= x[1].distance(p) <= 8.0)
    e.close()


@pytest.mark.parametrize("metric", ["geodesic", "euclidean"])
def test_reported_distances_are_fresh_lookups(tmp_path, metric):
    """A step looks the agent's distance to the goal up once (`RVNEnv._act`: the geodesic success test reuses it,
    the info reports the kept one): every reward, ending and info equals an env's that looks each distance up again
    where it is used (the code before 2026-12-05), over oracle-driven episodes (goals reached: new goals, STOPs near
    and far) and random actions, in train and eval mode."""
    import dataclasses
    import types

    act, info_of = RVNEnv._act, RVNEnv._info

    def fresh_act(self, a):
        return dataclasses.replace(act(self, a), goal_distance=self.success_distance_now())

    def fresh_info(self, step):
        return {**info_of(self, step), "distance_to_goal": float(self.distance_to_goal())}

    for mode, split in (("eval", "val"), ("train", "train")):
        kw = dict(mode=mode, split=split, success_metric=metric, goal_pool=8 if mode == "train" else 0)
        runs = []
        for fresh in (False, True):
            e = make_env(tmp_path, **kw)
            if fresh:  # this env instance only: the kept distances replaced by lookups where they are used
                e._act, e._info = types.MethodType(fresh_act, e), types.MethodType(fresh_info, e)
            oracle, rng, seen = OraclePolicy(), np.random.default_rng(3), []
            oracle.bind(e)
            obs, info = e.reset(seed=0)
            oracle.reset()
            for k in range(600):
                action = oracle.act(obs) if (k // 100) % 2 == 0 else int(rng.choice([0, 1, 1, 2, 3]))
                obs, reward, terminated, truncated, info = e.step(action)
                assert info["distance_to_goal"] == e.distance_to_goal()
                seen.append((reward, terminated, truncated, {k: v for k, v in info.items() if k != "episode"}))
                if terminated or truncated:
                    obs, _ = e.reset()
                    oracle.reset()
            runs.append(seen)
            e.close()
        assert runs[0] == runs[1]
        assert any(r == 1.0 for r, *_ in runs[0])  # goals were reached

"""The task's measures (rvn_data.benchmark.measures): the rules on hand-made step records,
and RVNEnv's rewards, costs and endings, step by step, against them and the paper's values."""
import pytest

from rvn_data.benchmark import measures
from rvn_data.benchmark.env import RVNEnv
from rvn_data.benchmark.measures import StepRecord, TaskRules
from rvn_data.conventions import Action

F, L, STOP = int(Action.MOVE_FORWARD), int(Action.TURN_LEFT), int(Action.STOP)
RULES = TaskRules(success_distance=0.36, n_goals=2, t_max=10)


def step(action=F, collided=False, before=5.0, after=4.75, goal_distance=4.75, goal_steps=1, goals_reached=0):
    return StepRecord(action=action, collided=collided, displacement=0.25 if action == F and not collided else 0.0,
                      dtg_before=before, dtg_after=after, goal_distance=goal_distance, goal_steps=goal_steps,
                      goals_reached=goals_reached)


@pytest.mark.parametrize("rec, reached, ending, reward, cost", [
    (step(), False, None, 0.25 - 0.01, 0.0),  # progress: -Δdtg - 0.01
    (step(after=5.25, goal_distance=5.25), False, None, -0.25 - 0.01, 0.0),  # away from the goal
    (step(collided=True, after=5.0), False, "collision", -0.1, 1.0),
    (step(collided=True, goal_steps=10), False, "collision", -0.1, 1.0),  # a collision outranks T_max
    (step(L, after=5.0, goal_distance=5.0, goal_steps=10), False, "timeout", -0.01, 0.0),
    (step(STOP, after=5.0, goal_distance=0.36), True, None, 1.0, 0.0),  # the next goal is given
    (step(STOP, after=5.0, goal_distance=0.36, goal_steps=10), True, None, 1.0, 0.0),  # ... and its T_max restarts
    (step(STOP, after=5.0, goal_distance=0.2, goals_reached=1), True, "success", 1.0, 0.0),  # N_goal-th goal
    (step(STOP, after=5.0, goal_distance=0.37), False, None, -0.01, 0.0),  # STOP far: a no-op
    (step(F, after=0.2, goal_distance=0.2), False, None, 4.8 - 0.01, 0.0),  # at the goal without STOP
])
def test_rules_on_step_records(rec, reached, ending, reward, cost):
    assert measures.goal_reached(RULES, rec) is reached
    assert measures.termination(RULES, rec) == ending
    assert measures.reward(RULES, rec) == pytest.approx(reward, abs=1e-12)
    assert measures.cost(rec) == cost
    assert measures.is_truncation(ending) is (ending == "timeout")


def test_stop_far_can_be_a_failure():
    strict = TaskRules(success_distance=0.36, n_goals=2, t_max=10, stop_far_is_failure=True)
    assert measures.termination(strict, step(STOP, after=5.0, goal_distance=0.37)) == "stop_far"
    assert measures.termination(strict, step(STOP, after=5.0, goal_distance=0.3)) is None
    assert measures.episode_success({"termination": "success"})
    assert not measures.episode_success({"termination": "stop_far"})


def make_env(tmp_path, **kw):
    return RVNEnv(**{**dict(mode="eval", split="val", scenes={"num_scenes": 1}, per_scene=1,
                            camera={"width": 16, "height": 16}, episodes={"n_goals": 1, "dir": str(tmp_path)}), **kw})


def drive(env, actions):
    """Step ``env`` (one goal per episode: the goal never changes) through ``actions`` until the
    episode ends; check every step's reward, cost and ending against the measures of the record
    rebuilt from the env's public state."""
    _, info = env.reset(seed=0)
    for a in actions:
        dtg, goal_steps, goals = info["distance_to_goal"], info["goal_steps"], info["goals_reached"]
        _, reward, terminated, truncated, info = env.step(a)
        moved = a != STOP
        rec = StepRecord(action=a, collided=info["collided"], displacement=info["displacement"], dtg_before=dtg,
                         dtg_after=env.distance_to_goal() if moved else dtg, goal_distance=env.success_distance_now(),
                         goal_steps=goal_steps + 1, goals_reached=goals)
        ending = measures.termination(env.rules, rec)
        expected = (measures.reward(env.rules, rec), measures.cost(rec), ending)
        assert (reward, info["cost"], info["termination"]) == expected
        assert (terminated, truncated) == (ending not in (None, "timeout"), ending == "timeout")
        if terminated or truncated:
            return reward, info
    raise AssertionError("the episode did not end")


def test_env_collision_costs_one_and_ends_the_episode(tmp_path):
    env = make_env(tmp_path)
    reward, info = drive(env, [F] * 200)  # straight ahead into a wall
    env.close()
    assert info["termination"] == "collision" and info["cost"] == 1.0 and reward == -0.1
    assert info["episode"]["collisions"] == 1 and info["episode"]["termination"] == "collision"


def test_env_stop_inside_the_success_distance_is_success(tmp_path):
    probe = make_env(tmp_path)
    probe.reset(seed=0)
    d = probe.success_distance_now()  # how far the episode's goal is at the start
    probe.close()
    near = make_env(tmp_path, success_distance=d + 1e-3)
    reward, info = drive(near, [STOP])
    near.close()
    assert info["termination"] == "success" and info["success"] and reward == 1.0 and info["cost"] == 0.0
    assert info["episode"]["goals_reached"] == 1 and info["episode"]["first_goal_success"]
    short = make_env(tmp_path, success_distance=d - 1e-3, t_max=2)
    reward, info = drive(short, [STOP, STOP])  # just outside: STOP is a no-op, then T_max
    short.close()
    assert info["termination"] == "timeout" and info["goals_reached"] == 0 and reward == pytest.approx(-0.01)


def test_env_t_max_ends_the_episode_as_timeout(tmp_path):
    env = make_env(tmp_path, t_max=3)
    reward, info = drive(env, [L] * 3)
    env.close()
    assert info["termination"] == "timeout" and info["goal_steps"] == 3 and not info["success"]
    assert info["episode"]["steps"] == 3 and info["episode"]["termination"] == "timeout"

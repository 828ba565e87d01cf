"""The RVN task's measures: the reward, the Safe-RL cost and the rules that end a goal or an
episode, each one pure function of one step's record (paper, "Task Definition" and
"Reinforcement Learning Environment").

Contract. A `StepRecord` says what one step did: the action, whether it collided, how far
the agent moved, the geodesic distance to the goal before and after it (``dtg``), the
distance the goal test compares (``goal_distance``: geodesic, or straight-line with
``success_metric="euclidean"``), the steps spent on the current goal (this one included)
and the goals reached before it. `TaskRules` holds the task's settings (success distance,
N_goal, T_max, the rewards). From these two, and nothing else:

- `goal_reached`: STOP within ``success_distance`` of the goal (the next goal is given);
- `termination`: how the step ends the episode, if it does: ``success`` (the N_goal-th
  goal reached), ``collision`` (failure due to collision), ``stop_far`` (STOP away from the
  goal, with ``stop_far_is_failure``), ``timeout`` (failure due to timeout: T_max steps on
  one goal; the only truncation, `is_truncation`), or None;
- `reward`: r_goal_reached on a reached goal, r_collision on a collision, else
  −Δ_dtg − slack (a STOP short of the goal moves nothing: −slack);
- `cost`: the Safe-RL cost, 1.0 on a collision, else 0.0;
- `episode_success`: an episode record (`rvn_data.benchmark.metrics`) ended in success.

`RVNEnv.step` builds the record and asks these functions for its reward, ``info["cost"]``
and ending, so rvn-eval's episode runner and rvn-rl's `BatchEnv` (which both step an
`RVNEnv`) see one definition of each; `RVNEnv.at_goal` (the oracle's goal test) and rvn-rl's
training log (`rvn_rl.runlog`) call `within_success_distance` and `episode_success`.
"""
from __future__ import annotations

from dataclasses import dataclass

from rvn_data.conventions import Action

SUCCESS, COLLISION, TIMEOUT, STOP_FAR = "success", "collision", "timeout", "stop_far"
TERMINATIONS = (SUCCESS, COLLISION, TIMEOUT, STOP_FAR)  # the order of metrics' ``goal_ends``


@dataclass(frozen=True)
class StepRecord:
    """What one step of the task did, as the measures see it (distances in metres)."""

    action: int  # an `Action`
    collided: bool  # the simulator's MOVE_FORWARD fell short of d_step (turns and STOP never collide)
    displacement: float  # how far the agent moved
    dtg_before: float  # geodesic distance to the goal before the step
    dtg_after: float  # and after it (equal to dtg_before when nothing moved)
    goal_distance: float  # what the goal test compares with success_distance, after the step
    goal_steps: int  # steps taken toward the current goal, this one included
    goals_reached: int  # goals reached before this step


@dataclass(frozen=True)
class TaskRules:
    """The task's settings the measures read (defaults: the paper's)."""

    success_distance: float  # m; the paper's 2·r_robot
    n_goals: int  # N_goal: goals per episode
    t_max: int  # T_max: steps allowed per goal
    stop_far_is_failure: bool = False  # STOP away from the goal: a no-op step (False) or a failure
    reward_goal: float = 1.0  # r_goal_reached
    reward_collision: float = -0.1  # r_collision, terminal
    slack_penalty: float = 0.01  # the step-wise −0.01


def within_success_distance(distance: float, success_distance: float) -> bool:
    """A goal ``distance`` m away counts as reached by a STOP."""
    return distance <= success_distance


def goal_reached(rules: TaskRules, step: StepRecord) -> bool:
    """The step was a STOP within ``success_distance`` of the goal."""
    return step.action == Action.STOP and within_success_distance(step.goal_distance, rules.success_distance)


def termination(rules: TaskRules, step: StepRecord) -> str | None:
    """How the step ends the episode (one of `TERMINATIONS`), or None when it goes on. A goal
    reached before the N_goal-th gives the next goal, whose T_max count starts afresh."""
    if step.collided:
        return COLLISION
    if goal_reached(rules, step):
        return SUCCESS if step.goals_reached + 1 >= rules.n_goals else None
    if step.action == Action.STOP and rules.stop_far_is_failure:
        return STOP_FAR
    if step.goal_steps >= rules.t_max:
        return TIMEOUT
    return None


def is_truncation(ending: str | None) -> bool:
    """The ending is a time limit (Gymnasium's ``truncated``), not a task outcome (``terminated``)."""
    return ending == TIMEOUT


def reward(rules: TaskRules, step: StepRecord) -> float:
    """The paper's r_t: r_goal_reached, r_collision, else −Δ_dtg − 0.01."""
    if goal_reached(rules, step):
        return rules.reward_goal
    if step.collided:
        return rules.reward_collision
    return -(step.dtg_after - step.dtg_before) - rules.slack_penalty


def cost(step: StepRecord) -> float:
    """The Safe-RL cost c_t: 1.0 when the step collided, else 0.0."""
    return 1.0 if step.collided else 0.0


def episode_success(record: dict) -> bool:
    """An episode record (`rvn_data.benchmark.metrics`) reached all N_goal goals."""
    return record["termination"] == SUCCESS

"""policy.turn_commit's state machine (rvn_il/policies/turn_commit.py) on scripted actions; through load_policy on a
trained checkpoint in tests/test_depth_aux.py (check_turn_commit)."""
from __future__ import annotations

from rvn_data.conventions import Action
from rvn_il.policies.turn_commit import TurnCommit

S, F, L, R = (int(a) for a in (Action.STOP, Action.MOVE_FORWARD, Action.TURN_LEFT, Action.TURN_RIGHT))


def run(commit: TurnCommit, model_actions: list[int], replaced: dict[int, int] | None = None) -> list[int]:
    """The actions taken, as the policy calls it: act, then (after the escape, here ``replaced`` at step i) taken."""
    out = []
    for i, a in enumerate(model_actions):
        a = commit.act(a)
        a = (replaced or {}).get(i, a)
        commit.taken(a)
        out.append(a)
    return out


def test_a_dither_becomes_a_sweep_until_the_model_drives():
    commit = TurnCommit()
    assert run(commit, [L, R, L, R, F, R, L, R]) == [L, L, L, L, F, R, R, R] and commit.commits == 3
    commit.reset()
    assert (commit.last, commit.commits) == (None, 0)
    assert run(commit, [R, L, S, L, R]) == [R, R, S, L, L] and commit.commits == 2  # a stop ends the turning too


def test_turns_one_way_and_forward_steps_pass_unchanged():
    commit = TurnCommit()
    assert run(commit, [L, L, F, F, R, R, F, L]) == [L, L, F, F, R, R, F, L] and commit.commits == 0


def test_the_turn_taken_counts_not_the_one_proposed():
    """The escape comes after the commitment and may turn the other way: that turn is the one to keep."""
    commit = TurnCommit()
    assert run(commit, [L, L, L, L], replaced={1: R}) == [L, R, R, R] and commit.commits == 2

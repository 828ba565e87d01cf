"""ppo.recompute_advantages: the rollout's values (the bootstrap after its last step included) recomputed with the
weights the update starts from, and GAE's returns again from them. Through `DeviceRollouts.start_policy` against
the policy stepped one step at a time, and through rvn-rl's public API (`rvn_rl.cli.compose`,
`rvn_rl.trainer.train`): synchronous PPO acts with the weights its update starts from, so there the values are the
acting ones up to rounding; with train.overlap a rollout's values come from the weights one update older."""
from __future__ import annotations

import json

import pytest
import torch

from test_rl_decoupled import TINY


def stepped(policy, rollouts) -> tuple[torch.Tensor, torch.Tensor]:
    """The log-probs of the rollout's actions [step, N] and the values [step + 1, N, heads] of the policy (eval mode)
    stepped through the rollout one step at a time."""
    logp, values, state = [], [], rollouts.state0.clone()
    policy.eval()
    with torch.no_grad():
        for t in range(rollouts.step + 1):
            feats, state = policy({k: v[t] for k, v in rollouts.obs.items()}, state, rollouts.prev_actions[t],
                                  rollouts.masks[t])
            values.append(policy.values(feats))
            if t < rollouts.step:
                logp.append(torch.log_softmax(policy.actor(feats), -1).gather(-1, rollouts.actions[t, :, None])[:, 0])
    return torch.stack(logp), torch.stack(values)


@pytest.mark.parametrize("chunks", [1, 2])
def test_recomputed_values_are_the_policys_and_returns_follow(chunks):
    """Values in the storage that no network gave: after `start_policy` and `use_values` they are the policy's own,
    step by step (episode restarts mid-way included), and the returns are GAE over them; the same pass's log-probs
    (ppo.decoupled's proximal ones) are the stepped policy's too."""
    from test_rl_recurrent import small_update_setup

    from rvn_rl.rollout import DeviceRollouts
    from rvn_rl.trainer import _Evaluate

    policy, _, rollouts = small_update_setup()
    expected_logp, expected = stepped(policy, rollouts)
    before = rollouts.values.clone()
    policy.train()  # as the update finds it: the pass runs in eval mode (the normaliser's statistics stay) and back
    batches = DeviceRollouts(rollouts, "cpu")
    logp, values = batches.start_policy(_Evaluate(policy), chunks)
    n = rollouts.step
    torch.testing.assert_close(logp, expected_logp, rtol=1e-4, atol=1e-5)
    batches.use_values(values, 0.99, 0.95)
    assert not torch.allclose(before[:n + 1], expected, atol=1e-3)
    torch.testing.assert_close(rollouts.values[:n + 1], expected, rtol=1e-4, atol=1e-5)
    returns = rollouts.returns[:n].clone()
    rollouts.compute_returns(expected[n], 0.99, 0.95)  # GAE over the stepped values
    torch.testing.assert_close(returns, rollouts.returns[:n], rtol=1e-4, atol=1e-5)
    assert policy.training


def run(monkeypatch, out, *overrides: str) -> tuple[list[float], list[dict]]:
    """A tiny rvn-rl PPO run. Returns, per update with ppo.recompute_advantages, the largest |recomputed - acting|
    value; and the log rows."""
    from rvn_rl import rollout, trainer
    from rvn_rl.cli import compose

    gaps, use_values = [], rollout.DeviceRollouts.use_values

    def recording(self, values, gamma, tau):
        acting = self.r.values[:self.r.step + 1].clone()
        use_values(self, values, gamma, tau)
        gaps.append(float((self.r.values[:self.r.step + 1] - acting).abs().max()))

    with monkeypatch.context() as patch:
        patch.setattr(rollout.DeviceRollouts, "use_values", recording)
        trainer.train(compose(["algo=ppo", f"out_dir={out}", *TINY, *overrides]))
    return gaps, [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]


@pytest.mark.slow  # rvn-rl runs
def test_synchronous_recomputed_values_are_the_acting_ones(tmp_path, monkeypatch):
    """One synchronous update: the recomputed values are those the acting policy gave (one policy, over the
    sequences instead of step by step), so the losses are plain PPO's up to rounding: the values' ~4e-8 carried
    through the update's 8 optimizer steps, 1e-8 to 1e-7 relative on main's stream and seeds 1-2, 6.3e-5 (value_loss)
    with env.goal_pool=8 (2026-12-03), hence 1e-3; a fault in the values is caught by ``gaps`` first."""
    _, plain = run(monkeypatch, tmp_path / "plain", "train.total_steps=16")
    gaps, rows = run(monkeypatch, tmp_path / "recomputed", "train.total_steps=16", "ppo.recompute_advantages=true")
    assert len(gaps) == 1 and gaps[0] < 1e-4, gaps
    for key in ("value_loss", "action_loss", "entropy", "grad_norm"):
        assert rows[0][key] == pytest.approx(plain[0][key], rel=1e-3, abs=1e-6), key


@pytest.mark.slow
def test_overlapped_values_come_from_the_updates_weights(tmp_path, monkeypatch):
    """train.overlap: the first rollout is acted by the weights the first update starts from (the same values); the
    second and third by weights one update older than their update's, so their values change, and the losses with
    them."""
    gaps, rows = run(monkeypatch, tmp_path / "recomputed", "train.total_steps=48", "train.overlap=true",
                     "ppo.recompute_advantages=true")
    assert len(gaps) == 3 and len(rows) == 3
    assert gaps[0] < 1e-4, gaps
    assert gaps[1] > 1e-4 and gaps[2] > 1e-4, gaps
    _, plain = run(monkeypatch, tmp_path / "plain", "train.total_steps=48", "train.overlap=true")
    assert rows[0]["value_loss"] == pytest.approx(plain[0]["value_loss"], rel=1e-3, abs=1e-6)
    assert rows[1]["value_loss"] != pytest.approx(plain[1]["value_loss"], rel=1e-3, abs=1e-6)


def test_decoupled_and_recomputed_share_one_pass(monkeypatch):
    """ppo.decoupled with ppo.recompute_advantages: the update runs the weights at its start over the rollout once,
    and takes its values for GAE and its log-probs as the proximal policy's."""
    from test_rl_recurrent import small_update_setup

    from rvn_rl.ppo import PPOConfig, ppo_update
    from rvn_rl.rollout import DeviceRollouts
    from rvn_rl.trainer import _Evaluate

    policy, _, rollouts = small_update_setup()
    passes, start_policy = [], DeviceRollouts.start_policy

    def counting(self, model, chunks):
        passes.append(start_policy(self, model, chunks))
        return passes[-1]

    monkeypatch.setattr(DeviceRollouts, "start_policy", counting)
    batches = DeviceRollouts(rollouts, "cpu")
    cfg = PPOConfig(ppo_epoch=2, num_mini_batch=2, decoupled=True, recompute_advantages=True)
    ppo_update(_Evaluate(policy), torch.optim.Adam(policy.parameters(), lr=1e-4), batches, cfg,
               torch.Generator().manual_seed(0))
    assert len(passes) == 1
    logp, values = passes[0]
    n = rollouts.step
    assert torch.equal(rollouts.values[:n + 1], values)
    assert batches._on_device["prox_logp"] is logp

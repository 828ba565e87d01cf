"""ppo.decoupled through rvn-rl's public API (`rvn_rl.cli.compose`, `rvn_rl.trainer.train`) at tiny sizes: the
surrogate is clipped around the proximal policy (the weights at the update's start, their log-probs recomputed) and
weighted by its ratio to the behaviour policy that acted. Synchronous PPO acts with the weights its update starts
from, so there the two are one policy and the update is plain PPO's up to rounding; with train.overlap a rollout is
acted by the weights one update older, and the proximal log-probs are those of the newer weights."""
from __future__ import annotations

import json

import pytest
import torch
from safetensors.torch import load_file

pytestmark = pytest.mark.slow  # rvn-rl runs

TINY = ["env.size=32", "env.num_envs=2", "env.num_scenes=2", "ppo.num_steps=8", "ppo.num_mini_batch=2",
        "model.backbone=resnet18", "train.threads=1", "progress=false", "renderer=raycast"]


def run(monkeypatch, out, *overrides: str) -> tuple[list[float], list[dict], dict]:
    """A tiny rvn-rl PPO run. Returns, per update with ppo.decoupled, the largest |proximal - behaviour| log-prob
    gap; the log rows; the last checkpoint's weights."""
    from rvn_rl import rollout, trainer
    from rvn_rl.cli import compose

    gaps, set_proximal = [], rollout.DeviceRollouts.set_proximal

    def recording(self, adv, logp):
        set_proximal(self, adv, logp)
        d = self._on(adv)
        gaps.append(float((d["prox_logp"] - d["logp"]).abs().max()))

    with monkeypatch.context() as patch:
        patch.setattr(rollout.DeviceRollouts, "set_proximal", recording)
        trainer.train(compose(["algo=ppo", f"out_dir={out}", *TINY, *overrides]))
    rows = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    latest = out / "checkpoints" / (out / "checkpoints" / "latest").read_text().strip()
    return gaps, rows, load_file(str(latest / "weights.safetensors"))


def test_synchronous_decoupled_update_is_plain_ppo(tmp_path, monkeypatch):
    """One synchronous update: the proximal log-probs are the behaviour ones (one policy, recomputed over the
    sequences instead of step by step), so the losses and the updated weights are plain PPO's up to rounding."""
    _, plain_rows, plain = run(monkeypatch, tmp_path / "plain", "train.total_steps=16")
    gaps, rows, weights = run(monkeypatch, tmp_path / "decoupled", "train.total_steps=16", "ppo.decoupled=true")
    assert len(gaps) == 1 and gaps[0] < 1e-4, gaps
    for key in ("value_loss", "action_loss", "entropy", "grad_norm"):
        assert rows[0][key] == pytest.approx(plain_rows[0][key], rel=1e-4, abs=1e-6), key
    assert plain.keys() == weights.keys()
    for name, value in plain.items():
        torch.testing.assert_close(weights[name], value, rtol=1e-4, atol=1e-6, msg=name)
    changed = [n for n, v in plain.items() if v.is_floating_point() and not torch.equal(v, weights[n])]
    assert len(changed) < len(plain)  # the float rounding of the recomputation, not another update


def test_overlapped_rollouts_are_acted_by_older_weights_than_the_proximal_policy(tmp_path, monkeypatch):
    """train.overlap: the first rollout is acted by the weights the first update starts from (proximal = behaviour),
    the second by those same weights while the first update runs, so the second update's proximal policy (its start:
    after the first update) differs from its behaviour policy; the first update is the plain overlapped run's."""
    gaps, rows, _ = run(monkeypatch, tmp_path / "decoupled", "train.total_steps=48", "train.overlap=true",
                              "ppo.decoupled=true")
    assert len(gaps) == 3 and len(rows) == 3
    assert gaps[0] < 1e-4, gaps
    assert gaps[1] > 1e-3 and gaps[2] > 1e-3, gaps
    assert all(torch.isfinite(torch.tensor(r["action_loss"])) for r in rows)
    _, plain_rows, _ = run(monkeypatch, tmp_path / "plain", "train.total_steps=16", "train.overlap=true")
    for key in ("value_loss", "action_loss", "entropy"):
        assert rows[0][key] == pytest.approx(plain_rows[0][key], rel=1e-4, abs=1e-6), key


def settle_normaliser(policy, rgb: torch.Tensor) -> None:
    """The input normaliser's statistics: those of ``rgb``, as if over many updates, so that a training-mode forward
    (which adds its batch to them) acts as the eval-mode one that computed the proximal log-probs."""
    from rvn_rl.model import RunningMeanAndVar

    x = rgb.flatten(0, 1).permute(0, 3, 1, 2).float() / 255.0
    for m in policy.modules():
        if isinstance(m, RunningMeanAndVar):
            m._mean.copy_(x.mean((0, 2, 3)).view(1, -1, 1, 1))
            m._var.copy_(x.var((0, 2, 3)).view(1, -1, 1, 1))
            m._count.fill_(1e9)


def _first_gradient(decoupled: bool, shift: float, proximal: torch.Tensor | None = None):
    """The actor head's gradient of one PPO step (one epoch, one mini-batch, action loss alone) on
    test_rl_recurrent's small rollout, its behaviour log-probs the policy's own (its proximal ones) minus ``shift``.
    Returns (gradient, proximal log-probs)."""
    from test_rl_recurrent import small_update_setup

    from rvn_rl.ppo import PPOConfig, ppo_update
    from rvn_rl.rollout import DeviceRollouts
    from rvn_rl.trainer import _Evaluate

    policy, _, rollouts = small_update_setup()
    settle_normaliser(policy, rollouts.obs["rgb"])
    learner = _Evaluate(policy)
    if proximal is None:
        proximal = DeviceRollouts(rollouts, "cpu").start_policy(learner, 2)[0].clone()
    rollouts.logp[:rollouts.step] = proximal - shift

    class Recorder:  # the optimiser: keeps the gradient, changes nothing
        def zero_grad(self):
            policy.zero_grad()

        def step(self):
            self.grad = policy.actor.weight.grad.clone()

    recorder = Recorder()
    cfg = PPOConfig(ppo_epoch=1, num_mini_batch=1, value_loss_coef=0.0, entropy_coef=0.0, max_grad_norm=1e9,
                    decoupled=decoupled)
    ppo_update(learner, recorder, DeviceRollouts(rollouts, "cpu"), cfg, torch.Generator().manual_seed(1))
    return recorder.grad, proximal


def test_decoupled_surrogate_clips_around_the_proximal_policy():
    """Behaviour log-probs one nat below the policy's own (a rollout acted by other weights): plain PPO's ratios start
    at e, outside its clip range, and the gradient changes; decoupled PPO's ratio to the proximal policy starts at 1
    and its importance weight is e, so its gradient is e times the on-policy one."""
    on_policy, proximal = _first_gradient(False, 0.0)
    decoupled, _ = _first_gradient(True, 1.0, proximal)
    plain, _ = _first_gradient(False, 1.0, proximal)
    assert on_policy.abs().max() > 0
    torch.testing.assert_close(decoupled, on_policy * torch.e, rtol=1e-4, atol=1e-7)
    assert not torch.allclose(plain, on_policy * torch.e, rtol=1e-2, atol=1e-6)

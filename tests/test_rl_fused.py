"""rvn-rl's Adam is fused on CUDA (one kernel a step for every parameter, as rvn-train's AdamW: the fourth GPU run's
PPO update was bound by the host's kernel launches, docs/results/2026-12-04_gpu4) and torch's default elsewhere, so a
CPU run is unchanged; a run resumed on another device takes that device's choice, not the one its checkpoint saved.
On a GPU a fused update is the for-each one within float rounding."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest
import torch

sys.path.append(str(Path(__file__).resolve().parents[1] / "benchmarks"))

POLICY = dict(obs_size=32, backbone="resnet18", base_planes=8, ngroups=4, hidden_size=64, rnn_layers=1)


def start(device: str, resume_from: Path | None = None):
    from rvn_rl.distrib import Dist
    from rvn_rl.settings import AlgoConfig, PPOConfig
    from rvn_rl.trainer import Run

    return Run.start(0, POLICY, PPOConfig(), AlgoConfig(), Dist(), torch.device(device), resume_from)


def test_a_resumed_run_takes_its_devices_choice_not_the_checkpoints(tmp_path):
    """A CPU run's Adam is torch's default (``fused`` None); a checkpoint whose optimiser groups say ``fused=True`` (a
    GPU run's) resumes on a CPU as a CPU run, with the saved moments and step counts."""
    from rvn_rl import checkpoint as ck

    run = start("cpu")
    assert run.optimizer.defaults["fused"] is None
    run.policy(  # one step, so that Adam has moments to save
        {"rgb": torch.zeros(2, 32, 32, 3, dtype=torch.uint8), "pointgoal": torch.ones(2, 2)},
        run.policy.initial_state(2), torch.zeros(2), torch.ones(2))[0].sum().backward()
    run.optimizer.step()
    state = run.resume_state()
    for group in state["optimizer"]["param_groups"]:
        group["fused"] = True
    ckpt = ck.save(tmp_path, 16, run.policy, state)
    resumed = start("cpu", ckpt)
    assert [g["fused"] for g in resumed.optimizer.param_groups] == [None]
    saved = run.optimizer.state_dict()["state"]
    again = resumed.optimizer.state_dict()["state"]
    assert saved.keys() == again.keys() and all(torch.equal(saved[k]["exp_avg"], again[k]["exp_avg"]) for k in saved)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a GPU: the fused Adam of CUDA runs")
def test_a_fused_update_on_cuda_is_the_for_each_update():
    """On CUDA rvn-rl's Adam is fused; one PPO update (2 epochs x 2 mini-batches) from the same weights and rollout
    gives the for-each Adam's losses and weights within float rounding."""
    from rl_learner import filled_rollouts
    from rvn_rl.ppo import PPOConfig, ppo_update
    from rvn_rl.rollout import DeviceRollouts
    from rvn_rl.trainer import _Evaluate

    run = start("cuda")
    assert run.optimizer.defaults["fused"] is True
    plain = start("cuda")
    plain.optimizer = torch.optim.Adam(plain.policy.parameters(), lr=2.5e-4, eps=1e-5)
    cfg = PPOConfig(ppo_epoch=2, num_mini_batch=2, num_steps=16)
    rollouts = filled_rollouts(4, 16, 32, tuple(run.policy.initial_state(4).shape), episode=6)
    out = []
    for r in (run, plain):
        losses = ppo_update(_Evaluate(r.policy), r.optimizer, DeviceRollouts(rollouts, torch.device("cuda")), cfg,
                            torch.Generator().manual_seed(0))
        out.append((losses, torch.cat([p.detach().flatten() for p in r.policy.parameters()])))
    (fused, w_fused), (each, w_each) = out
    for key in fused:
        assert fused[key] == pytest.approx(each[key], rel=1e-4, abs=1e-6), key
    assert torch.allclose(w_fused, w_each, rtol=1e-4, atol=1e-6)

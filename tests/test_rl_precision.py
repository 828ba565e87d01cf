"""rvn-rl's ``train.precision=bf16`` (issue 32): the visual encoder runs under torch.autocast(bfloat16) and a PPO
update from the same weights and rollout gives the float32 update's losses and direction within bf16's rounding,
with float32 weights and optimiser state; float32 stays the default. The CLI's side (config.yaml, a bad value) is
in test_rl.py."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest
import torch
from torch import nn

sys.path.append(str(Path(__file__).resolve().parents[1] / "benchmarks"))


def one_update(bf16: bool) -> dict:
    """One PPO update (2 epochs x 2 mini-batches) of a small ResNet-18 policy at 32² from seed 0's weights on a
    fixed random rollout with restarts: the losses, the weights' change, the conv outputs' dtypes, the dtypes after."""
    from rl_learner import filled_rollouts
    from rvn_rl.model import PointNavResNetPolicy
    from rvn_rl.ppo import PPOConfig, ppo_update
    from rvn_rl.rollout import DeviceRollouts
    from rvn_rl.trainer import _Evaluate

    torch.manual_seed(0)
    policy = PointNavResNetPolicy(obs_size=32, backbone="resnet18", base_planes=8, ngroups=4, hidden_size=64,
                                  rnn_layers=1).train()
    policy.autocast_bf16 = bf16
    seen = set()
    for m in policy.visual_encoder.modules():
        if isinstance(m, nn.Conv2d):
            m.register_forward_hook(lambda mod, inp, out: seen.add(out.dtype))
    before = torch.cat([p.detach().flatten().clone() for p in policy.parameters()])
    optimizer = torch.optim.Adam(policy.parameters(), lr=2.5e-4, eps=1e-5)
    rollouts = filled_rollouts(4, 16, 32, tuple(policy.initial_state(4).shape), episode=6)
    cfg = PPOConfig(ppo_epoch=2, num_mini_batch=2, num_steps=16)
    losses = ppo_update(_Evaluate(policy), optimizer, DeviceRollouts(rollouts, torch.device("cpu")), cfg,
                        torch.Generator().manual_seed(0))
    after = torch.cat([p.detach().flatten() for p in policy.parameters()])
    dtypes = {p.dtype for p in policy.parameters()} | {v.dtype for s in optimizer.state.values() for v in s.values()
                                                       if torch.is_tensor(v) and v.dim()}
    return dict(losses=losses, delta=after - before, conv_dtypes=seen, dtypes=dtypes)


@pytest.fixture(scope="module")
def updates():
    return one_update(False), one_update(True)


def test_bf16_runs_the_encoder_in_bfloat16_and_keeps_float32_weights(updates):
    fp32, bf16 = updates
    assert fp32["conv_dtypes"] == {torch.float32}  # the default: float32 throughout
    assert bf16["conv_dtypes"] == {torch.bfloat16}
    assert fp32["dtypes"] == bf16["dtypes"] == {torch.float32}  # weights and Adam's moments: checkpoints alike


def test_bf16_update_is_the_fp32_update_within_rounding(updates):
    fp32, bf16 = updates
    for key in ("value_loss", "action_loss", "entropy"):
        a, b = fp32["losses"][key], bf16["losses"][key]
        assert abs(a - b) <= 1e-2 * max(1.0, abs(a)), (key, a, b)
    a, b = fp32["losses"]["grad_norm"], bf16["losses"]["grad_norm"]
    assert abs(a - b) <= 0.05 * a, (a, b)
    d32, d16 = fp32["delta"], bf16["delta"]
    assert float(d32.abs().max()) > 0
    cosine = float(torch.dot(d32, d16) / (d32.norm() * d16.norm()))
    assert cosine > 0.9, cosine  # the same step up to bf16's rounding of the encoder's activations (0.97 here)


@pytest.mark.parametrize("native, precision, warned", [(False, "bf16", True), (True, "bf16", False),
                                                       (False, "fp32", False)])
def test_bf16_on_a_cpu_without_native_bfloat16_warns(monkeypatch, tmp_path, caplog, native, precision, warned):
    """oneDNN emulates bfloat16 on an x86 CPU without AVX512-BF16 or AMX (16x slower than float32 in the encoder):
    `train` says so, naming the setting, once its checks pass."""
    import logging

    from rvn_rl.cli import compose
    from rvn_rl.trainer import train

    monkeypatch.setattr("platform.machine", lambda: "x86_64")
    for probe in ("_is_avx512_bf16_supported", "_is_amx_tile_supported"):
        monkeypatch.setattr(torch.cpu, probe, lambda: native)

    class Checked(Exception):
        pass

    def stop():
        raise Checked

    cfg = compose(["device=cpu", f"train.precision={precision}", f"out_dir={tmp_path / 'run'}", "env.num_envs=2",
                   "ppo.num_mini_batch=2"])
    with caplog.at_level(logging.WARNING), pytest.raises(Checked):
        train(cfg, on_checked=stop)
    says = "train.precision=bf16 on a CPU without native bfloat16 (AVX512-BF16 or AMX)"
    assert (says in caplog.text) == warned, caplog.text

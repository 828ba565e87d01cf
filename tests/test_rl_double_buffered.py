"""train.double_buffered (`rvn_rl.collect`): the env workers in two halves, one stepping while the policy acts for the
other. `ProcessBatchEnv`'s halves stepped apart return what the batch stepped together does; rvn-rl with it collects
the plain run's transitions (on a CPU its actions to the byte: torch draws two halves' actions from one generator as
one draw for all), its log-probs and values to float rounding (a half's convolutions); a rollout that DD-PPO ends early
leaves no step under way."""
from __future__ import annotations

import json
import logging
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from rvn_rl.vec_procs import ProcessBatchEnv

from test_rl_overlap import TINY
from test_rl_vec_env import KW

pytestmark = pytest.mark.slow  # env worker processes, rvn-rl runs

THREE_IN_TWO = ["env.num_envs=3", "env.workers=2"]  # halves of 2 and 1 envs: two batch shapes


def test_halves_stepped_apart_give_what_the_batch_stepped_together_gives():
    together, apart = ProcessBatchEnv(KW, 3, workers=2, seed=7), ProcessBatchEnv(KW, 3, workers=2, seed=7)
    try:
        halves = apart.halves()
        assert halves == [slice(0, 2), slice(2, 3)]
        for want, got in zip(together.reset().values(), apart.reset().values()):
            np.testing.assert_array_equal(got, want)
        rng = np.random.default_rng(2)
        for _ in range(20):
            actions = rng.choice([0, 1, 1, 1, 2, 3], size=3)
            want = together.step(actions)
            for h in halves:
                apart.send_step(actions[h], h)
            second, first = apart.recv_step(halves[1]), apart.recv_step(halves[0])  # in either order
            for key in want[0]:
                np.testing.assert_array_equal(np.concatenate([first[0][key], second[0][key]]), want[0][key])
            for k in (1, 2, 3):
                np.testing.assert_array_equal(np.concatenate([first[k], second[k]]), want[k])
            assert first[4] + second[4] == want[4]
        with pytest.raises(RuntimeError, match="envs 0:2: no step under way"):
            apart.recv_step(halves[0])
        apart.send_step(np.zeros(2, int), halves[0])
        with pytest.raises(RuntimeError, match="envs 0:3: a step is already under way"):
            apart.step(np.zeros(3, int))  # the first half is still stepping
        with pytest.raises(ValueError, match=r"envs 0:1 are not whole workers \(their bounds: \[0, 2, 3\]\)"):
            apart.send_step(np.zeros(1, int), slice(0, 1))
        with pytest.raises(ValueError, match="1 actions for 2 envs"):
            apart.send_step(np.zeros(1, int), slice(0, 2))
    finally:
        together.close()
        apart.close()


def run(monkeypatch, out, *overrides: str) -> tuple[list[dict], list[dict]]:
    """rvn-rl (on a CPU unless ``overrides`` name a device); returns each rollout's transitions (read from the storage after its collection) and the log
    rows."""
    from rvn_rl import trainer
    from rvn_rl.cli import compose

    rollouts, collect = [], trainer.collect

    def recording_collect(actor, envs, storage, *args, **kwargs):
        result = collect(actor, envs, storage, *args, **kwargs)
        n = storage.step
        rollouts.append({"actions": storage.actions[:n].clone(), "rewards": storage.rewards[:n].clone(),
                         "masks": storage.masks[:n + 1].clone(), "rgb": storage.obs["rgb"][:n + 1].clone(),
                         "logp": storage.logp[:n].clone(), "values": storage.values[:n].clone()})
        return result

    with monkeypatch.context() as patch:
        patch.setattr(trainer, "collect", recording_collect)
        device = [] if any(o.startswith("device=") for o in overrides) else ["device=cpu"]
        trainer.train(compose(["algo=ppo", f"out_dir={out}", *device, *TINY, *THREE_IN_TWO, *overrides]))
    return rollouts, [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]


def test_rvn_rl_double_buffered_collects_the_plain_runs_transitions(monkeypatch, tmp_path, caplog):
    """On a CPU, with a warning that it is meant for a GPU."""
    plain, plain_rows = run(monkeypatch, tmp_path / "plain")
    assert not any("train.double_buffered" in r.message for r in caplog.records)
    with caplog.at_level(logging.WARNING, logger="rvn_rl.trainer"):
        double, rows = run(monkeypatch, tmp_path / "double", "train.double_buffered=true")
    assert any("train.double_buffered=true on a CPU" in r.message for r in caplog.records)
    assert len(plain) == len(double) == 2  # train.total_steps=48 in rollouts of 8 steps of 3 envs
    for want, got in zip(plain, double, strict=True):
        for key in ("actions", "rewards", "masks", "rgb"):
            assert torch.equal(got[key], want[key]), key
        for key in ("logp", "values"):
            torch.testing.assert_close(got[key], want[key], rtol=1e-4, atol=1e-5)
    assert len({tuple(r["actions"].flatten().tolist()) for r in plain}) > 1
    assert [(r["env_steps"], r["episodes"], r["reward"]) for r in rows] == \
        [(r["env_steps"], r["episodes"], r["reward"]) for r in plain_rows]
    for a, b in zip(plain_rows, rows):
        for key in ("value_loss", "action_loss", "entropy"):
            assert b[key] == pytest.approx(a[key], rel=1e-3, abs=1e-6), key


def test_env_workers_log_each_envs_first_renderer_in_the_run(monkeypatch, tmp_path, caplog):
    """Each env's first renderer line (which backend, and why renderer=auto picked it) reaches the run's log from
    the env worker processes, where nothing of theirs did before (spawned, they had no logging set up); the scene
    switches after the first reset are quiet there as in the trainer's process (a switch at every reset here)."""
    logging.getLogger("rvn").setLevel(logging.NOTSET)  # an earlier run in this process quieted it
    with caplog.at_level(logging.INFO):
        _, rows = run(monkeypatch, tmp_path / "run", "env.scene_switch_every=1")
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("renderer for procedural:train/")]
    assert len(lines) == 3 and all("raycast" in line for line in lines), lines
    assert rows[-1]["episodes"] > 0  # episodes ended, each drawing another scene: no line for those


class Preempting:
    """DD-PPO's pre-emption as `Dist` answers it once the other ranks are done: from step ``at`` of the rollout."""

    enabled, world_size = False, 1

    def __init__(self, at: int):
        self.at, self.asked = at, []

    def should_end_early(self, step: int, num_steps: int, update: int, sync_frac: float) -> bool:
        self.asked.append(step)
        return step >= self.at

    def rollout_done(self, update: int) -> None:
        pass


def preempted(double: bool) -> list[torch.Tensor]:
    """Two rollouts of 8 steps that DD-PPO ends after 3, collected by `collect` from fixed weights and seeds; each
    rollout's actions."""
    from rvn_rl.cli import compose
    from rvn_rl.collect import collect
    from rvn_rl.model import PointNavResNetPolicy
    from rvn_rl.rollout import RolloutStorage

    cfg = compose([*TINY, *THREE_IN_TWO, f"train.double_buffered={str(double).lower()}"])
    torch.manual_seed(0)
    policy = PointNavResNetPolicy(32, "resnet18", base_planes=16, ngroups=8, input_size=64, hidden_size=32)
    envs = ProcessBatchEnv(cfg.env_kwargs(), 3, workers=2, seed=3)
    try:
        obs = envs.reset()
        space = {k: (v.shape[1:], torch.uint8 if v.dtype == np.uint8 else torch.float32) for k, v in obs.items()}
        state = policy.initial_state(3, "cpu")
        storage = RolloutStorage(8, 3, space, tuple(state.shape), 1)
        storage.set_first(obs, state, torch.zeros(3, dtype=torch.long), torch.zeros(3))
        d, draw, steps = Preempting(at=3), torch.Generator().manual_seed(1), []
        for _ in range(2):
            state, _, _, delta = collect(policy, envs, storage, state, SimpleNamespace(updates=0), cfg, d, "cpu", 1,
                                         draw)
            assert storage.step == 3 and delta == 9 and not envs._stepping
            steps.append(storage.actions[:3].clone())
            storage.after_update(state)
        assert d.asked == [1, 2, 3, 1, 2, 3]
    finally:
        envs.close()
    return steps


def test_a_preempted_rollout_ends_with_no_step_under_way():
    """A rollout ended early keeps the steps before its end, whose actions are the plain loop's; the envs are left
    with no step under way, so the next rollout steps on."""
    plain, double = preempted(False), preempted(True)
    assert all(torch.equal(a, b) for a, b in zip(plain, double, strict=True))
    assert not torch.equal(plain[0], plain[1])


def test_benchmark_prints_both_settings_and_their_ratio():
    """benchmarks/rl_double_buffered.py (issue 32's figure for train.double_buffered) at a tiny size on a CPU."""
    import re
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "benchmarks" / "rl_double_buffered.py"
    tiny = ["--size", "32", "--envs", "2", "--workers", "2", "--scenes", "2", "--updates", "2", "--num-steps", "8",
            "--ppo-epoch", "1", "--mini-batches", "1", "--rounds", "1", "--renderer", "raycast", "--goal-pool", "4"]
    proc = subprocess.run([sys.executable, str(script), *tiny], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "2 envs in 2 worker processes, rollouts of 8" in proc.stdout, proc.stdout
    for on in ("false", "true"):
        assert re.search(rf"train.double_buffered={on} +collection +[\d.]+ env steps/s \(runs: [\d.]+\), waiting for "
                         r"the envs \d+% of it; collection \+ learning +[\d.]+", proc.stdout), proc.stdout
    assert re.search(r"train.double_buffered=true: collection x[\d.]+, collection \+ learning x[\d.]+", proc.stdout)
    bad = subprocess.run([sys.executable, str(script), "--workers", "1"], capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "--workers between 2 and --envs" in bad.stderr


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a GPU: CUDA graphs")
@pytest.mark.filterwarnings("error:RNN module weights are not part of single contiguous chunk")
def test_rvn_rl_double_buffered_with_graph_act_and_overlap_on_cuda(monkeypatch, tmp_path):
    """On a GPU with train.graph_act (a CUDA graph for each half's batch shape) and train.overlap (the actor's copy
    acting while the learner thread updates): every update runs, with finite losses, and each half's acts replay their
    own graph. The actions are other draws than the plain run's there (a GPU generator draws per call)."""
    from rvn_rl import trainer

    made = []

    class Recorded(trainer.GraphedAct):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(trainer, "GraphedAct", Recorded)
    _, rows = run(monkeypatch, tmp_path / "cuda", "device=cuda", "train.graph_act=true", "train.overlap=true",
                  "ppo.recompute_advantages=true", "train.double_buffered=true")
    assert [r["env_steps"] for r in rows] == [24, 48]
    assert all(np.isfinite(r[k]) for r in rows for k in ("value_loss", "action_loss", "entropy"))
    assert len(made) == 1 and made[0].recorded == 2 and len(made[0].graphs) == 2

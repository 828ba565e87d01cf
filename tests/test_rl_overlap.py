"""train.overlap through rvn-rl's public API (`rvn_rl.cli.compose`, `rvn_rl.trainer.train`) at tiny sizes: each PPO
update runs in the learner thread while the envs collect the next rollout with the weights from before it (one update
of policy lag), and the run is the same, to the byte, as the same schedule run one step after the other in one
thread: nothing the learner writes reaches the rollout being collected beside it."""
from __future__ import annotations

import hashlib
import json
import threading

import pytest
import torch

pytestmark = pytest.mark.slow  # rvn-rl runs

TINY = ["env.size=32", "env.num_envs=2", "env.num_scenes=2", "ppo.num_steps=8", "ppo.num_mini_batch=2",
        "model.backbone=resnet18", "train.threads=1", "progress=false", "renderer=raycast", "train.total_steps=48"]


def digest(module: torch.nn.Module) -> str:
    h = hashlib.sha256()
    for t in module.state_dict().values():
        h.update(t.detach().cpu().contiguous().numpy().tobytes())
    return h.hexdigest()[:16]


def run(monkeypatch, out, threaded: bool, device: str) -> tuple[list, list, list[dict], bytes]:
    """rvn-rl with train.overlap=true, its learner thread in a thread of its own or (``threaded=False``) each update
    run at once in the caller's thread, before the rollout that would collect beside it. Returns the weights' digest
    of each rollout's actor, each update's (thread, weights' digest at its start), the log rows and the last
    checkpoint's weights."""
    from rvn_rl import trainer
    from rvn_rl.cli import compose

    collected, updates = [], []
    collect, update = trainer.collect, trainer.ppo_update

    def recording_collect(actor, *args, **kwargs):
        collected.append(digest(actor))
        return collect(actor, *args, **kwargs)

    def recording_update(model, *args, **kwargs):
        updates.append((threading.current_thread() is threading.main_thread(), digest(model.policy)))
        return update(model, *args, **kwargs)

    class Learner(trainer.LearnerThread):
        def __init__(self, overlap: bool, device=None):
            super().__init__(overlap and threaded, device)

    with monkeypatch.context() as patch:
        patch.setattr(trainer, "collect", recording_collect)
        patch.setattr(trainer, "ppo_update", recording_update)
        patch.setattr(trainer, "LearnerThread", Learner)
        trainer.train(compose(["algo=ppo", f"out_dir={out}", "train.overlap=true", f"device={device}", *TINY]))
    rows = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    latest = out / "checkpoints" / (out / "checkpoints" / "latest").read_text().strip()
    return collected, updates, rows, (latest / "weights.safetensors").read_bytes()


@pytest.mark.parametrize("device", ["cpu", pytest.param("cuda", marks=pytest.mark.skipif(
    not torch.cuda.is_available(), reason="needs a GPU: the learner's CUDA stream"))])
@pytest.mark.filterwarnings("error:RNN module weights are not part of single contiguous chunk")  # the actor's copy
def test_overlap_learns_beside_the_collection_as_the_same_schedule_in_one_thread(monkeypatch, tmp_path, device):
    """On a GPU the update runs on the learner thread's CUDA stream; cuDNN's kernels may differ in the last bits from
    run to run there, so the one-thread run's losses are compared to float rounding (as tests/test_rl.py's compiled
    trunk, whose docstring has the measured spread), and its weights not at all."""
    collected, updates, rows, weights = run(monkeypatch, tmp_path / "threaded", True, device)
    # three rollouts and three updates, each update in the learner thread
    assert [r["env_steps"] for r in rows] == [16, 32, 48] and len(collected) == len(updates) == 3
    assert not any(main for main, _ in updates)
    # rollout k+1 is acted by the weights update k started from: theta_0, theta_0, theta_1
    theta = [w for _, w in updates]
    assert collected == [theta[0], theta[0], theta[1]] and len(set(theta)) == 3
    assert all(r["time_learn"] >= 0 and r["fps"] > 0 for r in rows)
    assert [r["overlapped"] for r in rows] == [1, 1, 0]  # the last update: nothing left to collect beside it

    one = run(monkeypatch, tmp_path / "inline", False, device)
    assert all(main for main, _ in one[1])
    keys = ("env_steps", "episodes", "value_loss", "action_loss", "entropy", "grad_norm", "reward")
    if device == "cpu":  # the same bytes
        assert one[0] == collected and [w for _, w in one[1]] == theta
        assert [[r.get(k) for k in keys] for r in one[2]] == [[r.get(k) for k in keys] for r in rows]
        assert one[3] == weights
    else:
        for a, b in zip(one[2], rows, strict=True):
            assert [a.get(k) for k in keys[:2]] == [b.get(k) for k in keys[:2]]
            for k in keys[2:]:  # action_loss, a mean of advantage-weighted ratios near 0: its rounding is absolute
                if b.get(k) is None:  # reward: none before the first episode has ended
                    assert a.get(k) is None, k
                else:
                    assert a.get(k) == pytest.approx(b[k], rel=1e-2, abs=1e-4 if k == "action_loss" else 1e-6), k

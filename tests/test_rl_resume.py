"""Continuing an rvn-rl run through its public API (`rvn_rl.cli.compose`, `rvn_rl.trainer.train`, `Run.start`) at
tiny sizes: a run that would start over another run's checkpoints is refused before anything is written, a finished
run trains and writes nothing, a resumed run logs each step once and steps by its own learning rates."""
from __future__ import annotations

import shutil

import pytest

from test_rl_overlap import TINY


def train(out, *overrides: str, cache=None) -> dict:
    """A tiny run into ``out``, its cache root ``cache`` (the fixture's: the scenes' navmeshes and goal pools built
    once for the tests' runs)."""
    from rvn_rl.cli import compose
    from rvn_rl.trainer import train

    cache = cache or out.parent / "cache"
    return train(compose(["algo=ppo", f"out_dir={out}", f"cache_dir={cache}", *TINY, "train.checkpoint_every=1",
                          "train.keep_checkpoints=3", *overrides]))


def snapshot(out) -> dict:
    """Every file of ``out`` (the cache root aside): its size and modification time."""
    return {p.relative_to(out): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(out.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A run of two updates (16 and 32 env steps), a checkpoint after each."""
    out = tmp_path_factory.mktemp("rl") / "ppo"
    train(out, "train.total_steps=32")
    return out


def copy(finished, tmp_path):
    out = tmp_path / "ppo"
    shutil.copytree(finished, out)
    return out


@pytest.mark.slow  # rvn-rl runs, as the two tests below
def test_a_run_not_resuming_is_refused_where_checkpoints_are(finished, tmp_path):
    """train.resume=false on an out_dir that holds checkpoints: its own would sort before them and be pruned at once,
    its rows appended to theirs; a one-line ConfigError (rvn-rl: status 2) names out_dir, and nothing is written."""
    from rvn_data.cli.common import ConfigError

    out = copy(finished, tmp_path)
    before = snapshot(out)
    with pytest.raises(ConfigError) as err:
        train(out, "train.total_steps=32", "train.resume=false", cache=finished.parent / "cache")
    assert str(err.value) == (f"out_dir={out} holds the checkpoints of a run, which train.resume=false would start "
                              "over; choose a new out_dir, or train.resume=true to continue that run")
    assert snapshot(out) == before


@pytest.mark.slow
@pytest.mark.parametrize("total", [32, 16])
def test_a_finished_run_run_again_trains_nothing_and_writes_nothing(finished, tmp_path, total):
    """Its latest checkpoint has train.total_steps (or more): no rollout, no update, no checkpoint past the end; the
    result says it is finished (rvn-rl prints that line)."""
    out = copy(finished, tmp_path)
    before = snapshot(out)
    result = train(out, f"train.total_steps={total}", cache=finished.parent / "cache")
    assert result == {"env_steps": 32, "finished": f"rvn-rl ppo: out_dir={out} holds a finished run (32 env steps, "
                      f"train.total_steps={total}); nothing to train: raise train.total_steps to go on"}
    assert snapshot(out) == before


@pytest.mark.slow
def test_a_resumed_run_logs_each_step_once(finished, tmp_path):
    """A run stopped after logging its update at 32 env steps but before that update's checkpoint resumes from the
    one at 16: metrics.jsonl and TensorBoard hold each step once, in order (the earlier run's row at 32 dropped)."""
    import json

    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    out = copy(finished, tmp_path)
    shutil.rmtree(out / "checkpoints" / "ckpt_000000000032")  # as if it stopped before this checkpoint was written
    (out / "checkpoints" / "latest").write_text("ckpt_000000000016\n")
    train(out, "train.total_steps=48", cache=finished.parent / "cache")
    rows = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    assert [r["env_steps"] for r in rows] == [16, 32, 48] and rows[1]["updates"] == 2
    events = EventAccumulator(str(out / "tb"))
    events.Reload()
    assert [e.step for e in events.Scalars("train/fps")] == [16, 32, 48]


def test_a_resumed_run_steps_by_its_own_learning_rates(tmp_path):
    """ppo.lr, ppo.eps and algo.lambda_lr changed on resuming act (config.yaml records them): the optimisers take
    the checkpoint's moments and step counts, not its learning rates."""
    import torch

    from rvn_rl import checkpoint as ck
    from rvn_rl.distrib import Dist
    from rvn_rl.settings import AlgoConfig, PPOConfig
    from rvn_rl.trainer import Run

    policy = dict(obs_size=32, backbone="resnet18", base_planes=8, ngroups=4, hidden_size=16, rnn_layers=1,
                  cost_critic=True)
    run = Run.start(0, policy, PPOConfig(), AlgoConfig(name="ppo_lag", lagrangian=True), Dist(), torch.device("cpu"),
                    None)
    run.policy({"rgb": torch.zeros(2, 32, 32, 3, dtype=torch.uint8), "pointgoal": torch.ones(2, 2)},
               run.policy.initial_state(2), torch.zeros(2), torch.ones(2))[0].sum().backward()
    run.optimizer.step()
    run.lagrange.update(0.5)
    ckpt = ck.save(tmp_path, 16, run.policy, run.resume_state())
    resumed = Run.start(0, policy, PPOConfig(lr=1e-3, eps=1e-6),
                        AlgoConfig(name="ppo_lag", lagrangian=True, lambda_lr=0.2), Dist(), torch.device("cpu"), ckpt)
    assert [(g["lr"], g["eps"]) for g in resumed.optimizer.param_groups] == [(1e-3, 1e-6)]
    assert [g["lr"] for g in resumed.lagrange.optimizer.param_groups] == [0.2]
    assert resumed.lagrange.value == run.lagrange.value
    saved, again = run.optimizer.state_dict()["state"], resumed.optimizer.state_dict()["state"]
    assert saved.keys() == again.keys() and all(torch.equal(saved[k]["exp_avg"], again[k]["exp_avg"]) for k in saved)
    assert resumed.lagrange.optimizer.state_dict()["state"][0]["step"] == 1


@pytest.mark.slow
def test_a_run_continued_from_another_trains_on_in_its_own_out_dir(finished, tmp_path):
    """train.continue_from: a new out_dir starts from another run's latest checkpoint and trains on as that run would
    have in place (the same weights, to the bit), its log holding the source's rows first; the source is left as it
    was. A rerun resumes the new out_dir's own checkpoints, with or without the setting; config.yaml records where it
    started. Bad sources and budgets are refused before anything is written."""
    import json

    import yaml
    from safetensors.torch import load_file

    from rvn_data.cli.common import ConfigError

    cache = finished.parent / "cache"
    source = snapshot(finished)
    in_place = copy(finished, tmp_path / "a")
    train(in_place, "train.total_steps=48", cache=cache)
    out = tmp_path / "b" / "ppo_48"
    train(out, "train.total_steps=48", f"train.continue_from={finished}", cache=cache)
    assert snapshot(finished) == source
    ckpt = "checkpoints/ckpt_000000000048/weights.safetensors"
    a, b = load_file(str(in_place / ckpt)), load_file(str(out / ckpt))
    assert a.keys() == b.keys() and all(a[k].equal(b[k]) for k in a)
    assert [json.loads(line)["env_steps"] for line in (out / "metrics.jsonl").read_text().splitlines()] == [16, 32, 48]
    record = yaml.safe_load((out / "config.yaml").read_text())["continued_from"]
    assert record["out_dir"] == str(finished) and record["env_steps"] == 32 and "commit" in str(record["provenance"])
    train(out, "train.total_steps=64", cache=cache)  # resumed without the setting: the record stays
    train(out, "train.total_steps=80", f"train.continue_from={finished}", cache=cache)
    assert [json.loads(line)["env_steps"] for line in (out / "metrics.jsonl").read_text().splitlines()] == \
        [16, 32, 48, 64, 80]
    assert yaml.safe_load((out / "config.yaml").read_text())["continued_from"] == record
    fresh = tmp_path / "c"
    for source_dir, total, said in [(out, 96, f"train.continue_from={out} is out_dir itself"),
                                    (finished, 32, f"train.continue_from={finished} stopped at 32 env steps, "
                                                   "train.total_steps=32: nothing to train; raise train.total_steps "
                                                   "above 32"),
                                    (tmp_path / "none", 96, f"train.continue_from={tmp_path / 'none'} is not a "
                                                            "directory"),
                                    (cache, 96, f"train.continue_from: {cache} is not an rvn-rl checkpoint directory")]:
        target = out if source_dir == out else fresh
        before = snapshot(out)
        with pytest.raises(ConfigError) as err:
            train(target, f"train.total_steps={total}", f"train.continue_from={source_dir}", cache=cache)
        assert said in str(err.value)
        assert not fresh.exists() and snapshot(out) == before
    with pytest.raises(ConfigError) as err:  # a run of its own in out_dir, not started from the source
        train(in_place, "train.total_steps=96", f"train.continue_from={finished}", cache=cache)
    assert str(err.value).startswith(f"out_dir={in_place} holds a run that started afresh, not from "
                                     f"train.continue_from={finished}")


@pytest.mark.slow
def test_a_kept_checkpoint_other_than_the_latest_is_evaluated(finished, tmp_path):
    """policy.env_steps: rvn-eval runs a kept checkpoint other than the run's latest (its weights, and its env steps in
    the run's identity); one the run does not keep is refused in one line naming those it keeps, nothing written."""
    import json
    import os
    import subprocess

    import torch
    from safetensors.torch import load_file

    from rvn_rl.policy import load_rl_policy

    for steps, name in [(16, "ckpt_000000000016"), (None, "ckpt_000000000032")]:
        net = load_rl_policy(finished, **({"env_steps": steps} if steps else {})).net
        saved = load_file(str(finished / "checkpoints" / name / "weights.safetensors"))
        assert all(torch.equal(v, saved[k]) for k, v in net.state_dict().items())
    args = ["rvn-eval", "policy=checkpoint", f"policy.checkpoint_path={finished}", "split=val", "episodes.num_scenes=1",
            "episodes.per_scene=1", "episodes.n_goals=1", "env.t_max=10", "camera.width=32", "camera.height=32",
            "progress=false", "renderer=raycast", f"episodes.dir={tmp_path / 'episodes'}"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([*args, "+policy.env_steps=16", f"out_dir={tmp_path / 'ev'}"], capture_output=True, text=True,
                          env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads((tmp_path / "ev" / "run.json").read_text())["policy"]["env_steps"] == 16
    proc = subprocess.run([*args, "+policy.env_steps=8", f"out_dir={tmp_path / 'bad'}"], capture_output=True,
                          text=True, env=env, timeout=600)
    assert proc.returncode != 0 and f"{finished} keeps no checkpoint of 8 env steps (policy.env_steps); it keeps " \
        "16, 32" in proc.stderr, proc.stderr[-2000:]
    assert not (tmp_path / "bad").exists()

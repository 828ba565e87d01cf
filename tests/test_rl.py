"""rvn-rl through its CLI at tiny sizes (32x32 RGB, ResNet-18, 2 envs, 2 train scenes):
PPO trains and writes a checkpoint that rvn-eval loads; a second run resumes it; PPO-Lag
logs lambda and J_c; bad input gets a one-line error."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import pytest
import yaml
from conftest import QUICK_COMPILE_ENV, without_shared_cache

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

TINY = ["env.size=32", "env.num_envs=2", "env.num_scenes=2", "ppo.num_steps=8", "ppo.num_mini_batch=2", "model.backbone=resnet18",
        "train.threads=1", "progress=false", "renderer=raycast"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def rvn_rl(*args, check=True, env=None, shared_cache=True):
    """rvn-rl ARGS; with ``shared_cache=False`` its caches under ``<out_dir>/cache`` (the default), not the suite's
    shared cache root (tests/conftest.py `share_cache_root`)."""
    full = {**ENV, **(env or {})}
    proc = subprocess.run([sys.executable, "-m", "rvn_rl.cli", *args], capture_output=True, text=True,
                          env=full if shared_cache else without_shared_cache(full), timeout=600)
    if check:
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc


def rows(out_dir):
    return [json.loads(line) for line in (out_dir / "metrics.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("rl") / "ppo"
    proc = rvn_rl("algo=ppo", f"out_dir={out}", "train.total_steps=32", *TINY, shared_cache=False)
    return out, proc


def test_ppo_trains_writes_a_checkpoint_and_a_curve(ppo_run):
    out, proc = ppo_run
    cfg = yaml.safe_load((out / "config.yaml").read_text())
    assert cfg["kind"] == "rl" and cfg["algo"]["name"] == "ppo" and cfg["policy"]["obs_size"] == 32
    latest = out / "checkpoints" / (out / "checkpoints" / "latest").read_text().strip()
    assert (latest / "weights.safetensors").is_file() and (latest / "state.pt").is_file()
    r = rows(out)
    assert [x["env_steps"] for x in r] == [16, 32]
    assert all(x["fps"] > 0 and x["overlapped"] == 0 for x in r) and "value_loss" in r[-1]
    assert (out / "learning_curve.png").stat().st_size > 1000
    assert list((out / "tb").glob("events.out.tfevents.*"))
    assert "rvn-rl ppo: 32 env steps" in proc.stdout
    assert re.search(r"rvn-rl ppo: 32 env steps in [\d.]+ min \([\d.]+ steps/s\)", proc.stdout)
    from rvn_rl.cli import compose
    from rvn_rl.runlog import summary

    cfg = compose(["algo=ppo"])  # a slow run's rate is not printed as 0, a fast one's without decimals
    assert "(0.38 steps/s)" in summary(out, cfg, 48, 126.0, 10**6)
    assert "(1234 steps/s)" in summary(out, cfg, 12340, 10.0, 10**6)
    assert list((out / "cache" / "navmesh").glob("*.npz")) and "no cache folder given" not in proc.stderr
    assert list((out / "cache" / "goal_pools").glob("*.npz"))  # env.goal_pool: each scene's pool kept


def rvn_eval_rl(out, tmp_path, split: str, per_scene: int, t_max: int) -> subprocess.CompletedProcess:
    """rvn-eval of the rvn-rl checkpoint ``out`` on one scene of ``split`` into ``tmp_path/eval``, as method PPO."""
    proc = subprocess.run(["rvn-eval", "policy=checkpoint", f"policy.checkpoint_path={out}", f"split={split}",
                           "episodes.num_scenes=1", f"episodes.per_scene={per_scene}", f"episodes.n_goals={per_scene}",
                           f"env.t_max={t_max}", "camera.width=32", "camera.height=32", f"out_dir={tmp_path / 'eval'}",
                           "progress=false", "method=PPO", "renderer=raycast", f"episodes.dir={tmp_path / 'episodes'}"],
                          capture_output=True, text=True, env=ENV, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


def test_rvn_eval_loads_the_rl_checkpoint(ppo_run, tmp_path):
    out, _ = ppo_run
    ev = tmp_path / "eval"
    proc = rvn_eval_rl(out, tmp_path, "val", 2, 20)
    metrics = json.loads((ev / "metrics.json").read_text())
    assert metrics["episodes"] == 2 and metrics["method"] == "PPO"
    assert "trained_scenes" not in metrics and "trained on" not in proc.stderr  # val: not the run's train scenes


def test_rvn_eval_names_the_rl_runs_train_scenes_it_evaluates(ppo_run, tmp_path):
    """An rvn-rl checkpoint names the train scenes of its config.yaml (rvn_rl.policy.training_scenes): rvn-eval on
    one of them says so and records it (rvn_data.benchmark.trained_scenes); scenes that cannot be listed here (a
    folder on another machine) are named unchecked."""
    from rvn_data.benchmark.trained_scenes import trained_scenes_evaluated
    from rvn_rl.policy import training_scenes

    out, _ = ppo_run
    ev = tmp_path / "eval"
    proc = rvn_eval_rl(out, tmp_path, "train", 1, 10)
    source = str(out / "config.yaml")
    assert f"policy 'PPO' trained on 1 of the 1 evaluated scenes (proc_train_0000; matched by name in what it " \
           f"trained on: {source})" in proc.stderr, proc.stderr
    record = json.loads((ev / "metrics.json").read_text())["trained_scenes"]
    assert record == {"sources": [source], "scenes": ["proc_train_0000"], "evaluated": 1}
    assert training_scenes(out, yaml.safe_load((out / "config.yaml").read_text()))["scenes"] == [
        "procedural:train/0", "procedural:train/1"]  # env.num_scenes=2
    gone = training_scenes(out, {"scenes": {"source": "mesh_dir", "root": str(tmp_path / "elsewhere")}})
    assert gone == {"source": source, "scenes": None}
    assert trained_scenes_evaluated(None, ["procedural:train/0"], gone) is None


def test_rl_policy_resets_its_recurrent_state(ppo_run):
    import numpy as np
    from rvn_il.policies import load_policy

    out, _ = ppo_run
    policy = load_policy(out)  # rvn_il's loader finds rvn-rl's loader by config.yaml's kind (entry point rvn.checkpoint_loaders)
    obs = {"rgb": np.full((64, 64, 3), 90, np.uint8), "pointgoal": np.array([3.0, 1.0], np.float32)}
    policy.reset()
    assert policy.act(obs) in range(4)
    assert float(policy.state.abs().sum()) > 0 and float(policy.mask[0]) == 1.0
    policy.reset()
    assert float(policy.state.abs().sum()) == 0 and float(policy.mask[0]) == 0.0


def test_resume_continues_from_the_latest_checkpoint(ppo_run, tmp_path):
    import shutil

    src, _ = ppo_run
    out = tmp_path / "ppo"
    shutil.copytree(src, out)
    # a float32 run continued with its visual encoder in bfloat16 (test_rl_precision: the update itself)
    rvn_rl("algo=ppo", f"out_dir={out}", "train.total_steps=48", "train.precision=bf16", *TINY)
    assert [x["env_steps"] for x in rows(out)] == [16, 32, 48]
    assert yaml.safe_load((out / "config.yaml").read_text())["train"]["precision"] == "bf16"
    assert (out / "checkpoints" / "latest").read_text().strip() == "ckpt_000000000048"
    import torch
    state = torch.load(out / "checkpoints" / "ckpt_000000000048" / "state.pt", weights_only=False)
    assert state["updates"] == 3 and state["env_steps"] == 48


def test_compiled_trunk_trains_as_the_plain_run(ppo_run, tmp_path):
    """train.compile=true (the visual trunk under torch.compile, in rollouts and updates): the plain run's episodes
    and losses to float rounding, its kernels under the cache root. Scalar C++ kernels in one translation unit per
    graph, compiled unoptimised, as tests/test_compiled.py's training step: what is checked is the wiring.

    How far rounding carries depends on the frames, so the tolerance is sized on several episode streams, not on
    this one alone (2026-12-03, largest relative gap of the four losses over both updates): seeds 1-4 of these tiny
    runs 1e-7 to 7e-7 (action_loss, a mean of advantage-weighted ratios near 0: at most 1.9e-7 apart, so it is
    compared to an absolute 1e-4), this run 5.5e-4, and with env.goal_pool=8 2.2e-4 in the first update and 2.7e-3
    (value_loss 1.9e-3, action_loss 2.9e-5 apart) in the second: the compiled trunk's rounding (fused GroupNorm
    reductions) carried through 8 optimizer steps. A wiring fault is not rounding: compiling a copy of the trunk
    (its gradients never reach the optimizer, the updates never reach it) put value_loss 31 % off (0.0114 against
    0.0167)."""
    plain, _ = ppo_run
    out = tmp_path / "compiled"
    rvn_rl("algo=ppo", f"out_dir={out}", "train.total_steps=32", "train.compile=true", *TINY,
           env=QUICK_COMPILE_ENV, shared_cache=False)
    a, b = rows(plain), rows(out)
    assert [(x["env_steps"], x.get("episodes")) for x in a] == [(x["env_steps"], x.get("episodes")) for x in b]
    for x, y in zip(a, b):
        for key in ("value_loss", "action_loss", "entropy", "grad_norm"):
            assert y[key] == pytest.approx(x[key], rel=1e-2, abs=1e-4 if key == "action_loss" else 1e-6), key
    assert list((out / "cache" / "compiled").iterdir())
    assert yaml.safe_load((out / "config.yaml").read_text())["train"]["compile"] is True


def test_ppo_lag_logs_lambda_and_episode_cost(tmp_path):
    out = tmp_path / "lag"
    proc = rvn_rl("algo=ppo_lag", f"out_dir={out}", "train.total_steps=32", "algo.lambda_lr=0.5", *TINY)
    r = rows(out)
    assert all("lambda" in x and "J_c" in x for x in r)
    assert all(x["lambda"] >= 0 for x in r)
    # episodes end at the first collision, so J_c > cost limit until the policy stops colliding: lambda grows
    if r[0]["J_c"] > 0:
        assert r[-1]["lambda"] > 0.001
    # the second rollout ended no episode (the log's window of episodes did not grow): no J_c measured, no step of
    # lambda (Adam stepped it by ~lambda_lr on the first rollout's J_c again: 0.501 -> 1.0)
    assert r[1]["episodes"] == r[0]["episodes"] and r[1]["lambda"] == r[0]["lambda"]
    assert "lambda" in proc.stdout
    cfg = yaml.safe_load((out / "config.yaml").read_text())
    assert cfg["policy"]["cost_critic"] is True and cfg["algo"]["cost_limit"] == 1e-4


@pytest.mark.parametrize("args, words", [
    (["algo=sac"], "algo='sac' is unknown"),
    (["env.num_envs=0"], "env.num_envs=0 must be a positive integer"),
    (["env.goal_pool=-1"], "env.goal_pool=-1 must be an integer >= 0"),
    (["env.num_scenes=0"], "env.num_scenes=0 must be a positive integer"),
    (["ppo.lr=-1"], "ppo.lr=-1.0 must be > 0"),
    (["ppo.gamma=1.5"], "ppo.gamma=1.5 must be in [0, 1]"),
    (["seed=-1"], "seed=-1 must be an integer >= 0"),
    (["train.threads=0"], "train.threads=0 must be a positive integer"),
    (["train.precision=fp16"], "train.precision='fp16'; choose one of fp32, bf16"),
    (["train.compile_mode=max-autotune"], "train.compile_mode='max-autotune'; choose one of default, reduce-overhead"),
    (["model.backbone=vgg"], "model.backbone='vgg'"),
    (["algo=ddppo_depth"], "depth.model_path"),
    (["env.num_envs=1"], "ppo.num_mini_batch"),
    (["train.total_steps=abc"], "train.total_steps=abc: Value 'abc' of type 'str' is incompatible"),  # the last override wins
    (["algo=ppo", "algo.cost_limit=0.5"], "algo.cost_limit=0.5 acts only in a Lagrangian algorithm"),
    (["algo=ddppo", "train.overlap=true"], "train.overlap=true learns in a thread of one process"),
])
def test_bad_input_one_line(tmp_path, args, words):
    proc = rvn_rl(f"out_dir={tmp_path / 'x'}", "train.total_steps=8", *TINY, *args, check=False)
    assert proc.returncode == 2 and not (tmp_path / "x").exists()  # bad input: nothing written
    err = [line for line in proc.stderr.splitlines() if line.strip() and "INFO" not in line]
    assert len(err) == 1 and err[0].startswith("rvn-rl: error:") and words in err[0], proc.stderr


def test_a_cache_dir_that_is_a_file_is_one_line(tmp_path):
    """The cache root (navmeshes, goal pools) is checked with out_dir, before anything is written."""
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    proc = rvn_rl(f"out_dir={tmp_path / 'x'}", f"cache_dir={blocker}", "train.total_steps=8", *TINY, check=False)
    assert proc.returncode == 2 and not (tmp_path / "x").exists()
    err = [line for line in proc.stderr.splitlines() if line.strip() and "INFO" not in line]
    assert err == [f"rvn-rl: error: cache_dir={blocker} is a file, not a folder; choose a folder for cache_dir="], err


def test_checkpoint_of_another_kind_is_refused(tmp_path):
    from rvn_rl.policy import load_rl_policy

    il = tmp_path / "il"
    il.mkdir()
    (il / "config.yaml").write_text(yaml.safe_dump({"model": {"name": "vint_pointgoal"}}))
    with pytest.raises(ValueError, match="not an rvn-rl"):
        load_rl_policy(il)
    proc = rvn_rl("algo=ppo", f"out_dir={il}", "train.total_steps=8", *TINY, check=False)
    assert proc.returncode == 2 and "not an rvn-rl" in proc.stderr
    other = tmp_path / "other"
    other.mkdir()
    (other / "config.yaml").write_text(yaml.safe_dump({"kind": "rl", "algo": {"name": "sac"}, "policy": {}}))
    with pytest.raises(ValueError, match="unknown RL algo 'sac'"):
        load_rl_policy(other)
    # a depth network's out_dir (python -m rvn_rl.depth.cli) given to rvn-eval's checkpoint loader: it says what it holds
    from rvn_il.policies import load_policy

    depth = tmp_path / "depth"
    depth.mkdir()
    (depth / "config.yaml").write_text(yaml.safe_dump({"out_dir": str(depth), "image_size": 32}))
    (depth / "model.json").write_text(json.dumps({"kind": "rvn_rl.depth"}))
    with pytest.raises(ValueError, match=r"not an rvn-train or rvn-rl checkpoint directory.*its kind: 'rvn_rl.depth'"):
        load_policy(depth)


def test_ddppo_depth_trains_on_a_fourth_channel(tmp_path):
    """algo=ddppo_depth (one rank): the rendered depth (depth.source=true) as the 4th input channel; rvn-eval runs it
    with env.depth=true. A frozen depth network's prediction (depth.source=model) as that channel, trained on 2 ranks
    and evaluated: the RL recipe's smoke test (tests/test_rl_ddppo.py)."""
    out = tmp_path / "dd"
    rvn_rl("algo=ddppo_depth", f"out_dir={out}", "train.total_steps=16", *TINY, "depth.source=true")
    cfg = yaml.safe_load((out / "config.yaml").read_text())
    assert cfg["policy"]["use_depth"] is True
    from rvn_rl.policy import load_rl_policy
    policy = load_rl_policy(out)
    assert policy.net.visual_encoder.backbone.conv1[0].in_channels == 4
    ev = tmp_path / "eval"
    args = ["rvn-eval", "policy=checkpoint", f"policy.checkpoint_path={out}", "split=val", "episodes.num_scenes=1",
            "episodes.per_scene=1", "episodes.n_goals=1", "env.t_max=10", "camera.width=32", "camera.height=32",
            f"out_dir={ev}", "progress=false", "renderer=raycast", f"episodes.dir={tmp_path / 'episodes'}", "env.depth=true"]
    proc = subprocess.run(args, capture_output=True, text=True, env=ENV, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]


def test_a_run_is_not_continued_on_another_depth_input(tmp_path):
    """config.yaml records the depth model's digest (depth.model_digest); a run whose out_dir holds a run trained on
    another depth source, or on a depth model that has changed since, is refused in one line before anything is
    written, instead of resuming its policy on another depth channel."""
    from rvn_rl import checkpoint as ck
    from rvn_rl.cli import compose
    from rvn_rl.depth.model import DepthNet, save_depth_model

    model = tmp_path / "depth"
    save_depth_model(DepthNet(widths=(4, 8)), model, image_size=32)
    with_model = ["algo=ddppo_depth", "depth.source=model", f"depth.model_path={model}", *TINY]
    for earlier, later, said in ((["algo=ddppo_depth", "depth.source=true", *TINY], with_model,
                                  "trained with depth.source=true, not model"),
                                 (with_model, with_model, "trained with depth.model_digest=")):
        out = tmp_path / "run"
        cfg = compose([*earlier, f"out_dir={out}"])
        ck.write_config(out, {**cfg.record(), "policy": cfg.model_kwargs()}, resuming=False)  # as rvn-rl writes it
        if said.endswith("digest="):  # the depth model retrained in place since
            assert len(yaml.safe_load((out / "config.yaml").read_text())["depth"].get("model_digest", "")) == 16
            save_depth_model(DepthNet(widths=(4, 8), init_depth=3.0), model, image_size=32)
        before = (out / "config.yaml").read_text()
        proc = rvn_rl(f"out_dir={out}", "train.total_steps=8", "train.resume=true", *later, check=False)
        err = [line for line in proc.stderr.splitlines() if line.strip() and "INFO" not in line]
        assert proc.returncode == 2 and len(err) == 1 and said in err[0], proc.stderr[-2000:]
        assert (out / "config.yaml").read_text() == before and not (out / "checkpoints").exists()


def test_a_policy_on_predicted_depth_names_the_depth_model_it_loaded(tmp_path):
    """An rvn-rl checkpoint on predicted depth loads the frozen depth model its config.yaml names, or the policy's
    ``depth_model_path`` (a model file: its folder), and names that folder as ``loaded_files`` for rvn-eval's run
    identity; a checkpoint on rendered depth loads none."""
    from rvn_rl import checkpoint as ck
    from rvn_rl.cli import compose
    from rvn_rl.depth.model import DepthNet, save_depth_model
    from rvn_rl.model import PointNavResNetPolicy
    from rvn_rl.policy import load_rl_policy

    model, other = tmp_path / "depth", tmp_path / "other"
    save_depth_model(DepthNet(widths=(4, 8)), model, image_size=32)
    save_depth_model(DepthNet(widths=(4, 8), init_depth=3.0), other, image_size=32)
    for source, loaded in ((["depth.source=model", f"depth.model_path={model}"], {"depth_model_path": str(model)}),
                           (["depth.source=true"], None)):
        out = tmp_path / source[0].split("=")[1]
        cfg = compose(["algo=ddppo_depth", *source, *TINY, f"out_dir={out}"])
        ck.write_config(out, {**cfg.record(), "policy": cfg.model_kwargs()}, resuming=False)  # as rvn-rl writes them
        ck.save(out, 8, PointNavResNetPolicy(**cfg.model_kwargs()), {})
        assert load_rl_policy(out).loaded_files == loaded
    other_file = str(other / "model.safetensors")
    assert load_rl_policy(tmp_path / "model", depth_model_path=other_file).loaded_files == \
        {"depth_model_path": str(other)}

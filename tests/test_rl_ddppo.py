"""DD-PPO: 2 ranks under torchrun on CPU (gloo), tiny sizes, through jobs/rl_small.sh; both ranks' steps are
counted, rank 0 writes the checkpoint, which rvn_rl's loader reads."""
from __future__ import annotations

import json
import os
import subprocess

import pytest
import yaml
from conftest import without_shared_cache


def test_straggler_preemption_rule():
    """A rank stops its rollout once sync_frac of the ranks finished theirs, but never before a
    quarter of the rollout (habitat-baselines' rule), counted per update."""
    import torch.distributed as dist

    from rvn_rl.distrib import Dist

    d = Dist(rank=3, world_size=4, store=dist.HashStore())
    assert not d.should_end_early(100, 128, update=0, sync_frac=0.6)
    d.rollout_done(0)
    d.rollout_done(0)
    assert not d.should_end_early(100, 128, update=0, sync_frac=0.6)  # 2 of 4 < 0.6
    d.rollout_done(0)
    assert d.should_end_early(100, 128, update=0, sync_frac=0.6)  # 3 of 4 >= 0.6
    assert not d.should_end_early(31, 128, update=0, sync_frac=0.6)  # under a quarter of the rollout
    assert not d.should_end_early(100, 128, update=1, sync_frac=0.6)  # the next update counts afresh
    assert not Dist().should_end_early(100, 128, update=0, sync_frac=0.6)  # one process: never


@pytest.mark.slow
def test_rl_small_recipe_smoke(tmp_path):
    """jobs/rl_small.sh end to end at SCALE=tiny: PPO, PPO-Lagrangian, DD-PPO (2 ranks under torchrun) and
    DD-PPO + predicted depth (the depth network trained first, then frozen), five evaluations, the report with
    its tests; a bad ALGOS, env split, DEPTH_SOURCE or DEPTH_MODEL stops before any work."""
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "jobs" / "rl_small.sh"
    out = tmp_path / "rl"
    # the recipe's caches under OUT/cache (its default), not the suite's shared root
    env = {**without_shared_cache(os.environ), "SCALE": "tiny", "THREADS": "1", "WORKERS": "1", "RENDERER": "raycast"}
    for bad, said in (({"ALGOS": "ppo dqn"}, "ALGOS contains 'dqn'"), ({"ALGOS": "ddppo", "NUM_ENVS": "2"}, "RANKS=2"),
                      ({"ALGOS": "ddppo_depth", "DEPTH_SOURCE": "sensor"}, "DEPTH_SOURCE=sensor"),
                      ({"ALGOS": "ddppo_depth", "DEPTH_MODEL": str(tmp_path)}, "holds no model.json")):
        proc = subprocess.run(["bash", str(script), str(tmp_path / "bad")], capture_output=True, text=True,
                              timeout=60, cwd=script.parents[1], env={**env, **bad})
        assert proc.returncode == 2 and said in proc.stderr, proc.stderr
        assert not (tmp_path / "bad").exists()
    proc = subprocess.run(["bash", str(script), str(out)], capture_output=True, text=True, timeout=900,
                          cwd=script.parents[1], env={**env, "ALGOS": "ppo ppo_lag ddppo ddppo_depth",
                                                      "COMPARE": "DD-PPO=PPO;DD-PPO=PPO-Lagrangian"})
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    report = (out / "report.md").read_text()
    assert "PPO-Lagrangian" in report and "Goal follower" in report
    assert report.count("| DD-PPO | PPO |") == 1 and "| DD-PPO | PPO-Lagrangian |" in report
    assert "| DD-PPO + predicted depth | DD-PPO |" in report
    depth = json.loads((out / "depth_model" / "metrics.json").read_text())
    assert 0 < depth["val"]["absrel"] < 10 and 0 <= depth["val"]["delta1"] <= 1
    depth_run = yaml.safe_load((out / "train" / "ddppo_depth" / "config.yaml").read_text())
    assert depth_run["depth"]["model_path"] == str(out / "depth_model") and depth_run["policy"]["use_depth"] is True
    # DD-PPO's 2 ranks (torchrun, gloo) x 2 envs: each update counts the steps of both ranks (at most the 16-step
    # rollout each; straggler pre-emption may end one early, never before a quarter of it)
    ddppo = [json.loads(line) for line in (out / "train" / "ddppo" / "metrics.jsonl").read_text().splitlines()]
    assert ddppo[-1]["env_steps"] >= 64 and all(4 <= r["rollout_steps"] <= 16 for r in ddppo)
    # DistributedDataParallel says nothing: no deprecated argument (torch 2.13's forward_sync_buffers), no stride
    # note for the downsample convolutions' gradients (rvn_rl.trainer._replica)
    log = (out / "logs" / "train_ddppo.log").read_text()
    assert "broadcast_buffers" not in log and "bucket view strides" not in log, log[-3000:]
    from rvn_rl.policy import load_rl_policy
    assert load_rl_policy(out / "train" / "ddppo").net.visual_encoder.running_mean_and_var._count > 0  # rank 0's
    # the frozen depth network's prediction as the 4th input channel (depth.source=model)
    assert load_rl_policy(out / "train" / "ddppo_depth").net.visual_encoder.backbone.conv1[0].in_channels == 4
    for algo in ("ppo", "ppo_lag", "ddppo", "ddppo_depth"):
        assert (out / "train" / algo / "learning_curve.png").is_file()
        assert json.loads((out / "eval" / algo / "metrics.json").read_text())["episodes"] == 1
    # one cache root for the recipe: the 2 train scenes' navmeshes and goal pools, the val scene's navmesh, kept once
    assert len(list((out / "cache" / "goal_pools").rglob("*.npz"))) == 2
    assert len(list((out / "cache" / "navmesh").rglob("*.npz"))) == 3
    assert not list(out.glob("*/*/cache")), "a run kept caches of its own"
    # FROM / TAG (a run continued in a tagged one) and EVAL_CHECKPOINTS: the recipe's commands in
    # tests/test_jobs_scripts.py, rvn-rl's train.continue_from and rvn-eval's +policy.env_steps in tests/test_rl_resume.py,
    # a row read over its checkpoints in tests/test_report.py


def test_rl_small_keeps_the_rendered_depth_ablation_apart(tmp_path):
    """jobs/rl_small.sh with DEPTH_SOURCE=true trains and evaluates into train/ddppo_depth_true and
    eval/ddppo_depth_true, so the rendered-depth ablation neither resumes nor overwrites the predicted-depth run of
    the same OUT (train/ddppo_depth, which rvn-rl would refuse as another depth input); the commands are recorded by
    stand-ins for python and rvn-eval."""
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "jobs" / "rl_small.sh"
    bin_dir, calls = tmp_path / "bin", tmp_path / "calls.txt"
    bin_dir.mkdir()
    for name in ("python", "rvn-eval"):
        (bin_dir / name).write_text(f'#!/usr/bin/env bash\necho "{name} $*" >> {calls}\n')
        (bin_dir / name).chmod(0o755)
    env = {**os.environ, "SCALE": "tiny", "ALGOS": "ddppo_depth", "PYTHON": str(bin_dir / "python"),
           "PATH": f"{bin_dir}:{os.environ['PATH']}"}
    for source, name in (("true", "ddppo_depth_true"), ("model", "ddppo_depth")):
        out = tmp_path / "out"
        proc = subprocess.run(["bash", str(script), str(out)], capture_output=True, text=True, timeout=60,
                              cwd=script.parents[1], env={**env, "DEPTH_SOURCE": source})
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
        lines = calls.read_text().splitlines()
        train = [line for line in lines if "rvn_rl.cli" in line and f"depth.source={source}" in line]
        evals = [line for line in lines if f"policy.checkpoint_path={out}/train/" in line]
        assert len(train) == 1 and f"out_dir={out}/train/{name} " in train[0], lines
        assert len(evals) == 1 and f"policy.checkpoint_path={out}/train/{name} " in evals[0] \
            and f"out_dir={out}/eval/{name} " in evals[0], lines
        calls.unlink()


def test_rl_paper_scale_jobs_share_one_cache_root(tmp_path):
    """jobs/rl_paper_scale.sh (DRY_RUN): every sbatch job (and the evaluations after them) uses $OUT/cache, so the jobs
    of the cluster build each scene's navmesh and goal pool once between them; a root the user set is kept."""
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "jobs" / "rl_paper_scale.sh"
    env = without_shared_cache(os.environ)
    for given, root in ((None, tmp_path / "out" / "cache"), (str(tmp_path / "scratch"), tmp_path / "scratch")):
        run_env = {**env, "DRY_RUN": "1", "OUT": str(tmp_path / "out"), "DEPTH_SOURCE": "true",
                   **({"RVN_CACHE_DIR": given} if given else {})}
        proc = subprocess.run(["bash", str(script)], capture_output=True, text=True, timeout=60, env=run_env)
        assert proc.returncode == 0, proc.stderr
        scripts = proc.stdout.split("---- ")[1:]
        assert [s.split("\n", 1)[0] for s in scripts] == ["ppo", "ppo_lag", "ddppo", "ddppo_depth"]
        for text in scripts:
            assert f"export RVN_CACHE_DIR={root}\n" in text, text


@pytest.mark.slow
def test_ranks_and_a_resumed_run_draw_their_own_actions(monkeypatch, tmp_path):
    """Every rank's weights start from one torch seed (DistributedDataParallel needs them equal); the actions do not
    draw from that stream: rank 1 acting on rank 0's envs (made here without the rank, so its observations are rank
    0's) draws other actions, and a run resumed after its first update draws from another stream than its start."""
    import torch

    from rvn_rl import trainer
    from rvn_rl.cli import compose
    from rvn_rl.distrib import Dist

    from test_rl_overlap import TINY

    seen, collect, make_envs = [], trainer.collect, trainer.make_envs

    def recording_collect(actor, envs, storage, *args, **kwargs):
        first = storage.obs["rgb"][0].clone()
        out = collect(actor, envs, storage, *args, **kwargs)
        generator = args[-1] if len(args) == 7 else kwargs.get("generator")
        seen.append((first, storage.actions[:storage.step].clone(), generator and generator.initial_seed()))
        return out

    def run(rank: int, out, total: int):
        seen.clear()
        with monkeypatch.context() as patch:
            patch.setattr(trainer, "init", lambda backend, device: Dist(rank=rank))
            patch.setattr(trainer, "collect", recording_collect)
            patch.setattr(trainer, "make_envs", lambda *a, rank=0, **k: make_envs(*a, rank=0, **k))
            trainer.train(compose(["algo=ppo", f"out_dir={out}", f"cache_dir={tmp_path / 'cache'}", *TINY,
                                   "ppo.num_steps=16", f"train.total_steps={total}"]))
        return list(seen)

    (rgb0, acts0, seed0), = run(0, tmp_path / "r0", 32)
    (rgb1, acts1, seed1), = run(1, tmp_path / "r1", 32)
    assert torch.equal(rgb0, rgb1)  # the same envs: what differs is the draw
    assert not torch.equal(acts0, acts1) and seed0 != seed1
    (_, _, resumed), = run(0, tmp_path / "r0", 64)  # from the checkpoint at 32 env steps (update 1)
    assert resumed not in (seed0, seed1)

"""rvn-train end to end on a tiny GNM dataset: CLI, checkpoints, load_policy, resume, bad input."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
from conftest import interrupted_copy
import torch
import yaml
from safetensors.torch import load_file

from rvn_il.data.synthetic import render_frame, write_synthetic_gnm
from rvn_il.models.checkpoint import latest_checkpoint
from rvn_il.policies import NoMaDNegPolicy, load_policy
from rvn_il.policies.loader import resolve_device
from rvn_il.train.cli import main, train

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

torch.set_num_threads(1)
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
SMALL = ["model.size=small", "train.batch_size=4", "train.log_every=1"]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    base = tmp_path_factory.mktemp("il_train")
    write_synthetic_gnm(base / "expert", 3, 24, image_size=64, seed=0)
    write_synthetic_gnm(base / "negative", 3, 15, image_size=64, seed=1)
    return base


def rvn_train(*args):
    return subprocess.run([sys.executable, "-m", "rvn_il.train.cli", *args], capture_output=True, text=True, env=ENV,
                          timeout=300)


@pytest.fixture(scope="module")
def runs(data):
    """One rvn-train run per model (3 steps, small size): ViNT's and NoMaD's call the CLI's main()
    in this process (ViNT's with 2 loader workers), NoMaD-Neg's runs the console script in a
    subprocess with data-derived action_stats, the moving waypoint labels and the padded first contexts."""
    out = {}
    common = [f"data.root={data / 'expert'}", f"data.negative_root={data / 'negative'}", "train.max_steps=3", *SMALL]
    for name, workers in (("vint_pointgoal", 2), ("nomad_pointgoal", 0)):
        out[name] = data / f"run_{name}"
        argv = sys.argv
        sys.argv = ["rvn-train", f"model={name}", f"out_dir={out[name]}", f"data.num_workers={workers}", *common]
        try:
            main()
        finally:
            sys.argv = argv
    out["nomad_neg"] = data / "run_nomad_neg"
    r = subprocess.run(["rvn-train", "model=nomad_neg", f"out_dir={out['nomad_neg']}", "data.num_workers=0",
                        "model.action_stats=auto", "data.waypoint_frames=moving", "data.pad_context=true", *common],
                       capture_output=True, text=True, env=ENV, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    return out


@pytest.mark.parametrize("name", ["vint_pointgoal", "nomad_pointgoal", "nomad_neg"])
def test_cli_trains_and_writes_a_self_contained_checkpoint(runs, name):
    out_dir = runs[name]
    # Hydra's record and the log, written once the settings were checked (Hydra itself writes nothing)
    assert (out_dir / ".hydra" / "config.yaml").is_file() and "rvn_il" in (out_dir / "rvn-train.log").read_text()
    cfg = yaml.safe_load((out_dir / "config.yaml").read_text())
    assert cfg["model"]["name"] == name and cfg["train"]["max_steps"] == 3
    assert cfg["data"]["waypoint_frames"] == ("moving" if name == "nomad_neg" else "all")
    assert cfg["data"]["pad_context"] == (name == "nomad_neg")
    members = ["expert", "negative"] if name == "nomad_neg" else ["model"]
    for m in members:
        ckpt = latest_checkpoint(out_dir / m)
        assert ckpt.name == "ckpt_00000003"
        assert (ckpt / "ema.safetensors").is_file() == name.startswith("nomad")
        assert load_file(str(ckpt / "weights.safetensors"))
        assert list((out_dir / "tb" / m).glob("events.out.tfevents.*"))
        if name == "nomad_neg":  # action_stats=auto: the data's delta range, in the stats and the EMA weights
            stats = json.loads((ckpt / "stats.json").read_text())["action_stats"]
            assert -1.2 < stats["min"][0] < 0.1 and 0.9 < stats["max"][0] < 1.2
            ema = load_file(str(ckpt / "ema.safetensors"))
            assert ema["action_max"].tolist() == pytest.approx(stats["max"])
    # the checkpoint alone rebuilds the policy; same seed → same actions
    policy = load_policy(out_dir)
    assert isinstance(policy, NoMaDNegPolicy) == (name == "nomad_neg")
    frames = [render_frame(np.array([0.25 * t, 0.0]), 0.1 * t, 128) for t in range(5)]

    def episode(p):
        p.reset()
        return [p.act({"rgb": f, "pointgoal": np.array([3.0, -1.0], np.float32)}) for f in frames]

    actions = episode(policy)
    assert actions == episode(load_policy(out_dir)) == episode(policy)
    assert all(a in (1, 2, 3) for a in actions)
    if name == "nomad_neg":  # as rvn-eval builds it from conf/policy/checkpoint.yaml
        from hydra.utils import instantiate
        p = instantiate({"_target_": "rvn_il.policies.load_policy", "checkpoint_path": str(out_dir), "device": "cpu",
                         "selection": "argmin", "cor_alpha": 2.0})
        assert (p.selection, p.cor_alpha) == ("argmin", 2.0) and len(episode(p)) == len(frames)


def test_a_nomad_policy_acts_without_importing_diffusers(runs):
    """A NoMaD checkpoint's policy samples with the plans' own noise schedule (rvn_il.models.sampling_plan.NoiseSchedule):
    a process that loads one and acts, with either sampler, never imports diffusers, whose import (torch._dynamo)
    costs ~1.9 s a process; the reference path brings it in."""
    code = ("import sys, numpy as np; from rvn_il.policies import load_policy; from rvn_il.data.synthetic import render_frame\n"
            "obs = {'rgb': render_frame(np.zeros(2), 0.0, 64), 'pointgoal': np.array([3.0, -1.0], np.float32)}\n"
            f"for sampler in ('ddpm', 'ddim'):\n p = load_policy({str(runs['nomad_neg'])!r}, sampler=sampler); p.reset(); p.act(obs)\n"
            "print('diffusers' in sys.modules)\n"
            "p.members[0].model.fast_sampling = False; p.act(obs); print('diffusers' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.split() == ["False", "True"]


def test_checkpoint_of_another_model_is_named(runs, data):
    with pytest.raises(ValueError, match="holds a 'vint_pointgoal' model, not 'nomad_pointgoal'"):
        load_policy(runs["vint_pointgoal"], model="nomad_pointgoal")
    with pytest.raises(ValueError, match="policy.lookahead is not a policy setting; nearest: lookahead_min_dist"):
        load_policy(runs["vint_pointgoal"], lookahead=3)
    with pytest.raises(ValueError, match="not an rvn-train checkpoint directory"):
        load_policy(data)
    with pytest.raises(ValueError, match=r"policy.depth_veto=0.5: this checkpoint has no depth head.*depth_aux_weight > 0"):
        load_policy(runs["nomad_pointgoal"], depth_veto=0.5)
    # weights of a ViNT run copied into a NoMaD run: refused, naming the checkpoint
    fake = data / "fake"
    shutil.copytree(runs["nomad_pointgoal"], fake)
    ckpt = latest_checkpoint(fake / "model")
    shutil.copy(latest_checkpoint(runs["vint_pointgoal"] / "model") / "stats.json", ckpt / "stats.json")
    with pytest.raises(ValueError, match=r"ckpt_00000003 holds a 'vint_pointgoal' model, not 'nomad_pointgoal'"):
        load_policy(fake)
    # resuming another model's out_dir is refused
    with pytest.raises(ValueError, match="holds a checkpoint of model 'vint_pointgoal'"):
        train(["model=nomad_pointgoal", f"data.root={data / 'expert'}", f"out_dir={runs['vint_pointgoal']}", *SMALL])


def test_ensemble_vote_pools_checkpoints(runs, data, tmp_path):
    """policy.ensemble: a second NoMaD run (here a copy) joins the vote as a second member, through
    the Hydra instantiation rvn-eval uses; bad ensembles are named."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    twin = tmp_path / "twin"
    shutil.copytree(runs["nomad_pointgoal"], twin)
    cfg = OmegaConf.create({"_target_": "rvn_il.policies.load_policy", "checkpoint_path": str(runs["nomad_pointgoal"]),
                            "device": "cpu", "aggregate": "vote", "ensemble": [str(twin)], "num_samples": 3})
    policy = instantiate(cfg)
    assert len(policy.members) == 2
    frames = [render_frame(np.array([0.25 * t, 0.0]), 0.1 * t, 128) for t in range(4)]
    policy.reset()
    first = [policy.act({"rgb": f, "pointgoal": np.array([3.0, 1.0], np.float32)}) for f in frames]
    policy.reset()
    assert first == [policy.act({"rgb": f, "pointgoal": np.array([3.0, 1.0], np.float32)}) for f in frames]
    assert all(a in (1, 2, 3) for a in first)
    nomad = runs["nomad_pointgoal"]
    with pytest.raises(ValueError, match="needs policy.aggregate=vote"):
        load_policy(nomad, ensemble=[twin])
    with pytest.raises(ValueError, match="holds a 'vint_pointgoal' model, not 'nomad_pointgoal'"):
        load_policy(nomad, aggregate="vote", ensemble=str(runs["vint_pointgoal"]))
    with pytest.raises(ValueError, match="missing does not exist"):
        load_policy(nomad, aggregate="vote", ensemble=[data / "missing"])
    with pytest.raises(ValueError, match="NoMaD-Neg already pairs"):
        load_policy(runs["nomad_neg"], ensemble=[twin])


def test_sampler_setting_reaches_every_network(runs):
    """policy.sampler=ddim sets DDIM on each NoMaD network (NoMaD-Neg: both), the policy still acts;
    ViNT and unknown samplers are refused with the setting named."""
    for name, n in (("nomad_pointgoal", 1), ("nomad_neg", 2)):
        policy = load_policy(runs[name], sampler="ddim", num_samples=2)
        assert [m.model.sampler for m in policy.members] == ["ddim"] * n
        policy.reset()
        obs = {"rgb": render_frame(np.zeros(2), 0.0, 128), "pointgoal": np.array([3.0, 1.0], np.float32)}
        assert policy.act(obs) in (0, 1, 2, 3)
    assert [m.model.sampler for m in load_policy(runs["nomad_pointgoal"]).members] == ["ddpm"]
    with pytest.raises(ValueError, match="policy.sampler='ddim': ViNT-PointGoal predicts its waypoints directly"):
        load_policy(runs["vint_pointgoal"], sampler="ddim")
    with pytest.raises(ValueError, match="policy.sampler='ddim2'"):
        load_policy(runs["nomad_pointgoal"], sampler="ddim2")


def test_resume_continues_exactly(data, tmp_path):
    args = [f"data.root={data / 'expert'}", "model=nomad_pointgoal", "train.max_steps=4", "train.ckpt_every=2",
            "data.num_workers=0", *SMALL]
    full = train([f"out_dir={tmp_path / 'full'}", *args])
    # an interrupted run: only the step-2 checkpoint survived
    part = interrupted_copy(full, tmp_path / "part")
    train([f"out_dir={part}", *args])
    a = latest_checkpoint(full / "model")
    b = latest_checkpoint(part / "model")
    assert a.name == b.name == "ckpt_00000004"
    assert torch.load(b / "state.pt", weights_only=False)["step"] == 4
    for f in ("weights.safetensors", "ema.safetensors"):
        wa, wb = load_file(str(a / f)), load_file(str(b / f))
        for k in wa:
            torch.testing.assert_close(wa[k], wb[k], rtol=0, atol=0, msg=f"{f}:{k}")
    # nothing left to do: a rerun returns at once and keeps the checkpoint
    train([f"out_dir={part}", *args])
    assert latest_checkpoint(part / "model").name == "ckpt_00000004"


@pytest.fixture(scope="module")
def kept_run(data):
    """NoMaD-PointGoal trained 6 steps keeping its checkpoints of steps 2, 4 and 6."""
    run = data / "run"
    train([f"out_dir={run}", f"data.root={data / 'expert'}", "model=nomad_pointgoal", "train.max_steps=6",
           "train.ckpt_every=2", "train.keep_checkpoints=3", "data.num_workers=0", *SMALL])
    return run


def test_policy_step_loads_a_kept_checkpoint(kept_run, tmp_path):
    """policy.step: a kept checkpoint other than the latest (a run read over its last few), its EMA weights; a step the
    run does not keep names the ones it does; a bad value or an ensemble is refused."""
    run = kept_run
    assert sorted(p.name for p in (run / "model").glob("ckpt_*")) == ["ckpt_00000002", "ckpt_00000004", "ckpt_00000006"]
    for step, ckpt in ((2, "ckpt_00000002"), (4, "ckpt_00000004"), (None, "ckpt_00000006")):
        net = load_policy(run, step=step).members[0].model
        ema = load_file(str(run / "model" / ckpt / "ema.safetensors"))
        for k, v in net.state_dict().items():
            torch.testing.assert_close(v, ema[k], rtol=0, atol=0, msg=f"step={step}: {k}")
    with pytest.raises(ValueError, match=r"keeps no checkpoint of step 3 \(policy.step\); it keeps 2, 4, 6"):
        load_policy(run, step=3)
    for bad in ("4", -1, 2.0, True):
        with pytest.raises(ValueError, match="policy.step=.*integer"):
            load_policy(run, step=bad)
    with pytest.raises(ValueError, match="policy.step=2 with policy.ensemble"):
        load_policy(run, step=2, aggregate="vote", ensemble=[str(run)])
    # rvn-eval with no method=: the row "run ckpt2" in runs/eval/val/run_ckpt2, which the report reads "run" over
    r = subprocess.run([sys.executable, "-m", "rvn_data.benchmark.cli", "policy=checkpoint", f"policy.checkpoint_path={run}",
                        "+policy.step=2", "split=val", "episodes.num_scenes=1", "episodes.per_scene=1", "episodes.n_goals=1",
                        "env.t_max=5", "camera.width=32", "camera.height=32", "progress=false",
                        f"episodes.dir={tmp_path / 'episodes'}"], capture_output=True, text=True, env=ENV, timeout=300,
                       cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    metrics = json.loads((tmp_path / "runs" / "eval" / "val" / "run_ckpt2" / "metrics.json").read_text())
    assert metrics["method"] == "run ckpt2" and metrics["episodes"] == 1


def test_cli_bad_input_one_line(data, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    r = rvn_train("model=vint_pointgoal", f"data.root={empty}", f"out_dir={tmp_path / 'o1'}", *SMALL)
    assert r.returncode == 2 and "holds no trajectory" in r.stderr and "Traceback" not in r.stderr
    with pytest.raises(ValueError, match="data.negative_root"):
        train(["model=nomad_neg", f"data.root={data / 'expert'}", "data.negative_root=null", f"out_dir={tmp_path / 'o2'}"])
    with pytest.raises(ValueError, match="fewer than context_size.*skip_short"):
        train(["model=nomad_pointgoal", f"data.root={data / 'negative'}", f"out_dir={tmp_path / 'o3'}",
               "model.context_size=14", *SMALL])
    with pytest.raises(ValueError, match="model.prediction_type='x0'; choose one of epsilon, sample, v_prediction"):
        train(["model=nomad_pointgoal", f"data.root={data / 'expert'}", f"out_dir={tmp_path / 'o4'}",
               "model.prediction_type=x0", *SMALL])
    assert not (tmp_path / "o4").exists()
    r = rvn_train("model=nomad_pointgoal", f"data.root={data / 'expert'}", f"out_dir={tmp_path / 'o6'}",
                  "data.waypoint_frames=moved", *SMALL)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "data.waypoint_frames='moved'" in r.stderr
    assert not (tmp_path / "o6").exists()
    # the loop takes every step modulo these: 0 ended in a ZeroDivisionError after the first step (the cache built)
    r = rvn_train("model=vint_pointgoal", f"data.root={data / 'expert'}", f"out_dir={tmp_path / 'o7'}", "train.ckpt_every=0",
                  *SMALL)
    assert r.returncode == 2 and r.stderr.strip().splitlines()[-1].endswith("train.ckpt_every=0 must be a positive integer")
    assert not (tmp_path / "o7").exists()
    if not torch.cuda.is_available():  # a CPU build of torch: one line naming the setting, nothing written
        r = rvn_train("model=vint_pointgoal", f"data.root={data / 'expert'}", f"out_dir={tmp_path / 'o5'}", "device=cuda",
                      *SMALL)
        assert r.returncode == 2 and "Traceback" not in r.stderr
        assert "device=cuda" in r.stderr and "use device=cpu" in r.stderr and len(r.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "o5" / "model").exists()
        with pytest.raises(ValueError, match="policy.device=cuda"):
            resolve_device("cuda", "policy.device")


def test_a_step_that_leaves_a_weight_non_finite_is_not_saved(data, tmp_path, monkeypatch):
    """The loss is checked before each checkpoint, but a step whose loss was finite can still overflow a weight: its
    checkpoint would have become ``latest``, the one a resume continues from. The optimizer's last step here writes
    an inf into one weight after a finite loss."""
    step = torch.optim.AdamW.step
    calls = []

    def overflowing(self, *args, **kwargs):
        out = step(self, *args, **kwargs)
        calls.append(1)
        if len(calls) == 2:
            weight = self.param_groups[0]["params"][0].data
            weight[(0,) * weight.dim()] = float("inf")
        return out

    monkeypatch.setattr(torch.optim.AdamW, "step", overflowing)
    with pytest.raises(ValueError, match=r"non-finite weight \S+ after step 2 of vint_pointgoal/model, not saved"):
        train(["model=vint_pointgoal", f"data.root={data / 'expert'}", f"out_dir={tmp_path / 'o'}", "train.max_steps=2",
               "data.num_workers=0", *SMALL])
    assert not list((tmp_path / "o" / "model").glob("ckpt_*"))


def test_nomad_neg_adopts_a_nomad_pointgoal_run_as_nomad_e(runs, data, tmp_path):
    """train.expert_from: NoMaD_e is the NoMaD-PointGoal run's checkpoint (not trained again),
    NoMaD_n is trained; a rerun keeps it; a run of another model is refused by name."""
    common = [f"data.root={data / 'expert'}", f"data.negative_root={data / 'negative'}", "train.max_steps=2",
              "data.num_workers=0", *SMALL]
    out = tmp_path / "neg"
    train(["model=nomad_neg", f"out_dir={out}", f"train.expert_from={runs['nomad_pointgoal']}", *common])
    src = latest_checkpoint(runs["nomad_pointgoal"] / "model")
    mine = latest_checkpoint(out / "expert")
    assert mine.name == src.name  # the source's step, not this run's max_steps
    a, b = load_file(str(mine / "ema.safetensors")), load_file(str(src / "ema.safetensors"))
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert json.loads((mine / "stats.json").read_text())["adopted_from"] == str(src.resolve())
    assert latest_checkpoint(out / "negative").name == "ckpt_00000002"
    assert isinstance(load_policy(out), NoMaDNegPolicy)
    train(["model=nomad_neg", f"out_dir={out}", f"train.expert_from={runs['nomad_pointgoal']}", *common])  # rerun: kept
    assert latest_checkpoint(out / "expert") == mine
    r = rvn_train("model=nomad_neg", f"out_dir={tmp_path / 'bad'}", f"train.expert_from={runs['vint_pointgoal']}", *common)
    assert r.returncode != 0 and "train.expert_from" in r.stderr and "'vint_pointgoal' run" in r.stderr
    assert "Traceback" not in r.stderr


def test_nomad_neg_adopts_a_kept_checkpoint_as_nomad_e(kept_run, data, tmp_path):
    """train.expert_step: NoMaD-Neg's NoMaD_e is the NoMaD-PointGoal run's kept checkpoint of that step (NoMaD-Neg read
    over NoMaD_e's checkpoints); NoMaD_n does not depend on which, the same seed trains the same weights. A step the run
    does not keep names the kept ones; the setting without train.expert_from, or not a step, is refused in one line."""
    common = [f"data.root={data / 'expert'}", f"data.negative_root={data / 'negative'}", "train.max_steps=2",
              "data.num_workers=0", f"train.expert_from={kept_run}", *SMALL]
    negatives = []
    for step in (4, 2):
        out = tmp_path / f"neg{step}"
        train(["model=nomad_neg", f"out_dir={out}", f"train.expert_step={step}", *common])
        mine, src = latest_checkpoint(out / "expert"), kept_run / "model" / f"ckpt_{step:08d}"
        assert mine.name == src.name
        a, b = load_file(str(mine / "ema.safetensors")), load_file(str(src / "ema.safetensors"))
        assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
        assert json.loads((mine / "stats.json").read_text())["adopted_from"] == str(src.resolve())
        negatives.append(load_file(str(latest_checkpoint(out / "negative") / "weights.safetensors")))
        assert isinstance(load_policy(out), NoMaDNegPolicy)
    assert all(torch.equal(negatives[0][k], negatives[1][k]) for k in negatives[0])
    # a rerun with another step: the run holds another NoMaD_e
    r = rvn_train("model=nomad_neg", f"out_dir={tmp_path / 'neg4'}", "train.expert_step=6", *common)
    assert r.returncode == 2 and "already holds a NoMaD_e checkpoint that is not" in r.stderr, r.stderr[-2000:]
    assert "Traceback" not in r.stderr and not list((tmp_path / "neg4" / "negative").glob("*.tmp*"))
    for bad, said in (("train.expert_step=3", "keeps no checkpoint of step 3 (train.expert_step); it keeps 2, 4, 6"),
                      ("train.expert_step=abc", "train.expert_step"),
                      ("train.expert_step=-2", "train.expert_step=-2: give a kept checkpoint's optimiser step")):
        r = rvn_train("model=nomad_neg", f"out_dir={tmp_path / 'bad'}", bad, *common)
        assert r.returncode == 2 and said in r.stderr and "Traceback" not in r.stderr, (bad, r.stderr[-2000:])
        assert not (tmp_path / "bad").exists()
    r = rvn_train("model=nomad_neg", f"out_dir={tmp_path / 'bad'}", "train.expert_step=2",
                  *[c for c in common if not c.startswith("train.expert_from")])
    assert r.returncode == 2 and "train.expert_step=2 needs train.expert_from" in r.stderr, r.stderr[-2000:]


def test_a_current_packed_cache_spares_the_frame_check(runs, data):
    """rvn-train's preflight reads every frame of its data (verify.py), unless the packed cache built from exactly
    these files is current; a file changed since makes it read them all again (benchmarks/verify.py: the cost)."""
    args = ["model=nomad_pointgoal", f"data.root={data / 'expert'}", f"out_dir={runs['nomad_pointgoal']}",
            "train.max_steps=3", "data.num_workers=0", *SMALL]
    r = rvn_train(*args)
    assert r.returncode == 0 and "3 trajectories unchanged since their packed cache was built" in r.stdout + r.stderr
    frame = data / "expert" / "traj_000_0000" / "0.jpg"
    os.utime(frame, ns=(frame.stat().st_atime_ns, frame.stat().st_mtime_ns + 1_000_000))
    r = rvn_train(*args)
    assert r.returncode == 0 and "unchanged since their packed cache" not in r.stdout + r.stderr


def test_bf16_on_a_gpu_without_bfloat16_is_one_line_before_any_work(data, tmp_path, monkeypatch):
    """train.precision=bf16 on a GPU before Ampere (no bfloat16) would fail inside autocast at the first step:
    rvn-train's preflight names the GPU and the setting instead, nothing written (rvn-rl's trainer runs the same
    check, rvn_il.train.choices.check_precision_on). The GPU is stood in for: this machine may have none."""
    import rvn_il.train.preflight as preflight
    from rvn_il.train.choices import check_precision_on

    monkeypatch.setattr(preflight, "resolve_device", lambda setting, *a: torch.device("cuda"))
    monkeypatch.setattr(torch.cuda, "is_bf16_supported", lambda *a, **k: False)
    monkeypatch.setattr(torch.cuda, "get_device_name", lambda *a: "Tesla V100-SXM2-16GB")
    with pytest.raises(ValueError, match=r"^train.precision=bf16: Tesla V100-SXM2-16GB has no bfloat16 \(GPUs from "
                                         r"Ampere on\); use train.precision=fp32$"):
        train(["model=vint_pointgoal", f"data.root={data / 'expert'}", f"out_dir={tmp_path / 'o'}", "device=cuda",
               "train.precision=bf16", *SMALL])
    assert not (tmp_path / "o").exists()
    check_precision_on("fp32", torch.device("cuda"))  # float32 runs anywhere; bf16 on a CPU too (slow if emulated)
    check_precision_on("bf16", torch.device("cpu"))

"""python -m rvn_il.eval.agreement on a dataset made by rvn-gen and a checkpoint made by rvn-train."""
from __future__ import annotations

import json

import pytest
from conftest import run_python as run

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    base = tmp_path_factory.mktemp("agreement")
    run("-m", "rvn_data.gen.cli", f"out_dir={base / 'data'}", "scenes.num_scenes=1", "trajectories_per_scene=3",
        "camera.width=64", "camera.height=64", "progress=false")
    run("-m", "rvn_il.train.cli", "model=nomad_pointgoal", "model.size=small", f"data.root={base / 'data'}",
        f"out_dir={base / 'run'}", "train.max_steps=2", "train.batch_size=4", "data.num_workers=0", "device=cpu")
    return base


def test_agreement_replays_every_expert_frame(trained):
    out = trained / "agreement.json"
    proc = run("-m", "rvn_il.eval.agreement", str(trained / "run"), str(trained / "data"), "--waypoint-index", "none",
               "--json", str(out))
    result = json.loads(out.read_text())
    frames = sum(json.loads(p.read_text())["frames"] for p in (trained / "data").glob("*/rvn_meta.json"))
    assert result["trajectories"] == 3 and result["policy"]["steps"] == frames
    assert sum(map(sum, result["confusion"])) == frames
    assert 0.0 <= result["policy"]["agreement"] <= 1.0
    # the first-waypoint rule is the expert follower's own rule: the true future gives its actions back
    assert result["adapter_ceiling"]["agreement"] >= 0.99, result["adapter_ceiling"]
    assert "agreement with the expert's action" in proc.stdout
    # the blind goal follower is compared on every frame; the policy is scored apart where it is wrong
    blind, needs_image = result["blind_goal_follower"], result["policy_where_blind_is_wrong"]
    assert blind["steps"] == frames and 0 < needs_image["steps"] < frames
    assert needs_image["steps"] == round(frames * (1 - blind["agreement"]))
    # and apart on each trajectory's first context_size (3) decisions, whose context is padded
    assert result["policy_first_decisions"]["steps"] == 3 * 3 and "first 3 decisions" in proc.stdout
    # one run for two independent settings: the last-waypoint rule cannot reproduce every turn even from the true
    # future; a vote over NoMaD's samples scores the same frames, as rvn-eval's policy.aggregate=vote
    vote = trained / "vote.json"
    last = run("-m", "rvn_il.eval.agreement", str(trained / "run"), str(trained / "data"), "--waypoint-index", "-1",
               "--num-samples", "4", "--aggregate", "vote", "--json", str(vote))
    assert "adapter ceiling" in last.stdout and "adapter ceiling 1.000" not in last.stdout
    assert json.loads(vote.read_text())["policy"]["steps"] == frames


def test_agreement_bad_input_is_one_line(trained):
    proc = run("-m", "rvn_il.eval.agreement", str(trained / "run"), str(trained), "--split", "test", check=False)
    assert proc.returncode == 2 and "data_splits" in proc.stderr and "Traceback" not in proc.stderr
    proc = run("-m", "rvn_il.eval.agreement", str(trained / "run"), str(trained / "data"), "--aggregate", "mean", check=False)
    assert proc.returncode == 2 and "aggregate='mean'" in proc.stderr and "Traceback" not in proc.stderr
    proc = run("-m", "rvn_il.eval.agreement", str(trained / "data"), str(trained / "data"), check=False)
    assert proc.returncode == 2 and "not an rvn-train checkpoint directory" in proc.stderr


def test_training_logs_val_loss_and_the_agreement_tool_figure(trained):
    """rvn-train data.val_root=...: held-out loss and open-loop agreement at every val_every step and the
    last, in val.json; the last agreement is what the agreement tool reports for the saved checkpoint. Here the val
    data is the training data, which rvn-train says. The dataset's entry crops as visualnav-transformer
    (data.official_config gives each of its datasets that crop): validation crops as the policy will (it took
    data.crop, aspect, while training took the entry's)."""
    out = trained / "run_val"
    proc = run("-m", "rvn_il.train.cli", "model=nomad_pointgoal", "model.size=small",
               f"data.datasets=[{{root: {trained / 'data'}, crop: official}}]", f"cache_dir={trained / 'cache_val'}",
               f"data.val_root={trained / 'data'}", "train.val_every=2", "train.val_trajectories=2",
               "train.val_batches=2", f"out_dir={out}", "train.max_steps=3", "train.batch_size=4", "data.num_workers=0",
               "device=cpu", "train.precision=bf16")
    packed = sorted(p.name for p in (trained / "cache_val" / "packed").rglob("*.h5"))
    assert len(packed) == 2 and all(name.endswith("_official.h5") for name in packed), packed  # training's, validation's
    # validating on the training data's own scene is said (rvn-gen split=val would give other scenes)
    assert (f"data.val_root={trained / 'data'} holds 1 scene(s) of the training data (proc_train_0000): validation on "
            "them is not held out") in proc.stderr + proc.stdout
    history = json.loads((out / "model" / "val.json").read_text())
    assert list(history) == ["2", "3"]
    for figures in history.values():
        assert figures["loss"] > 0 and 0.0 <= figures["agreement"] <= 1.0 and figures["steps"] > 0
        assert set(figures) >= {"diffusion_loss", "dist_loss", "agreement_blind", "agreement_image", "agreement_start"}
    tool = trained / "val_agreement.json"
    run("-m", "rvn_il.eval.agreement", str(out), str(trained / "data"), "--max-trajectories", "2", "--json", str(tool))
    result = json.loads(tool.read_text())
    assert history["3"]["steps"] == result["policy"]["steps"]
    assert history["3"]["agreement"] == pytest.approx(result["policy"]["agreement"], abs=1e-4)
    assert history["3"]["agreement_blind"] == pytest.approx(result["blind_goal_follower"]["agreement"], abs=1e-4)
    assert history["3"]["agreement_start"] == pytest.approx(result["policy_first_decisions"]["agreement"], abs=1e-4)


def test_training_settings_fail_before_any_work(trained):
    base = ["-m", "rvn_il.train.cli", "model=nomad_pointgoal", "model.size=small", f"data.root={trained / 'data'}",
            "data.num_workers=0", "device=cpu"]
    proc = run(*base, f"out_dir={trained / 'bad1'}", f"data.val_root={trained / 'nowhere'}", check=False)
    assert proc.returncode == 2 and "data.val_root" in proc.stderr and "does not exist" in proc.stderr
    assert not (trained / "bad1" / "model").exists()
    proc = run(*base, f"out_dir={trained / 'bad2'}", "train.precision=fp16", check=False)
    assert proc.returncode == 2 and "train.precision='fp16'" in proc.stderr and "Traceback" not in proc.stderr


def test_val_data_on_other_scenes_is_not_said(trained, tmp_path):
    """`val_training_scenes`, which rvn-train's warning names: none for rvn-gen split=val data, the shared scene for the
    training data itself."""
    from rvn_il.train.cli import compose
    from rvn_il.train.preflight import val_training_scenes
    from rvn_il.train.settings import complete_config

    run("-m", "rvn_data.gen.cli", "split=val", f"out_dir={tmp_path / 'val'}", "scenes.num_scenes=1",
        "trajectories_per_scene=1", "camera.width=64", "camera.height=64", "progress=false")
    cfg = complete_config(compose(["model=nomad_pointgoal", f"data.root={trained / 'data'}",
                                   f"data.val_root={tmp_path / 'val'}"]))
    assert val_training_scenes(cfg) == []
    cfg["data"]["val_root"] = str(trained / "data")
    assert val_training_scenes(cfg) == ["proc_train_0000"]

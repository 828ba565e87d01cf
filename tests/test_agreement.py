"""python -m rvn_il.eval.agreement on a dataset made by rvn-gen and a checkpoint made by rvn-train."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def run(*args, check=True):
    proc = subprocess.run([sys.executable, *args], capture_output=True, text=True, env=ENV, timeout=600)
    if check:
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc


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
    # the last-waypoint rule cannot reproduce every turn even from the true future
    last = run("-m", "rvn_il.eval.agreement", str(trained / "run"), str(trained / "data"), "--waypoint-index", "-1")
    assert "adapter ceiling 1.000" not in last.stdout
    # vote over NoMaD's samples: the same frames, scored as rvn-eval's policy.aggregate=vote
    vote = trained / "vote.json"
    run("-m", "rvn_il.eval.agreement", str(trained / "run"), str(trained / "data"), "--num-samples", "4",
        "--aggregate", "vote", "--json", str(vote))
    assert json.loads(vote.read_text())["policy"]["steps"] == frames


def test_agreement_bad_input_is_one_line(trained):
    proc = run("-m", "rvn_il.eval.agreement", str(trained / "run"), str(trained), "--split", "test", check=False)
    assert proc.returncode == 2 and "data_splits" in proc.stderr and "Traceback" not in proc.stderr
    proc = run("-m", "rvn_il.eval.agreement", str(trained / "run"), str(trained / "data"), "--aggregate", "mean", check=False)
    assert proc.returncode == 2 and "aggregate='mean'" in proc.stderr and "Traceback" not in proc.stderr
    proc = run("-m", "rvn_il.eval.agreement", str(trained / "data"), str(trained / "data"), check=False)
    assert proc.returncode == 2 and "not an rvn-train checkpoint directory" in proc.stderr

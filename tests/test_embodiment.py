"""The embodiment record (rvn_data/embodiment.py) through the CLIs: rvn-gen's data → rvn-train's checkpoint
(the data's robot and camera; an agent.* given on the command line announced and recorded) → rvn-eval, which
refuses another camera or d_step with one line before any episode, or runs it with embodiment_mismatch=allow
and records the difference; rvn-rl refuses a camera size other than env.size; a camera off the robot (above its
cylinder, under the floor, outside its footprint), and a navmesh not built for the robot, are refused by rvn-gen,
rvn-eval and rvn-rl; rvn-train refuses negatives as a model's data and expert data as NoMaD_n's."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import pytest
import yaml

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs

ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
TRAIN = ["model=nomad_pointgoal", "model.size=small", "train.batch_size=4", "train.max_steps=1", "data.num_workers=0",
         "device=cpu"]
EVAL = ["split=val", "episodes.num_scenes=1", "episodes.per_scene=1", "episodes.n_goals=1", "env.t_max=20",
        "progress=false", "camera.width=32", "camera.height=32"]


def cli(module: str, *args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *args], capture_output=True, text=True, env=ENV, timeout=600,
                          cwd=cwd)


def ok(proc: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc


def one_line_error(proc: subprocess.CompletedProcess) -> str:
    assert proc.returncode == 2, proc.stderr[-3000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    return lines[0]


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    base = tmp_path_factory.mktemp("embodiment")
    ok(cli("rvn_data.gen.cli", "split=train", "scenes.num_scenes=1", "trajectories_per_scene=2", "camera.width=32",
           "camera.height=32", "camera.hfov_deg=100", "dataset.train_fraction=1.0", "progress=false",
           f"out_dir={base / 'data'}"))
    ok(cli("rvn_il.train.cli", *TRAIN, f"data.root={base / 'data'}", f"out_dir={base / 'ckpt'}"))
    return base


def test_checkpoint_carries_the_datas_robot_and_camera(trained):
    cfg = yaml.safe_load((trained / "ckpt" / "config.yaml").read_text())
    fx = 16 / math.tan(math.radians(50))  # the intrinsics as the camera resolves them
    assert cfg["embodiment"]["camera"] == pytest.approx({"width": 32, "height": 32, "hfov_deg": 100.0, "h_camera": 0.6,
                                                         "pitch_deg": 0.0, "forward_offset": 0.0, "fx": fx, "fy": fx,
                                                         "cx": 16.0, "cy": 16.0})
    assert cfg["embodiment"]["agent"] == {"r_robot": 0.18, "h_robot": 1.0, "d_step": 0.25, "theta_step_deg": 30.0}
    assert cfg["embodiment"]["expert"]["margin"] > 0 and "overrides" not in cfg["embodiment"]
    assert cfg["agent"]["d_step"] == 0.25  # the policy's control: the data's robot


def test_an_agent_setting_given_to_rvn_train_is_announced_and_recorded(trained):
    proc = ok(cli("rvn_il.train.cli", *TRAIN, f"data.root={trained / 'data'}", f"out_dir={trained / 'ckpt_d30'}",
                  "agent.d_step=0.3"))
    assert "agent.d_step=0.3 overrides the data's 0.25" in proc.stdout + proc.stderr
    cfg = yaml.safe_load((trained / "ckpt_d30" / "config.yaml").read_text())
    assert cfg["agent"]["d_step"] == 0.3 and cfg["embodiment"]["agent"]["d_step"] == 0.3
    assert cfg["embodiment"]["overrides"] == [{"setting": "agent.d_step", "data": 0.25, "given": 0.3}]


def test_rvn_eval_refuses_another_camera_or_step_before_any_episode(trained, tmp_path):
    ckpt = trained / "ckpt"
    for setting, trained_value in (("camera.hfov_deg=90", "100"), ("agent.d_step=0.3", "0.25"),
                                   ("camera.width=48", "32"), ("camera.forward_offset=0.1", "0"),
                                   ("camera.fx=20", "13.4256")):
        out = tmp_path / setting.replace("=", "_")
        camera = [] if setting.startswith("camera.hfov_deg") else ["camera.hfov_deg=100"]  # only `setting` differs
        base = [o for o in EVAL if o.split("=")[0] != setting.split("=")[0]]
        line = one_line_error(cli("rvn_data.benchmark.cli", *base, "policy=checkpoint", f"policy.checkpoint_path={ckpt}",
                                  f"episodes.dir={tmp_path / 'episodes'}", f"out_dir={out}", *camera, setting, cwd=tmp_path))
        key, value = setting.split("=")
        assert f"{key}={value} (trained: {trained_value})" in line and f"run with {key}={trained_value}" in line, line
        assert "embodiment_mismatch=allow" in line and str(ckpt) in line
        assert not out.exists() and not (tmp_path / "episodes").exists()  # nothing written


def test_rvn_eval_runs_a_mismatch_it_is_allowed_and_records_it(trained, tmp_path):
    out = tmp_path / "allowed"
    proc = ok(cli("rvn_data.benchmark.cli", *EVAL, "policy=checkpoint", f"policy.checkpoint_path={trained / 'ckpt'}",
                  f"episodes.dir={tmp_path / 'episodes'}", f"out_dir={out}", "embodiment_mismatch=allow", cwd=tmp_path))
    assert "camera.hfov_deg=90 (trained: 100)" in proc.stderr and "embodiment_mismatch=allow" in proc.stderr
    diff = [{"setting": "camera.hfov_deg", "trained": 100.0, "here": 90.0}]
    assert json.loads((out / "metrics.json").read_text())["embodiment_mismatch"] == diff
    assert json.loads((out / "run.json").read_text())["embodiment_mismatch"] == diff
    # the matching camera: nothing to note, nothing recorded
    same = tmp_path / "same"
    proc = ok(cli("rvn_data.benchmark.cli", *EVAL, "policy=checkpoint", f"policy.checkpoint_path={trained / 'ckpt'}",
                  f"episodes.dir={tmp_path / 'episodes'}", f"out_dir={same}", "camera.hfov_deg=100", cwd=tmp_path))
    assert "embodiment" not in proc.stderr and "embodiment_mismatch" not in json.loads((same / "metrics.json").read_text())
    bad = cli("rvn_data.benchmark.cli", *EVAL, "policy=checkpoint", f"policy.checkpoint_path={trained / 'ckpt'}",
              f"out_dir={tmp_path / 'bad'}", "embodiment_mismatch=warn", cwd=tmp_path)
    assert "embodiment_mismatch='warn'; choose one of error, allow" in one_line_error(bad)


def test_rvn_rl_refuses_a_camera_size_other_than_env_size(tmp_path):
    line = one_line_error(cli("rvn_rl.cli", "env.size=32", "camera.width=48", f"out_dir={tmp_path / 'rl'}"))
    assert "camera.width=48 differs from env.size=32" in line and "set env.size=48" in line
    assert not (tmp_path / "rl").exists()


@pytest.mark.parametrize("module, settings, words", [
    ("rvn_data.gen.cli", ["camera.h_camera=3.0"], ["camera.h_camera=3 m", "above the robot's top (agent.h_robot=1 m)"]),
    ("rvn_data.gen.cli", ["camera.h_camera=0"], ["camera.h_camera=0 m", "at or below the floor"]),
    ("rvn_data.benchmark.cli", ["policy=random", "camera.forward_offset=-0.3"],
     ["camera.forward_offset=-0.3 m", "outside the robot (agent.r_robot=0.18 m)"]),
    ("rvn_rl.cli", ["agent.h_robot=0.5"], ["camera.h_camera=0.6 m", "above the robot's top (agent.h_robot=0.5 m)"]),
    ("rvn_data.gen.cli", ["navmesh.agent_height=0.3"], ["navmesh.agent_height=0.3 is below agent.h_robot=1"]),
    ("rvn_data.benchmark.cli", ["policy=random", "navmesh.agent_radius=0.1"],
     ["navmesh.agent_radius=0.1 differs from agent.r_robot=0.18"]),
    ("rvn_rl.cli", ["navmesh.agent_height=0.5"], ["navmesh.agent_height=0.5 is below agent.h_robot=1"]),
])
def test_a_camera_or_navmesh_not_the_robots_is_refused_before_anything_is_written(tmp_path, module, settings, words):
    """rvn-gen, rvn-eval and rvn-rl: a camera above the robot's cylinder, under the floor or outside its footprint
    sees through what the robot collides with (rvn-gen wrote a ceiling seen from above as ok frames with
    camera.h_camera=3.0), and a navmesh built lower than the robot lets it under tables (rvn-gen wrote ok trajectories
    with navmesh.agent_height=0.3): one line naming the settings, nothing written."""
    line = one_line_error(cli(module, *settings, f"out_dir={tmp_path / 'out'}"))
    assert all(w in line for w in words), line
    assert not (tmp_path / "out").exists()


def test_a_taller_robot_carries_a_higher_camera(tmp_path):
    """agent.h_robot raised to the camera's mount: rvn-gen runs with the camera at 1.5 m (its navmesh follows the
    robot's height, conf/navmesh/default.yaml)."""
    ok(cli("rvn_data.gen.cli", "agent.h_robot=2.0", "camera.h_camera=1.5", "scenes.num_scenes=1",
           "trajectories_per_scene=1", "camera.width=32", "camera.height=32", "progress=false",
           f"out_dir={tmp_path / 'data'}"))
    meta = json.loads(next((tmp_path / "data").glob("*/rvn_meta.json")).read_text())
    assert meta["settings"]["camera"]["h_camera"] == 1.5 and meta["settings"]["agent"]["h_robot"] == 2.0


def test_rvn_train_refuses_negatives_made_with_another_camera(trained):
    ok(cli("rvn_data.gen.cli", "dataset=negative", "split=train", "scenes.num_scenes=1", "trajectories_per_scene=1",
           "camera.width=32", "camera.height=32", "dataset.train_fraction=1.0", "progress=false",
           f"out_dir={trained / 'negative_hfov90'}"))
    out = trained / "neg"
    train = [o for o in TRAIN if not o.startswith("model=")]
    line = one_line_error(cli("rvn_il.train.cli", *train, "model=nomad_neg", f"data.root={trained / 'data'}",
                              f"data.negative_root={trained / 'negative_hfov90'}", f"out_dir={out}"))
    assert f"data.negative_root={trained / 'negative_hfov90'} was made with camera.hfov_deg=90" in line, line
    assert f"data.root={trained / 'data'} with 100" in line and not out.exists()


def test_rvn_train_refuses_a_dataset_of_the_other_kind(trained):
    """rvn-gen's negatives (each ends in a collision) as a model's data.root, or its expert data as NoMaD_n's
    data.negative_root: one line naming the setting, nothing written (rvn-train trained NoMaD-PointGoal on negatives
    without a word before)."""
    ok(cli("rvn_data.gen.cli", "dataset=negative", "split=train", "scenes.num_scenes=1", "trajectories_per_scene=1",
           "camera.width=32", "camera.height=32", "camera.hfov_deg=100", "dataset.train_fraction=1.0",
           "progress=false", f"out_dir={trained / 'negative_hfov100'}"))
    expert, negative, out = trained / "data", trained / "negative_hfov100", trained / "kinds"
    line = one_line_error(cli("rvn_il.train.cli", *TRAIN, f"data.root={negative}", f"out_dir={out}"))
    assert f"data.root={negative} holds negative trajectories" in line and "model=nomad_pointgoal" in line, line
    train = [o for o in TRAIN if not o.startswith("model=")]
    line = one_line_error(cli("rvn_il.train.cli", *train, "model=nomad_neg", f"data.root={expert}",
                              f"data.negative_root={expert}", f"out_dir={out}"))
    assert f"data.negative_root={expert} holds expert trajectories" in line, line
    assert not out.exists()


def test_rvn_eval_names_evaluated_scenes_the_model_trained_on(trained, tmp_path):
    """rvn-eval on scenes in the checkpoint's training data (its stats.json's dataset, whose manifest.json lists the
    scenes of its GNM train split): a note naming them, metrics.json's ``trained_scenes`` and the report's warning. On
    the val scenes, which the data does not hold: nothing. A training folder without a manifest is named unchecked."""
    from rvn_data.benchmark.runs import find_runs, provenance_note
    from rvn_data.benchmark.trained_scenes import trained_scenes_evaluated

    data = str((trained / "data").resolve())
    out = tmp_path / "on_train"
    base = [o for o in EVAL if not o.startswith("split=")]
    proc = ok(cli("rvn_data.benchmark.cli", *base, "split=train", "camera.hfov_deg=100", "policy=checkpoint",
                  f"policy.checkpoint_path={trained / 'ckpt'}", f"episodes.dir={tmp_path / 'episodes'}",
                  f"out_dir={out}", "method=NoMaD", cwd=tmp_path))
    assert "policy 'NoMaD' trained on 1 of the 1 evaluated scenes (proc_train_0000; matched by name in what it " \
           f"trained on: {data}): this row is not a held-out figure" in proc.stderr, proc.stderr
    record = json.loads((out / "metrics.json").read_text())["trained_scenes"]
    assert record == {"sources": [data], "scenes": ["proc_train_0000"], "evaluated": 1}
    assert "evaluated on scenes the model trained on (not held-out figures): NoMaD (1 of 1 scenes)" in \
        provenance_note(find_runs([out]))
    held_out = tmp_path / "on_val"
    proc = ok(cli("rvn_data.benchmark.cli", *EVAL, "camera.hfov_deg=100", "policy=checkpoint",
                  f"policy.checkpoint_path={trained / 'ckpt'}", f"episodes.dir={tmp_path / 'episodes'}",
                  f"out_dir={held_out}", cwd=tmp_path))
    assert "trained on" not in proc.stderr and "trained_scenes" not in json.loads((held_out / "metrics.json").read_text())
    assert "trained on" not in provenance_note(find_runs([held_out]))
    elsewhere = str(tmp_path / "on_another_machine")
    assert trained_scenes_evaluated([elsewhere, data], ["procedural:train/0", "procedural:train/1"]) == {
        "sources": [data], "scenes": ["proc_train_0000"], "evaluated": 2, "unchecked": [elsewhere]}
    assert trained_scenes_evaluated([elsewhere], ["procedural:train/0"]) is None
    assert trained_scenes_evaluated(None, ["procedural:train/0"]) is None


@pytest.mark.parametrize("camera, hfov", [({"width": 64, "height": 48, "hfov_deg": 100.0}, 100.0),
                                          ({"width": 64, "height": 48, "hfov_deg": 90.0, "fx": 20.0}, 116.0),
                                          ({"width": 64, "height": 48, "hfov_deg": 90.0, "fy": 16.0}, 126.9)])
def test_recorded_hfov_is_the_cameras_as_it_resolves_it(tmp_path, camera, hfov):
    """fx (or fy alone, square pixels) overrides hfov_deg: the swept depth veto's field of view is the image's."""
    from rvn_il.data import recorded_hfov

    (tmp_path / "t0").mkdir()
    (tmp_path / "t0" / "rvn_meta.json").write_text(json.dumps({"settings": {"camera": camera}}))
    assert recorded_hfov(tmp_path, "t0") == pytest.approx(hfov, abs=0.05)
    assert recorded_hfov(tmp_path, "missing") is None

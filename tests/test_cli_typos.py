"""Issue 35 items 2 and 3: a typo never runs. Every Hydra command (rvn-gen, rvn-eval, rvn-train, rvn-rl, the
depth network's trainer) refuses a key that is not a setting, with or without Hydra's ``+``, a value of the
wrong type and an unknown group option, in one line that names the setting and its nearest valid ones,
with exit status 2, before anything is written; rvn-gen checks every setting before its first scene, and a
run that failed on every scene does not block the corrected command."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
MODULES = {"rvn-gen": "rvn_data.gen.cli", "rvn-eval": "rvn_data.benchmark.cli", "rvn-train": "rvn_il.train.cli",
           "rvn-rl": "rvn_rl.cli", "rvn_rl.depth.cli": "rvn_rl.depth.cli"}


def run(prog: str, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", MODULES[prog], *args], capture_output=True, text=True, env=ENV,
                          cwd=cwd, timeout=300)


@pytest.mark.parametrize("prog, args, line", [
    # the cases: Hydra's advice "+key" made each of them run (or print a traceback)
    ("rvn-gen", ["+trajectories_per_scen=4"], "trajectories_per_scen is not a setting of rvn-gen; nearest: trajectories_per_scene"),
    ("rvn-rl", ["+train.total_step=512"], "train.total_step is not a setting of rvn-rl; nearest: train.total_steps"),
    ("rvn-train", ["+train.max_step=5"], "train.max_step is not a setting of rvn-train; nearest: train.max_steps"),
    ("rvn-eval", ["+episodes.num_scene=2"], "episodes.num_scene is not a setting of rvn-eval; nearest: episodes.num_scenes"),
    ("rvn_rl.depth.cli", ["train.step=3"], "train.step is not a setting of rvn_rl.depth.cli; nearest: train.steps"),
    # without +, in a multirun sweep, a wrong type (in a schema; in rvn-eval's policy group, which has none), an unknown
    # group option, bad syntax
    ("rvn-gen", ["-m", "seed=1,2", "dataset.margn=0.3"], "dataset.margn is not a setting of rvn-gen; nearest: dataset.margin"),
    ("rvn-rl", ["ppo.lr=abc"], "ppo.lr=abc: Value 'abc' of type 'str' could not be converted to Float"),
    ("rvn_rl.depth.cli", ["train.lr=abc"], "train.lr=abc: Value 'abc' of type 'str' could not be converted to Float"),
    ("rvn-eval", ["policy=oracle", "policy.turn_cost=abc"], "policy.turn_cost='abc': give a number (default 0.01)"),
    ("rvn-eval", ["policy=oracle", "policy.replan_after=-1"], "policy 'oracle': policy.replan_after=-1: must be a whole number >= 0"),
    ("rvn-eval", ["policy=oracle", "policy.replan_after=1.5"], "policy.replan_after=1.5: must be a whole number >= 0"),
    ("rvn-eval", ["policy=oracle", "+policy.replan_nodes=abc"], "policy.replan_nodes='abc': must be a whole number > 0"),
    ("rvn-eval", ["policy=orcle"], "policy=orcle is not an option; choose one of checkpoint, goal_follower, oracle"),
    ("rvn-train", ["x=[1"], "cannot read the override 'x=[1'"),
    ("rvn-rl", ["out_dir="], "out_dir= is empty: give a folder or file"),  # would write into the current folder
])
def test_typo_is_one_line_and_writes_nothing(tmp_path, prog, args, line):
    proc = run(prog, f"out_dir={tmp_path / 'out'}", *args, cwd=tmp_path)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and lines == [f"{prog}: error: {lines[0].split(': error: ', 1)[1]}"], proc.stderr[-3000:]
    assert line in lines[0] and "Traceback" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no out_dir, no runs/, no outputs/, no .hydra


def test_open_policy_group_checks_its_own_keys(tmp_path):
    """rvn-eval's policy.* settings are the policy class's keyword arguments: +policy.<typo> names the nearest."""
    proc = run("rvn-eval", "policy=random", "+policy.sed=1", f"out_dir={tmp_path / 'out'}", cwd=tmp_path)
    assert proc.returncode == 2 and "policy.* settings: seed, probs (nearest: seed)" in proc.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_gen_checks_settings_before_its_first_scene_and_a_failed_run_does_not_block(tmp_path):
    out = tmp_path / "o"
    tiny = ["scenes.num_scenes=1", "trajectories_per_scene=1", "progress=false", f"out_dir={out}"]
    for bad, words in (("camera.width=-5", "camera setting width=-5 must be a positive integer"),
                       ("renderer.backend=foo", "renderer.backend='foo'"),
                       ("scenes.first_scene=900", "scenes.first_scene=900 is past the last scene"),
                       ("scenes.num_scenes=0", "no scenes to generate: scenes.first_scene=0 and scenes.num_scenes=0")):
        proc = run("rvn-gen", *tiny, bad, cwd=tmp_path)
        assert proc.returncode == 2 and words in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert not out.exists()
    # a setting only a scene can refuse (the robot fits nowhere): every scene fails, exit 1, no maps claimed ...
    failed = run("rvn-gen", *tiny, "agent.r_robot=3", cwd=tmp_path)
    assert failed.returncode == 1 and "no navigable island" in failed.stdout and "maps/*.png" not in failed.stdout
    # ... and the corrected command is not refused for the failed run's settings
    fixed = run("rvn-gen", *tiny, "camera.width=32", "camera.height=32", cwd=tmp_path)
    assert fixed.returncode == 0, fixed.stderr[-2000:]
    assert json.loads((out / ".rvn" / "settings.json").read_text())["agent"]["r_robot"] == 0.18
    assert "maps/*.png" in fixed.stdout and list((out / "maps").glob("*.png"))

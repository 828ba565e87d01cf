"""A new user's first commands (issue 18 items 1, 2, 7), through the console scripts: default
output folders that do not collide, every path checked before any work, one line and exit
status 2 for bad input with nothing written, 1 for a run that failed."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from rvn_il.data.synthetic import write_synthetic_gnm

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
TINY_GEN = ["scenes.num_scenes=1", "trajectories_per_scene=1", "camera.width=32", "camera.height=32",
            "progress=false"]
SMALL_EVAL = ["split=val", "episodes.num_scenes=1", "episodes.per_scene=1", "camera.width=32", "camera.height=32",
              "progress=false"]


def cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(list(args), capture_output=True, text=True, env=ENV, cwd=cwd, timeout=600)


def one_line_bad_input(proc: subprocess.CompletedProcess, *words: str) -> str:
    """Exit status 2, one line on stderr naming ``words``, no traceback; returns the line."""
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr and all(w in lines[0] for w in words), lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def gnm(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("gnm")
    write_synthetic_gnm(base / "expert", 2, 24, image_size=64, seed=0)
    return base


def test_gen_readme_examples_do_not_collide(tmp_path):
    """`rvn-gen`, then `rvn-gen dataset.perturb_prob=0.1`: refused with a folder to use instead,
    which then works; `dataset=negative` has its own default folder."""
    assert cli("rvn-gen", *TINY_GEN, cwd=tmp_path).returncode == 0
    line = one_line_bad_input(cli("rvn-gen", "dataset.perturb_prob=0.1", *TINY_GEN, cwd=tmp_path),
                              "holds a dataset", "dataset.perturb_prob")
    other = tmp_path / "outputs" / "rvn_expert_perturb_prob0.1"
    assert f"out_dir={other}" in line and not other.exists()
    assert cli("rvn-gen", "dataset.perturb_prob=0.1", f"out_dir={other}", *TINY_GEN, cwd=tmp_path).returncode == 0
    assert cli("rvn-gen", "dataset=negative", *TINY_GEN, cwd=tmp_path).returncode == 0
    assert sorted(p.name for p in (tmp_path / "outputs").iterdir()) == [
        "rvn_expert", "rvn_expert_perturb_prob0.1", "rvn_negative"]


def test_gen_bad_paths_are_one_line(tmp_path):
    blob = tmp_path / "scan.bin"
    blob.write_bytes(b"glTF\xdf\xff\x00\x01")
    one_line_bad_input(cli("rvn-gen", "scenes=mesh_dir", f"scenes.root={blob}", f"out_dir={tmp_path / 'o'}", *TINY_GEN,
                           cwd=tmp_path), f"scenes.root={blob}", "neither a text file")
    typo = cli("rvn-gen", "camera.widht=3", f"out_dir={tmp_path / 'o'}", cwd=tmp_path)  # Hydra's own message
    assert typo.returncode == 2 and "widht" in typo.stderr
    assert not (tmp_path / "o").exists()


def test_eval_default_out_dir_names_the_method_or_checkpoint(tmp_path):
    def out_dir(*args):
        proc = cli("rvn-eval", *args, "--cfg", "job", "--resolve", cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        return next(ln.split(": ", 1)[1] for ln in proc.stdout.splitlines() if ln.startswith("out_dir:"))

    ckpt = "policy.checkpoint_path=runs/train/nomad_neg"
    assert out_dir("policy=checkpoint", ckpt, "method=NoMaD-Neg") == "runs/eval/val/NoMaD-Neg"
    assert out_dir("policy=checkpoint", ckpt) == "runs/eval/val/nomad_neg"
    assert out_dir("policy=checkpoint", "policy.checkpoint_path=runs/train/nomad/", "split=test") == "runs/eval/test/nomad"
    # a kept checkpoint other than the latest (rvn-train's policy.step, rvn-rl's policy.env_steps): a folder of its own
    assert out_dir("policy=checkpoint", "policy.checkpoint_path=runs/train/nomad", "+policy.step=9000") == \
        "runs/eval/val/nomad_ckpt9000"
    assert out_dir("policy=checkpoint", "policy.checkpoint_path=runs/rl/ppo", "+policy.env_steps=399360") == \
        "runs/eval/val/ppo_ckpt399360"
    assert out_dir("policy=checkpoint", ckpt, "+policy.step=9000", "method=NoMaD-Neg ckpt9000") == \
        "runs/eval/val/NoMaD-Neg_ckpt9000"
    assert out_dir("policy=random") == "runs/eval/val/random"
    assert out_dir("policy=random", "method=Goal follower") == "runs/eval/val/Goal_follower"
    # the shards of a multirun over episodes.first_scene: a folder each (they wrote into one before)
    assert out_dir("policy=random", "episodes.first_scene=0") == "runs/eval/val/random"
    assert out_dir("policy=random", "episodes.first_scene=5", "method=Random") == "runs/eval/val/Random_first_scene5"


def test_eval_checks_paths_before_any_episode(tmp_path):
    """A checkpoint that does not exist, an out_dir that cannot be written, a scene root that is
    no scene: one line, status 2, no episode generated, no out_dir, no .hydra/, no log."""
    out, episodes = tmp_path / "e", tmp_path / "episodes"
    common = [*SMALL_EVAL, f"episodes.dir={episodes}"]
    missing = tmp_path / "runs" / "train" / "nope"
    one_line_bad_input(cli("rvn-eval", "policy=checkpoint", f"policy.checkpoint_path={missing}", f"out_dir={out}",
                           *common, cwd=tmp_path), f"policy.checkpoint_path={missing} does not exist")
    blocker = tmp_path / "file"
    blocker.write_text("x")
    one_line_bad_input(cli("rvn-eval", "policy=random", f"out_dir={blocker}/sub", *common, cwd=tmp_path),
                       f"out_dir={blocker}/sub", "cannot write there")
    one_line_bad_input(cli("rvn-eval", "policy=random", "scenes=mesh_dir", f"scenes.root={blocker}", f"out_dir={out}",
                           *common, cwd=tmp_path), "scene list")
    one_line_bad_input(cli("rvn-eval", "policy=random", "workers=-1", f"out_dir={out}", *common, cwd=tmp_path),
                       "workers=-1 must be a positive integer")
    typo = cli("rvn-eval", "policy=random", "episodes.per_scne=1", f"out_dir={out}", cwd=tmp_path)
    assert typo.returncode == 2 and "per_scne" in typo.stderr
    assert not out.exists() and not episodes.exists() and not (tmp_path / ".hydra").exists()
    assert not list(tmp_path.glob("*.log"))


def test_eval_first_scene_past_the_split_is_one_readable_line(tmp_path):
    """Issue 35: episodes.first_scene=60 on the 50 val scenes printed a raw settings dict; now one
    line names the setting, the split's size and the range to choose from."""
    out, episodes = tmp_path / "e", tmp_path / "episodes"
    line = one_line_bad_input(cli("rvn-eval", "policy=random", "episodes.first_scene=60", f"out_dir={out}",
                                  f"episodes.dir={episodes}", "progress=false", cwd=tmp_path))
    assert line == ("rvn-eval: error: episodes.first_scene=60 is past the last scene: the val split has 50 scenes "
                    "(indices 0 to 49); choose episodes.first_scene from 0 to 49")
    assert not out.exists() and not episodes.exists()


def test_train_checks_every_path_before_training(gnm, tmp_path):
    """nomad_neg: a missing data.negative_root is named before NoMaD_e is trained; a missing
    data.root, train.expert_from, an unwritable out_dir and a typo'd key: one line, status 2,
    nothing written."""
    out = tmp_path / "t"
    common = ["model.size=small", "train.max_steps=1", "data.num_workers=0", f"out_dir={out}"]
    missing = tmp_path / "no_negative"
    one_line_bad_input(cli("rvn-train", "model=nomad_neg", f"data.root={gnm / 'expert'}",
                           f"data.negative_root={missing}", *common, cwd=tmp_path),
                       f"data.negative_root={missing} does not exist", "dataset=negative")
    one_line_bad_input(cli("rvn-train", "model=vint_pointgoal", f"data.root={missing}", *common, cwd=tmp_path),
                       f"data.root={missing} does not exist")
    one_line_bad_input(cli("rvn-train", "model=nomad_neg", f"data.root={gnm / 'expert'}",
                           f"data.negative_root={gnm / 'expert'}", f"train.expert_from={missing}", *common, cwd=tmp_path),
                       f"train.expert_from={missing} does not exist")
    blocker = tmp_path / "file"
    blocker.write_text("x")
    one_line_bad_input(cli("rvn-train", "model=vint_pointgoal", f"data.root={gnm / 'expert'}", *common,
                           f"out_dir={blocker}/sub", cwd=tmp_path), f"out_dir={blocker}/sub", "cannot write there")
    typo = cli("rvn-train", "train.bach_size=4", *common, cwd=tmp_path)  # Hydra's message, status 2
    assert typo.returncode == 2 and "bach_size" in typo.stderr
    assert not out.exists() and not (tmp_path / ".hydra").exists() and not list(tmp_path.glob("*.log"))


def test_scene_unwritable_output_is_one_line(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    for command, target in (("map", blocker / "map.png"), ("map", tmp_path), ("views", blocker / "views"),
                            ("navmesh", blocker / "x.navmesh")):
        line = one_line_bad_input(cli("rvn-scene", command, "-o", str(target), cwd=tmp_path), f"-o {target}")
        assert "UnboundLocalError" not in line
    if Path("/proc/self").is_dir():  # a folder no one can create files in, root included
        one_line_bad_input(cli("rvn-scene", "map", "-o", "/proc/rvn_map.png", cwd=tmp_path), "cannot write there")

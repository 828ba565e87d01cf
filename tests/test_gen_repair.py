"""Nothing silently wrong with a damaged dataset: rvn-gen rerun into the same out_dir checks
every trajectory it resumes and redoes what is missing or damaged (same bytes as the first run,
one line per scene saying what); rvn-train refuses a damaged dataset with one line naming the
trajectory and the rvn-gen command that redoes it, before it writes anything."""
from __future__ import annotations

import hashlib
import json
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

TINY = ["scenes.num_scenes=2", "trajectories_per_scene=2", "camera.width=32", "camera.height=32",
        "dataset.save_depth=true", "dataset.depth_size=4", "progress=false"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def run(module: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *args], capture_output=True, text=True, env=ENV, timeout=600)


def dataset_bytes(root: Path) -> dict[str, str]:
    """sha256 of every dataset file: visible paths plus the scene records (run bookkeeping in
    .rvn/ such as the recorded command excluded)."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root).as_posix()
        if p.is_file() and (not any(part.startswith(".") for part in rel.split("/")) or rel.startswith(".rvn/scenes/")):
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


DAMAGE = {  # how -> (trajectory, what rvn-gen and rvn-train say about it)
    "image deleted": ("proc_train_0000_expert_0000", "5.jpg missing", lambda d: (d / "5.jpg").unlink()),
    "image truncated": ("proc_train_0000_expert_0001", "7.jpg truncated", lambda d: truncate(d / "7.jpg")),
    "folder deleted": ("proc_train_0001_expert_0000", "folder missing", shutil.rmtree),
    "depth truncated": ("proc_train_0001_expert_0001", "depth.npy truncated", lambda d: truncate(d / "depth.npy")),
    "pose file unreadable": ("proc_train_0001_expert_0000", "traj_data.pkl unreadable",
                             lambda d: (d / "traj_data.pkl").write_bytes(b"not a pickle")),
}


def damaged_copy(made: Path, to: Path, *hows: str) -> Path:
    shutil.copytree(made, to)
    for how in hows:
        name, _, act = DAMAGE[how]
        act(to / name)
    return to


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> Path:
    """An undamaged tiny dataset (2 scenes x 2 trajectories, 32x32 frames, depth sidecars)."""
    out = tmp_path_factory.mktemp("repair") / "made"
    proc = run("rvn_data.gen.cli", f"out_dir={out}", *TINY)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def test_rerun_redoes_damaged_trajectories_with_the_same_bytes(made, tmp_path):
    d = damaged_copy(made, tmp_path / "d", "image deleted", "image truncated", "folder deleted", "depth truncated")
    (d / ".rvn" / "scenes" / "proc_train_0000.json").unlink()  # scene 0 as an interrupted run leaves it: no record
    proc = run("rvn_data.gen.cli", f"out_dir={d}", *TINY)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    lines = [ln for ln in proc.stdout.splitlines() if " damaged (" in ln]
    assert lines == [
        "rvn-gen: proc_train_0000: 2 trajectories damaged (proc_train_0000_expert_0000: 5.jpg missing; "
        "proc_train_0000_expert_0001: 7.jpg truncated), redone",
        "rvn-gen: proc_train_0001: 2 trajectories damaged (proc_train_0001_expert_0000: folder missing; "
        "proc_train_0001_expert_0001: depth.npy truncated), redone"], proc.stdout
    assert dataset_bytes(d) == dataset_bytes(made)
    assert not any((d / ".rvn" / "tmp").iterdir())
    again = run("rvn_data.gen.cli", f"out_dir={d}", *TINY)  # whole now: nothing redone
    assert again.returncode == 0 and " damaged (" not in again.stdout and again.stdout.count("done before") == 2


def test_a_scene_record_left_empty_is_done_again(made, tmp_path):
    """A node that crashes after the rename, before the disk has the data, can leave a scene's record empty: it failed
    every rerun and every shard's splits (exit 2); the scene is now done again from its trajectories on disk."""
    d = tmp_path / "d"
    shutil.copytree(made, d)
    (d / ".rvn" / "scenes" / "proc_train_0001.json").write_text("")
    proc = run("rvn_data.gen.cli", f"out_dir={d}", *TINY)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert dataset_bytes(d) == dataset_bytes(made)


@pytest.mark.parametrize("how", ["image deleted", "image truncated", "folder deleted", "pose file unreadable"])
def test_train_refuses_a_damaged_dataset_naming_the_repair(made, tmp_path, how):
    d = damaged_copy(made, tmp_path / "d", how)
    name, problem, _ = DAMAGE[how]
    split = next(s for s in ("train", "test")
                 if name in (d / "data_splits" / "rvn_expert" / s / "traj_names.txt").read_text().split())
    out = tmp_path / "run"
    proc = run("rvn_il.train.cli", "model=vint_pointgoal", f"data.root={d}", f"data.split={split}", f"out_dir={out}",
               "model.size=small")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    command = shlex.join(["rvn-gen", f"out_dir={d.resolve()}", *TINY])
    assert lines[0].startswith(f"rvn-train: error: data.root={d}: trajectory {name}: {problem}")
    assert lines[0].endswith(f"; rerun the rvn-gen command that made {d.resolve()} (same out_dir) to redo it: {command}")
    assert not out.exists()
    if how == "folder deleted":  # the command it prints repairs the dataset
        argv = shlex.split(lines[0].rsplit(": ", 1)[1])
        assert argv[0] == "rvn-gen"
        assert run("rvn_data.gen.cli", *argv[1:]).returncode == 0
        assert dataset_bytes(d) == dataset_bytes(made)


def splits(d: Path) -> list[str]:
    return "".join((d / "data_splits" / "rvn_expert" / s / "traj_names.txt").read_text() for s in ("train", "test")).split()


def test_merge_writes_splits_of_what_is_on_disk(made, tmp_path):
    """mode=merge redoes nothing: a folder a record lists but the disk lacks is left out of the
    splits, named in the manifest and in a note with the command that redoes it."""
    d = damaged_copy(made, tmp_path / "d", "folder deleted")
    name = DAMAGE["folder deleted"][0]
    proc = run("rvn_data.gen.cli", f"out_dir={d}", *TINY, "mode=merge")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    command = shlex.join(["rvn-gen", f"out_dir={d.resolve()}", *TINY])
    assert (f"  note: 1 trajectory listed by the scene records is missing or damaged ({name}: folder missing) and left "
            f"out of the splits; rerun the rvn-gen command that made {d.resolve()} (same out_dir) to redo it: {command}"
            ) in proc.stdout.splitlines()
    assert name not in splits(d) and len(splits(d)) == 3
    assert json.loads((d / "manifest.json").read_text())["left_out_of_splits"] == {name: "folder missing"}


def test_damage_outside_the_scene_list_is_left_out_of_the_splits(made, tmp_path):
    """A rerun with fewer scenes checks the folders it keeps from earlier runs in full: a damaged
    one leaves the splits, with a note; a run with its scene in the list redoes it."""
    d = damaged_copy(made, tmp_path / "d", "image truncated", "depth truncated")  # scene 0 and scene 1
    fewer = ["scenes.first_scene=1", "scenes.num_scenes=1", *TINY[1:]]  # procedural:train/1 only
    proc = run("rvn_data.gen.cli", f"out_dir={d}", *fewer)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    name = DAMAGE["image truncated"][0]
    assert (f"  note: 1 trajectory listed by the scene records is missing or damaged ({name}: 7.jpg truncated) and left "
            f"out of the splits; rerun rvn-gen into {d.resolve()} with proc_train_0000's scene in its scene list to "
            "redo it") in proc.stdout.splitlines()
    assert " damaged (proc_train_0001_expert_0001: depth.npy truncated), redone" in proc.stdout
    assert name not in splits(d) and len(splits(d)) == 3
    assert run("rvn_data.gen.cli", f"out_dir={d}", *TINY).returncode == 0
    assert dataset_bytes(d) == dataset_bytes(made)


def test_shards_finalise_in_turn(made, tmp_path):
    """Shards that finish at once take turns writing the splits and manifest (a lock on .rvn/finalise.lock): side by
    side, one's train list could stand beside another's test list. While another holds the lock, finalising waits."""
    import fcntl
    import threading

    from rvn_data.dataset.finalise import finalise_dataset
    from rvn_data.dataset.settings import GenSettings
    from rvn_data.render.camera import CameraConfig

    d = tmp_path / "d"
    shutil.copytree(made, d)
    (d / "manifest.json").unlink()
    settings = GenSettings(save_depth=True, depth_size=4, camera=CameraConfig(width=32, height=32))
    done = []
    fd = os.open(d / ".rvn" / "finalise.lock", os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)  # another shard finalising
    worker = threading.Thread(target=lambda: done.append(finalise_dataset(d, settings, ["procedural:train/0",
                                                                                      "procedural:train/1"])))
    worker.start()
    worker.join(timeout=1.0)
    assert worker.is_alive() and not (d / "manifest.json").exists()  # it waits its turn
    os.close(fd)
    worker.join(timeout=60)
    assert done and done[0].written and dataset_bytes(d) == dataset_bytes(made)

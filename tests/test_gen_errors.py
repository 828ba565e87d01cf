"""rvn-gen on bad input: clear one-line errors naming the scene and setting, other scenes
finish, failures listed, non-zero exit, nothing half-written."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import trimesh
import pytest

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

TINY = ["trajectories_per_scene=1", "camera.width=32", "camera.height=32", "progress=false"]


def rvn_gen(*args):
    return subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", *args], capture_output=True, text=True,
                          timeout=600)


def assert_clean(out: Path):
    """No trajectory folder without its pickle, no leftovers in .rvn/tmp."""
    if out.exists():
        for p in out.iterdir():
            if p.is_dir() and not p.name.startswith(".") and p.name not in ("maps", "data_splits"):
                assert (p / "traj_data.pkl").is_file() and (p / "rvn_meta.json").is_file(), p
        tmp = out / ".rvn" / "tmp"
        assert not tmp.exists() or not any(tmp.iterdir())


def test_d_min_beyond_every_geodesic(tmp_path):
    out = tmp_path / "o"
    proc = rvn_gen(f"out_dir={out}", "scenes.num_scenes=1", "dataset.d_min=60", "dataset.d_max=70", *TINY)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "procedural:train/0" in proc.stdout and "d_min=60" in proc.stdout
    assert "Traceback" not in proc.stderr
    assert_clean(out)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["trajectories"] == 0 and list(manifest["scenes"]["failed"]) == ["procedural:train/0"]


def test_margin_that_closes_every_passage(tmp_path):
    out = tmp_path / "o"
    proc = rvn_gen(f"out_dir={out}", "scenes.num_scenes=1", "dataset.margin=0.9", "dataset.max_attempts=10", *TINY)
    assert proc.returncode == 1
    assert "procedural:train/0" in proc.stdout and "dataset.margin=0.9" in proc.stdout
    assert_clean(out)


def test_unwritable_out_dir(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    proc = rvn_gen(f"out_dir={blocker}/sub", "scenes.num_scenes=1", *TINY)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "out_dir=" in proc.stderr and "Traceback" not in proc.stderr


def test_bad_setting_names_it(tmp_path):
    proc = rvn_gen(f"out_dir={tmp_path / 'o'}", "dataset.d_min=9", "dataset.d_max=5", *TINY)
    assert proc.returncode == 2 and "dataset.d_min=9" in proc.stderr and "Traceback" not in proc.stderr


def test_bad_navmesh_setting_fails_before_any_scene(tmp_path):
    out = tmp_path / "o"
    proc = rvn_gen(f"out_dir={out}", "navmesh.profile=recast", *TINY)
    assert proc.returncode == 2 and "profile='recast'" in proc.stderr and "Traceback" not in proc.stderr
    assert proc.stderr.count("profile='recast'") == 1 and not out.exists()


def room_glb(path: Path) -> None:
    """An 8 x 3 m room with 2.5 m walls, y up."""
    parts = [trimesh.creation.box(extents=(8.0, 0.02, 3.0), transform=trimesh.transformations.translation_matrix((0, -0.01, 0)))]
    for ext, pos in [((8.2, 2.5, 0.1), (0, 1.25, 1.55)), ((8.2, 2.5, 0.1), (0, 1.25, -1.55)),
                     ((0.1, 2.5, 3.2), (4.05, 1.25, 0)), ((0.1, 2.5, 3.2), (-4.05, 1.25, 0)),
                     ((0.6, 0.7, 0.6), (1.0, 0.35, 0.3))]:
        parts.append(trimesh.creation.box(extents=ext, transform=trimesh.transformations.translation_matrix(pos)))
    mesh = trimesh.util.concatenate(parts)
    mesh.visual.vertex_colors = np.tile([180, 160, 140, 255], (len(mesh.vertices), 1)).astype(np.uint8)
    mesh.export(path)


def test_scene_that_fails_to_load_in_a_multi_scene_run(tmp_path):
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    room_glb(scenes / "room_a.glb")
    (scenes / "room_b.glb").write_bytes(b"this is not a GLB file")
    out = tmp_path / "o"
    proc = rvn_gen(f"out_dir={out}", "scenes=mesh_dir", f"scenes.root={scenes}", "scenes.num_scenes=null",
                   "dataset.d_min=2", "dataset.d_max=6", *TINY)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "FAILED scenes (1)" in proc.stdout and "room_b" in proc.stdout
    assert f"note: scenes.root={scenes} has no train/ folder, so split=train takes every mesh in it" in proc.stdout
    assert (out / "room_a_expert_0000" / "traj_data.pkl").is_file()
    assert not any(p.name.startswith("room_b") for p in out.iterdir())
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["trajectories"] == 1 and len(manifest["scenes"]["failed"]) == 1
    names = [(out / "data_splits" / "rvn_expert" / s / "traj_names.txt").read_text().split() for s in ("train", "test")]
    assert sorted(names[0] + names[1]) == ["room_a_expert_0000"]
    assert_clean(out)


def test_a_dataset_records_how_its_scenes_were_read(tmp_path):
    """scenes.up_axis / unit_scale / level make another scene of the same mesh: a rerun into the dataset with other
    values is refused naming the setting (it was taken, and its trajectories mixed with the others'); trajectories
    record them where not the defaults. A dataset begun by code that makes other trajectories from the same settings
    (rvn_data.dataset.settings.DATASET_VERSION; a record without one: version 1) is not resumed either."""
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    room_glb(scenes / "room_a.glb")
    out = tmp_path / "o"
    common = [f"out_dir={out}", "scenes=mesh_dir", f"scenes.root={scenes}", "scenes.num_scenes=null", "dataset.d_min=2",
              "dataset.d_max=6", *TINY]
    assert rvn_gen(*common, "scenes.level=true").returncode == 0
    settings = json.loads((out / ".rvn" / "settings.json").read_text())
    assert settings["scenes"] == {"up_axis": "y", "unit_scale": 1.0, "level": True}
    assert json.loads((out / "room_a_expert_0000" / "rvn_meta.json").read_text())["settings"]["scenes"]["level"] is True
    proc = rvn_gen(*common, "trajectories_per_scene=2")
    line = proc.stderr.strip().splitlines()[-1]
    assert proc.returncode == 2 and "was made with scenes.level=True but this run uses scenes.level=False" in line, line
    assert rvn_gen(*common, "scenes.level=true", "trajectories_per_scene=2").returncode == 0  # the same: resumed
    assert len(list(out.glob("room_a_expert_*"))) == 2
    from rvn_data.dataset.settings import DATASET_VERSION

    del settings["scenes"], settings["dataset_version"]  # as rvn-gen wrote it before 2026-12-05
    (out / ".rvn" / "settings.json").write_text(json.dumps(settings))
    proc = rvn_gen(*common, "scenes.level=true", "trajectories_per_scene=3")
    line = proc.stderr.strip().splitlines()[-1]
    assert proc.returncode == 2 and "holds a dataset of rvn-gen's dataset version 1" in line and f"makes version {DATASET_VERSION}" in line
    assert len(list(out.glob("room_a_expert_*"))) == 2
    assert_clean(out)


def test_the_writability_probe_leaves_another_shards_alone(tmp_path):
    """Shards on other nodes write into one dataset and may share a process id: the probe was named by it alone, so one
    shard could overwrite and remove another's probe, whose unlink then failed as 'cannot write there'."""
    import os

    from rvn_data.dataset.gnm_writer import GNMWriter
    from rvn_data.dataset.settings import GenSettings

    other = tmp_path / "o" / ".rvn" / f".probe{os.getpid()}"
    other.parent.mkdir(parents=True)
    other.write_bytes(b"another node's")
    GNMWriter.open(tmp_path / "o", GenSettings())
    assert other.read_bytes() == b"another node's"
    assert sorted(p.name for p in other.parent.iterdir()) == [other.name, "settings.json"]

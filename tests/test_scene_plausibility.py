"""Mesh files read with the wrong units or up axis are refused, naming the setting (rvn_data.scenes.plausibility).

The data: procedural apartments written as mesh files in metres, centimetres or millimetres, y-up or z-up, and the
shipped apartment, read right (levelled, or tilted up to 10 deg) and turned on its side; a floor tilted, not levelled,
is said (rvn-gen: among its summary's notes)."""
from __future__ import annotations

import json
import math
import os
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from rvn_data.scenes import SceneError, load_mesh_file
from rvn_data.scenes.procedural import make_apartment


def _mesh_file(path: Path, v: np.ndarray, f: np.ndarray, scale: float = 1.0, z_up: bool = False) -> Path:
    """(v, f), y-up metres, written to ``path`` in ``scale`` units of a metre, z-up if asked (file = (x, -z, y): what
    `mesh_file.Z_UP_TO_Y_UP` turns back)."""
    v = np.asarray(v, np.float64)
    if z_up:
        v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], 1)
    trimesh.Trimesh(v / scale, f, process=False).export(path)
    return path


def _apartment_file(tmp_path: Path, index: int = 0, **kw) -> Path:
    v, f = make_apartment("train", index).triangles()
    return _mesh_file(tmp_path / f"apartment_{index}.ply", v, f, **kw)


@pytest.mark.parametrize("index", range(12))
def test_an_apartment_read_right_passes_and_on_its_side_is_refused(tmp_path, index):
    y_up = _apartment_file(tmp_path, index)
    assert load_mesh_file(y_up).num_triangles > 0
    with pytest.raises(SceneError, match=r"read with scenes.up_axis=z stands on its side: .* Set scenes.up_axis=y"):
        load_mesh_file(y_up, up_axis="z")
    z_up = _apartment_file(tmp_path, index, z_up=True)
    assert load_mesh_file(z_up, up_axis="z").num_triangles > 0
    with pytest.raises(SceneError, match=r"read with scenes.up_axis=y stands on its side: .* Set scenes.up_axis=z"):
        load_mesh_file(z_up)


def test_wrong_units_name_the_unit_scale_that_makes_a_building(tmp_path):
    cm = _apartment_file(tmp_path, scale=0.01)
    with pytest.raises(SceneError) as err:
        load_mesh_file(cm)
    text = str(err.value)
    assert "read with scenes.unit_scale=1 spans " in text and "larger than an indoor scene" in text
    assert "as centimetres (scenes.unit_scale=0.01)" in text and "as inches (scenes.unit_scale=0.0254)" in text
    assert "millimetres" not in text  # 1 m across: not a room
    assert load_mesh_file(cm, unit_scale=0.01).num_triangles > 0
    metres = _apartment_file(tmp_path, index=1)  # read as millimetres: 12 mm across, no robot's island
    with pytest.raises(SceneError, match=r"read with scenes.unit_scale=0.001 spans 0.0\d+ x .* smaller than a room "
                       r"\(at least 1 m\). If scenes.unit_scale is wrong: as metres \(scenes.unit_scale=1\) "):
        load_mesh_file(metres, unit_scale=0.001)


def _tilted(v: np.ndarray, deg: float) -> np.ndarray:
    return np.asarray(v, np.float64) @ trimesh.transformations.rotation_matrix(math.radians(deg), [1, 0, 1])[:3, :3].T


@pytest.mark.parametrize("deg", [0, 3, 6, 10])
def test_the_shipped_apartment_tilted_read_right_passes_and_on_its_side_is_refused(dream_path, tmp_path, deg):
    v, f = load_mesh_file(dream_path).triangles()
    tilted = _mesh_file(tmp_path / "tilted.ply", _tilted(v, deg), f)
    assert load_mesh_file(tilted, level=True).num_triangles == len(f)
    turned = _mesh_file(tmp_path / "turned.ply", _tilted(v, deg), f, z_up=True)
    with pytest.raises(SceneError, match="Set scenes.up_axis=z"):
        load_mesh_file(turned, level=True)
    for path, up_axis in ((tilted, "y"), (turned, "z")):  # not levelled: the tilt is said from 1.5 deg
        with pytest.warns(UserWarning, match=f"tilted {deg}.0 deg") if deg else warnings.catch_warnings():
            if not deg:
                warnings.simplefilter("error")
            assert load_mesh_file(path, up_axis=up_axis).num_triangles == len(f)


def _gen(tmp_path: Path, mesh: Path, *overrides: str) -> subprocess.CompletedProcess:
    return subprocess.run(["rvn-gen", "scenes=mesh_dir", f"scenes.root={mesh}", f"out_dir={tmp_path / 'data'}",
                           "trajectories_per_scene=2", *overrides],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, "RVN_CACHE_DIR": str(tmp_path / "cache")})


def test_rvn_gen_names_the_units_then_the_up_axis_then_writes_the_scene(tmp_path):
    """A scan in millimetres, z-up, through rvn-gen: its scene fails naming scenes.unit_scale (before, rvn-gen built a
    kilometres-wide navmesh for minutes), then scenes.up_axis (before, it wrote trajectories along a wall), and with
    both set the same out_dir gets its trajectories."""
    mesh = _apartment_file(tmp_path, scale=0.001, z_up=True)
    first = _gen(tmp_path, mesh)
    assert first.returncode == 1 and "FAILED" in first.stdout + first.stderr
    assert "as millimetres (scenes.unit_scale=0.001)" in first.stdout + first.stderr
    manifest = json.loads((tmp_path / "data" / "manifest.json").read_text())
    assert "scenes.unit_scale=0.001" in manifest["scenes"]["failed"][str(mesh)] and manifest["frames"] == 0
    second = _gen(tmp_path, mesh, "scenes.unit_scale=0.001")
    assert second.returncode == 1 and "Set scenes.up_axis=z" in second.stdout + second.stderr
    third = _gen(tmp_path, mesh, "scenes.unit_scale=0.001", "scenes.up_axis=z")
    assert third.returncode == 0, third.stderr[-2000:]
    manifest = json.loads((tmp_path / "data" / "manifest.json").read_text())
    assert manifest["scenes"]["failed"] == {} and manifest["frames"] > 0
    assert len(list((tmp_path / "data").glob("apartment_0_expert_*"))) == 2


def test_rvn_eval_refuses_the_scene_and_its_corrected_rerun_takes_the_same_out_dir(tmp_path):
    """rvn-eval on the z-up scan read y-up: one line naming scenes.up_axis; its out_dir then holds a run.json of no
    episode, which no longer stops the corrected run there (a run with episodes and other settings still does:
    tests/test_eval.py)."""
    mesh = _apartment_file(tmp_path, z_up=True)
    out = tmp_path / "eval"

    def rvn_eval(*overrides: str) -> subprocess.CompletedProcess:
        return subprocess.run(["rvn-eval", "scenes=mesh_dir", f"scenes.root={mesh}", "policy=goal_follower",
                               f"out_dir={out}", "episodes.per_scene=2", "progress=false", *overrides],
                              capture_output=True, text=True, timeout=600,
                              env={**os.environ, "RVN_CACHE_DIR": str(tmp_path / "cache")})
    wrong = rvn_eval()
    assert wrong.returncode != 0 and "Set scenes.up_axis=z" in wrong.stderr and "Traceback" not in wrong.stderr
    assert not (out / "metrics.json").exists() and (out / "episodes.jsonl").read_text() == ""
    right = rvn_eval("scenes.up_axis=z")
    assert right.returncode == 0, right.stderr[-2000:]
    assert json.loads((out / "metrics.json").read_text())["episodes"] == 2
    assert json.loads((out / "run.json").read_text())["scenes"]["up_axis"] == "z"


def test_a_floor_tilted_not_levelled_is_said_naming_scenes_level(tmp_path):
    """A scan not levelled: a warning at 3 deg (none at 1 deg, the threshold 1.5), none with scenes.level=true."""
    v, f = make_apartment("train", 0).triangles()
    for deg, said in ((1, False), (3, True)):
        path = _mesh_file(tmp_path / f"tilted_{deg}.ply", _tilted(v, deg), f)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            load_mesh_file(path)
            load_mesh_file(path, level=True)
        texts = [str(w.message) for w in caught]
        assert texts == ([f"mesh file {str(path)!r}: its floor is tilted {deg}.0 deg from level (the area-weighted "
                          "normal of its upward faces); set scenes.level=true to level it (rvn-scene: --level)"]
                         if said else []), texts


def test_rvn_gen_lists_a_tilted_floor_in_its_summary(tmp_path):
    """rvn-gen on a scan not levelled: the loader's warning is one of the summary's notes, named by its scene (not a
    Python warning printed into the progress bar), and the run goes on."""
    v, f = make_apartment("train", 0).triangles()
    mesh = _mesh_file(tmp_path / "tilted.ply", _tilted(v, 3), f)
    proc = _gen(tmp_path, mesh, "workers=2")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert ("  notes (1):\n    tilted: mesh file " in proc.stdout and "tilted 3.0 deg from level" in proc.stdout
            and "set scenes.level=true" in proc.stdout), proc.stdout
    assert "UserWarning" not in proc.stderr


def test_rvn_eval_says_a_tilted_floor_once_in_one_line(tmp_path):
    """rvn-eval with 2 workers on a scan not levelled: the loader's warning in one line named by the command, once for
    the run (its main process and each worker load the scene; Python printed it in two lines, once in each)."""
    v, f = make_apartment("train", 0).triangles()
    mesh = _mesh_file(tmp_path / "tilted.ply", _tilted(v, 3), f)
    proc = subprocess.run(["rvn-eval", "scenes=mesh_dir", f"scenes.root={mesh}", "policy=goal_follower", "workers=2",
                           f"out_dir={tmp_path / 'eval'}", "episodes.per_scene=2", "progress=false"],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, "RVN_CACHE_DIR": str(tmp_path / "cache")})
    assert proc.returncode == 0, proc.stderr[-2000:]
    said = [line for line in proc.stderr.splitlines() if "tilted 3.0 deg" in line]
    assert said == [f"rvn-eval: warning: mesh file {str(mesh)!r}: its floor is tilted 3.0 deg from level (the "
                    "area-weighted normal of its upward faces); set scenes.level=true to level it (rvn-scene: --level)"]
    assert "UserWarning" not in proc.stderr

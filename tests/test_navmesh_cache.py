"""Built navmeshes kept under the cache root (rvn_data/navmesh/disk_cache.py): a navmesh read back equals the
built one, a file belongs to one scene geometry and one set of build settings, bad files are rebuilt, and
rvn-eval and rvn-rl's envs keep theirs under their run's cache root."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import box_scene, room_boxes
from rvn_data.navmesh import NavMesh, NavMeshSettings
from rvn_data.navmesh.disk_cache import LAYER_ARRAYS, LAYER_SCALARS
from rvn_data.navmesh.source import open_navmesh
from rvn_data.scenes import load_scene


def two_storey():
    boxes = room_boxes(8.0, 4.0, height=5.0)  # test_navmesh's stairs scene: layers joined by seam links
    boxes += [((1.0 + 0.25 * k, 0, 0), (1.25 + 0.25 * k, 0.15 * (k + 1), 1.2)) for k in range(16)]
    boxes += [((5.0, 2.3, 0), (8.0, 2.4, 4.0))]
    return box_scene(boxes, "two-storey")


def assert_same(a: NavMesh, b: NavMesh) -> None:
    assert len(a.layers) == len(b.layers) and a.island_areas == b.island_areas
    assert (a.x0, a.z0, a.scene_grid_shape) == (b.x0, b.z0, b.scene_grid_shape)
    assert a.links.dtype == b.links.dtype and np.array_equal(a.links, b.links)
    for la, lb in zip(a.layers, b.layers):
        for k in LAYER_SCALARS:
            assert type(getattr(la, k)) is type(getattr(lb, k)) and getattr(la, k) == getattr(lb, k), k
        for k in LAYER_ARRAYS:
            x, y = getattr(la, k), getattr(lb, k)
            assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y, equal_nan=True), k


def files(root):
    return sorted((root / "navmesh").glob("*.npz"))


@pytest.mark.parametrize("which", ["procedural", "two-storey", "dream"])
def test_a_kept_navmesh_is_the_built_one(which, tmp_path, monkeypatch, request):
    scene = {"procedural": lambda: load_scene("procedural:train/3"), "two-storey": two_storey,
             "dream": lambda: load_scene(str(request.getfixturevalue("dream_path")))}[which]()
    settings = NavMeshSettings()
    built = open_navmesh(scene, settings, tmp_path)  # a miss: built, then written
    assert len(files(tmp_path)) == 1 and files(tmp_path)[0].name.endswith(".npz")
    if which == "two-storey":
        assert len(built.links) > 0
    monkeypatch.setattr(NavMesh, "build", classmethod(lambda *a: pytest.fail("built although it was kept")))
    kept = open_navmesh(scene, settings, tmp_path)
    monkeypatch.undo()
    assert_same(kept, NavMesh.build(scene, settings))
    assert kept.scene_id == scene.scene_id and kept.settings == settings
    rng = np.random.default_rng(0)
    pts = np.stack([built.sample(rng) for _ in range(20)])
    assert np.array_equal(kept.distance_field(pts[0]).distance(pts), built.distance_field(pts[0]).distance(pts))


def test_a_file_holds_one_geometry_and_one_build(tmp_path, monkeypatch):
    scene = load_scene("procedural:train/3")
    open_navmesh(scene, NavMeshSettings(), tmp_path)
    open_navmesh(scene, NavMeshSettings(source="auto"), tmp_path)  # auto with no file beside it builds: the same file
    assert len(files(tmp_path)) == 1
    wider = open_navmesh(scene, NavMeshSettings(agent_radius=0.25), tmp_path)
    assert len(files(tmp_path)) == 2 and wider.settings.agent_radius == 0.25
    assert_same(wider, NavMesh.build(scene, NavMeshSettings(agent_radius=0.25)))
    other = load_scene("procedural:train/4")
    open_navmesh(other, NavMeshSettings(), tmp_path)
    assert len(files(tmp_path)) == 3
    moved = load_scene("procedural:train/3")
    moved.parts[0].vertices[0, 1] += 0.001  # one vertex moved: another geometry, another file
    open_navmesh(moved, NavMeshSettings(), tmp_path)
    assert len(files(tmp_path)) == 4


def test_an_unreadable_file_is_rebuilt_and_an_unwritable_folder_only_warned_about(tmp_path):
    scene = load_scene("procedural:train/3")
    open_navmesh(scene, NavMeshSettings(), tmp_path)
    path = files(tmp_path)[0]
    path.write_bytes(path.read_bytes()[:1000])  # cut short, as by a full disk
    with pytest.warns(UserWarning, match=rf"navmesh cache file {path} is unreadable .*rebuilding it"):
        again = open_navmesh(scene, NavMeshSettings(), tmp_path)
    assert_same(again, NavMesh.build(scene, NavMeshSettings()))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        open_navmesh(scene, NavMeshSettings(), tmp_path)  # replaced by a whole file
    blocked = tmp_path / "blocked"
    blocked.mkdir()
    (blocked / "navmesh").write_text("a file where the folder would go")
    with pytest.warns(UserWarning, match=r"cannot keep built navmeshes in .*blocked/navmesh.*RVN_CACHE_DIR"):
        nm = open_navmesh(scene, NavMeshSettings(), blocked)
    assert_same(nm, NavMesh.build(scene, NavMeshSettings()))


ASK = """
import sys, time
from pathlib import Path
from rvn_data.navmesh import NavMesh, NavMeshSettings
from rvn_data.navmesh.source import open_navmesh
from rvn_data.scenes import load_scene

root, go, log = (Path(a) for a in sys.argv[1:4])
scene = load_scene("procedural:train/3")
build = NavMesh.build


def counted(*args, **kwargs):
    with open(log, "a") as f:
        f.write("build\\n")
    time.sleep(1.0)  # long enough for the other process to ask meanwhile
    return build(*args, **kwargs)


NavMesh.build = counted
while not go.exists():
    time.sleep(0.005)
nm = open_navmesh(scene, NavMeshSettings(), root)
print(len(nm.layers), sum(int(layer.free.sum()) for layer in nm.layers), nm.island_areas)
"""


def test_processes_asking_at_once_build_once(tmp_path):
    """Two processes that find the same navmesh missing at the same moment (trainings side by side on the same
    scenes, DD-PPO's ranks): one builds it under the file's lock, the other waits and reads it; no lock file stays."""
    import subprocess
    import sys
    import time

    go, log = tmp_path / "go", tmp_path / "builds.log"
    procs = [subprocess.Popen([sys.executable, "-c", ASK, str(tmp_path), str(go), str(log)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    time.sleep(3.0)  # both have loaded the scene and wait for the signal
    go.touch()
    outs = [p.communicate(timeout=120) for p in procs]
    assert all(p.returncode == 0 for p in procs), [err[-2000:] for _, err in outs]
    assert log.read_text().splitlines() == ["build"], "each process built the navmesh"
    assert outs[0][0] == outs[1][0] and outs[0][0].strip()
    assert len(files(tmp_path)) == 1 and not list((tmp_path / "navmesh").glob("*.lock"))

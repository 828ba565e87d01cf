"""Reruns of rvn-gen into the same out_dir never shrink the splits (the union of every complete
trajectory on disk is kept and the summary says so), a changed split drops visualnav-transformer's
caches beside it, and the pictures have legends (dataset maps, clip figure and animation)."""
import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from rvn_data.dataset.gnm_writer import GNMWriter
from rvn_data.dataset.naming import scene_slug, traj_name
from rvn_data.dataset.reader import list_trajectories
from rvn_data.config import typed
from rvn_data.config_schemas import GenConfig
from rvn_data.dataset.settings import GenSettings
from rvn_data.dataset.topdown import map_legend
from rvn_data.dataset.writer import encode_jpeg

TINY = ["camera.width=32", "camera.height=32", "progress=false"]
SPLITS = ("train", "test")


def rvn_gen(out: Path, scenes: int, per_scene: int = 1, *extra: str) -> subprocess.CompletedProcess:
    proc = subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", f"out_dir={out}", f"scenes.num_scenes={scenes}",
                           f"trajectories_per_scene={per_scene}", *TINY, *extra],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc


def splits(out: Path, name: str = "rvn_expert") -> dict[str, str]:
    return {p: (out / "data_splits" / name / p / "traj_names.txt").read_text() for p in SPLITS}


def folders(out: Path) -> list[str]:
    return sorted(p.name for p in out.iterdir() if (p / "rvn_meta.json").is_file())


@pytest.fixture(scope="module")
def three(tmp_path_factory) -> Path:
    """3 train scenes x 1 trajectory."""
    out = tmp_path_factory.mktemp("union") / "three"
    rvn_gen(out, 3)
    return out


@pytest.mark.slow
def test_fewer_scenes_keep_the_union(three, tmp_path):
    out = tmp_path / "o"
    shutil.copytree(three, out)
    before, manifest = splits(out), (out / "manifest.json").read_text()
    assert sorted("".join(before.values()).split()) == folders(out) and len(folders(out)) == 3
    proc = rvn_gen(out, 1)
    assert splits(out) == before  # nothing dropped, same split by scene
    m = json.loads((out / "manifest.json").read_text())
    assert m["trajectories"] == 3 and m["scenes"]["listed"] == 1 and m["scenes"]["done"] == 3
    assert m["kept_from_earlier_runs"] == {"scenes": ["proc_train_0001", "proc_train_0002"],
                                           "trajectories": folders(out)[1:]}
    assert "keep 2 trajectories earlier runs wrote here of 2 scenes" in proc.stdout, proc.stdout
    assert list_trajectories(out, "train")[1] + list_trajectories(out, "test")[1]  # the reader still reads it
    # the full list again: the same bytes as the first run
    rvn_gen(out, 3)
    assert (out / "manifest.json").read_text() == manifest and splits(out) == before


@pytest.mark.slow
def test_fewer_trajectories_per_scene_keep_the_folders(tmp_path):
    out = tmp_path / "o"
    rvn_gen(out, 1, 2)
    before = splits(out)
    proc = rvn_gen(out, 1, 1)
    assert splits(out) == before and len("".join(before.values()).split()) == 2
    m = json.loads((out / "manifest.json").read_text())
    assert m["trajectories"] == 2
    assert m["kept_from_earlier_runs"] == {"scenes": [], "trajectories": ["proc_train_0000_expert_0001"]}
    assert "beyond trajectories_per_scene" in proc.stdout, proc.stdout


@pytest.mark.slow
def test_changed_split_drops_official_caches(three, tmp_path):
    out = tmp_path / "o"
    shutil.copytree(three, out)

    def plant():
        for part in SPLITS:
            d = out / "data_splits" / "rvn_expert" / part
            (d / "dataset_rvn_expert.lmdb").mkdir(exist_ok=True)
            (d / "dataset_rvn_expert.lmdb" / "data.mdb").write_bytes(b"old")
            (d / "dataset_dist_0_to_20_context_temporal_n5_slack_0.pkl").write_bytes(b"old")

    def caches(part):
        d = out / "data_splits" / "rvn_expert" / part
        return sorted(p.name for p in d.iterdir() if p.name.startswith("dataset_"))

    plant()
    proc = rvn_gen(out, 3)  # resume, nothing changes: the caches stay
    assert all(len(caches(p)) == 2 for p in SPLITS) and "stale" not in proc.stdout
    before = splits(out)
    proc = rvn_gen(out, 5)  # two more scenes: the splits change
    after = splits(out)
    changed = [p for p in SPLITS if after[p] != before[p]]
    assert changed
    for part in SPLITS:
        assert caches(part) == ([] if part in changed else sorted(["dataset_rvn_expert.lmdb",
                                "dataset_dist_0_to_20_context_temporal_n5_slack_0.pkl"]))
    assert "removed" in proc.stdout and f"data_splits/rvn_expert/{changed[0]}/dataset_" in proc.stdout, proc.stdout
    # the new scenes joined train, no scene changed sides: no note
    assert "changed split" not in proc.stdout and after["test"] == before["test"], proc.stdout


@pytest.mark.slow
def test_scene_changing_split_is_reported(three, tmp_path):
    """Adding scenes draws the split anew: a scene that changes sides is named in the summary."""
    out = tmp_path / "o"
    shutil.copytree(three, out)
    test_before = json.loads((out / "manifest.json").read_text())["per_scene"]
    was_test = [slug for slug, e in test_before.items() if e["gnm_split"] == "test"]
    proc = rvn_gen(out, 6)  # with the default seed and train_fraction the one test scene of 3 goes to train at 6
    now = json.loads((out / "manifest.json").read_text())["per_scene"]
    moved = sorted(slug for slug in test_before if now[slug]["gnm_split"] != test_before[slug]["gnm_split"])
    assert moved == was_test, (moved, was_test)
    assert f"note: 1 scene changed split ({moved[0]}: test -> train;" in proc.stdout, proc.stdout
    assert not [n for n in splits(out)["test"].split() if n.startswith(moved[0] + "_")]
    assert [n for n in splits(out)["train"].split() if n.startswith(moved[0] + "_")]
    proc = rvn_gen(out, 6)  # nothing new: nothing moved
    assert "changed split" not in proc.stdout, proc.stdout


@pytest.mark.slow
def test_dataset_map_and_data_config_for_gnm_users(three):
    for png in (three / "maps").glob("*.png"):
        img = cv2.imread(str(png))
        legend = map_legend(img.shape[1])
        assert np.array_equal(img[-len(legend):], legend), png  # the legend strip under the map
    cfg = (three / "data_config.yaml").read_text()
    assert "metric_waypoint_spacing: 0.25" in cfg and "0.14 m" in cfg and "turns in place" in cfg


def _write(gnm, s, spec, index):
    slug = scene_slug(spec)
    name = traj_name(slug, s.kind, index)
    meta = {"name": name, "spec": spec, "scene": spec, "kind": s.kind, "index": index, "frames": 2, "t_c": None,
            "path_length": 1.0, "attempt": 0, "rejected": {"no_path": 1}, "renderer": "gl"}
    gnm.write_trajectory(name, [encode_jpeg(np.zeros((4, 4, 3), np.uint8), 90)] * 2, np.zeros((2, 2)),
                         np.zeros(2), meta)
    return name, meta


def test_unfinished_scene_of_an_earlier_run_is_kept(tmp_path):
    """A scene begun by an earlier run (folders, no record) and not in this run's list."""
    s = GenSettings.resolve(typed(GenConfig, {"dataset": {"train_fraction": 0.5}, "agent": {}, "seed": 0,
                                 "camera": {"width": 4, "height": 4}}))  # the frames _write makes
    gnm = GNMWriter.open(tmp_path, s)
    done, begun = "procedural:train/0", "procedural:train/1"
    name0, meta0 = _write(gnm, s, done, 0)
    gnm.close_scene(scene_slug(done), {"scene": done, "spec": done, "trajectories": [
        {k: meta0[k] for k in ("name", "index", "frames", "t_c", "path_length", "attempt")}],
        "failed": [], "rejected": {}, "attempts": 1, "renderers": ["gl"]})
    name1, _ = _write(gnm, s, begun, 0)
    out = gnm.finalise_dataset([done])
    assert out.missing == [] and out.earlier == ["proc_train_0001"] and out.extra == [name1]
    listed = "".join(splits(tmp_path).values()).split()
    assert sorted(listed) == [name0, name1]
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["per_scene"]["proc_train_0001"]["unfinished"] is True and m["scenes"]["done"] == 1
    assert m["trajectories"] == 2 and m["attempts"] == 3


def test_clip_view_legends():
    from rvn_data.dataset.topdown import legend_strip
    from rvn_data.inspect.clips import Clip
    from rvn_data.inspect.maps import LEGEND, SceneMap
    from rvn_data.inspect.plots import animation_frames, clip_figure

    t = 6
    planar, yaw = np.stack([np.linspace(0.0, 1.25, t), np.zeros(t)], 1), np.zeros(t)
    meta = {"t_c": 3, "t_c_episode": 3, "start": [0.0, 0.0, 0.0], "goal_planar": [2.0, 0.0], "contact": [0.8, 0.0, 0.0],
            "waypoints_planar": [[0.0, 0.0], [2.0, 0.0]]}
    clip = Clip("c", np.zeros((t, 8, 8, 3), np.uint8), planar, yaw, meta)
    smap = SceneMap(np.full((120, 200, 3), 255, np.uint8), (-1.0, -1.0), 0.05, 3)
    fig = clip_figure(clip, smap)
    texts = [x.get_text() for x in fig.legends[0].get_texts()]
    assert texts == [label for *_, label in LEGEND]
    assert "commanded after t_c" in texts and "heading (last pose)" in texts and "contact point" in texts
    frames = animation_frames(clip, smap, height=64)
    legend = legend_strip(frames[0].shape[1], LEGEND)
    assert all(np.array_equal(f[-len(legend):], legend) for f in frames)

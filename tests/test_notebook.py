"""notebooks/collision_clips.ipynb and rvn_data.inspect on a tiny negative dataset made by the
real `rvn-gen dataset=negative` CLI (1 scene, 3 trajectories, 64×64 images)."""
from __future__ import annotations

import json
import pickle
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from PIL import Image

from rvn_data.inspect import (animation_frames, clip_figure, collisions, collisions_by_scene, dataset_stats,
                              first_collision, list_trajectories, load_clip, markdown_table, scene_map,
                              stats_figure, write_animation)
from rvn_data.dataset.topdown import legend_strip
from rvn_data.inspect.maps import LEGEND, OCCUPIED

REPO = Path(__file__).resolve().parents[1]
NOTEBOOK = REPO / "notebooks" / "collision_clips.ipynb"
TINY = ["dataset=negative", "scenes.num_scenes=1", "trajectories_per_scene=3", "camera.width=64", "camera.height=64",
        "progress=false"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("clips") / "rvn_negative"
    proc = subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", f"out_dir={out}", *TINY], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    return out


@pytest.fixture(scope="module")
def clip_and_map(dataset):
    clip = load_clip(dataset, first_collision(list_trajectories(dataset)))
    return clip, scene_map(clip.meta)


def test_lists_collisions_by_scene(dataset):
    metas = list_trajectories(dataset)
    manifest = json.loads((dataset / "manifest.json").read_text())
    assert len(metas) == manifest["trajectories"] == 3
    assert [m["name"] for m in metas] == sorted(m["name"] for m in metas)
    rows = collisions_by_scene(metas)
    assert len(rows) == 1 and rows[0]["scene"] == metas[0]["scene"]
    assert rows[0]["trajectories"] == rows[0]["collisions"] == 3  # every negative clip ends in a collision
    assert rows[0]["mean_steps_to_collision"] == pytest.approx(np.mean([m["t_c_episode"] for m in metas]), abs=0.01)
    table = markdown_table(rows)
    assert table.splitlines()[0].startswith("| scene | trajectories | collisions |") and metas[0]["scene"] in table
    assert {r["name"] for r in collisions(metas)} == {m["name"] for m in metas}


def test_load_clip_matches_gnm_files(dataset, clip_and_map):
    clip, _ = clip_and_map
    with open(dataset / clip.name / "traj_data.pkl", "rb") as fh:
        data = pickle.load(fh)
    assert clip.frames.shape == (len(data["position"]), 64, 64, 3) and clip.frames.dtype == np.uint8
    np.testing.assert_array_equal(clip.planar, data["position"])
    np.testing.assert_array_equal(clip.yaw, data["yaw"])
    ref = cv2.imread(str(dataset / clip.name / "0.jpg"))[:, :, ::-1]  # RGB order
    np.testing.assert_array_equal(clip.frames[0], ref)
    assert 0 <= clip.t_c < len(clip)
    for t in range(clip.t_c + 1, len(clip)):  # the image is frozen at I_{t_c}
        np.testing.assert_array_equal(clip.frames[t], clip.frames[clip.t_c])


def test_map_transform_puts_poses_on_free_floor(clip_and_map):
    clip, smap = clip_and_map
    h, w = smap.image.shape[:2]
    for p in clip.planar[: clip.t_c + 1]:  # real (navigable) poses up to the collision
        col, row = np.round(smap.to_px(p)).astype(int)
        assert 0 <= row < h and 0 <= col < w
        assert tuple(smap.image[row, col]) != OCCUPIED
    local = smap.crop(clip.planar, pad=1.0)
    assert local.image.shape[0] < h or local.image.shape[1] < w
    p = clip.planar[clip.t_c]
    full, part = smap.to_px(p), local.to_px(p)
    offset = np.round(full - part).astype(int)
    np.testing.assert_allclose(full - part, offset, atol=1e-6)  # a crop shifts by whole pixels
    col, row = np.round(part).astype(int)
    np.testing.assert_array_equal(local.image[row, col], smap.image[row + offset[1], col + offset[0]])


def test_animation_gif_and_mp4(clip_and_map, tmp_path):
    clip, smap = clip_and_map
    frames = animation_frames(clip, smap, height=128)
    legend_rows = legend_strip(frames[0].shape[1], LEGEND).shape[0]  # the map's legend under the 128-px panels
    assert len(frames) == len(clip) and {f.shape for f in frames} == {frames[0].shape}
    assert frames[0].shape[0] == 128 + legend_rows and legend_rows > 0
    assert not np.array_equal(frames[0], frames[-1])  # the path grows, the border turns red
    gif = write_animation(frames, tmp_path / "clip.gif")
    with Image.open(gif) as im:
        assert im.n_frames == len(clip) and im.size == (frames[0].shape[1], frames[0].shape[0])
    mp4 = write_animation(frames, tmp_path / "clip.mp4", fps=5)
    cap = cv2.VideoCapture(str(mp4))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == len(clip)
    cap.release()
    assert not list(tmp_path.glob(".*tmp*"))
    with pytest.raises(ValueError, match="gif or .mp4"):
        write_animation(frames, tmp_path / "clip.avi")


def test_figures(dataset, clip_and_map):
    clip, smap = clip_and_map
    fig = clip_figure(clip, smap, cols=5)
    images = [ax for ax in fig.axes if ax.images]
    assert len(images) == len(clip) + 1  # every frame and the map
    assert "t_c" in images[clip.t_c].get_title()
    stats = dataset_stats(list_trajectories(dataset))
    assert len(stats["frames"]) == len(stats["t_c"]) == 3 and sum(stats["per_scene"].values()) == 3
    assert all(4.0 <= x <= 8.0 for x in stats["path_length"])
    assert len(stats_figure(stats).axes) == 4


def test_bad_input(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        list_trajectories(tmp_path / "nope")
    with pytest.raises(ValueError, match="holds no trajectory"):
        list_trajectories(tmp_path)
    with pytest.raises(ValueError, match="not a complete trajectory"):
        load_clip(tmp_path, "missing")
    with pytest.raises(ValueError, match="no trajectory of this dataset ends in a collision"):
        first_collision([{"name": "a", "t_c": None}])


def test_notebook_file_is_generated_from_its_script():
    sys.path.insert(0, str(NOTEBOOK.parent))
    try:
        import make_collision_clips
    finally:
        sys.path.remove(str(NOTEBOOK.parent))
    import nbformat

    assert nbformat.writes(make_collision_clips.build()) == nbformat.writes(nbformat.read(str(NOTEBOOK), as_version=4))


@pytest.mark.slow
def test_notebook_runs_headless(dataset, tmp_path, monkeypatch):
    """The README's recipe: `RVN_DATASET=<relative path> jupyter lab` from the launch folder, the
    kernel running in notebooks/ with the launch shell's environment; clips under the cache root."""
    import nbformat
    from nbclient import NotebookClient

    launch = dataset.parent
    monkeypatch.setenv("PWD", str(launch))  # what the shell exports after `cd <launch>`
    monkeypatch.setenv("RVN_DATASET", dataset.name)  # relative to the launch folder, not to notebooks/
    for name in ("RVN_CLIPS_OUT", "RVN_CACHE_DIR", "RVN_LAUNCH_DIR"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    repo_before = sorted(NOTEBOOK.parent.iterdir())
    nb = nbformat.read(str(NOTEBOOK), as_version=4)
    kernel_dir = {"metadata": {"path": str(NOTEBOOK.parent)}}  # as Jupyter runs it: in notebooks/
    NotebookClient(nb, timeout=300, kernel_name="python3", resources=kernel_dir).execute()
    assert sorted(NOTEBOOK.parent.iterdir()) == repo_before  # nothing written into the repository
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    mimes = [m for o in outputs for m in o.get("data", {})]
    assert mimes.count("image/png") == 2 and mimes.count("image/gif") == 1  # clip figure, stats; animation
    markdown = "".join(o["data"]["text/markdown"] for o in outputs if "text/markdown" in o.get("data", {}))
    assert "procedural:train/0" in markdown and "| scene | trajectories | collisions |" in markdown
    gifs = list((launch / "outputs" / "cache" / "clips").glob(f"{dataset.name}-*/*.gif"))
    assert len(gifs) == 1 and gifs[0].stem == first_collision(list_trajectories(dataset))
    with Image.open(gifs[0]) as im:
        assert im.n_frames == len(load_clip(dataset, gifs[0].stem))

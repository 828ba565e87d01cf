"""The depth model of the DD-PPO + predicted depth baseline, through its CLI on tiny data
(2 train scenes, 1 val scene, 8 poses each, 32x32 frames): it writes a model that
`load_depth_model` loads and that reproduces the reported val metrics, the metrics and the
PNG; training lowers the error on the training frames well below the untrained model's;
pairs are reproducible and reused; bad input gets a one-line error."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

TINY = ["image_size=32", "pairs.train_scenes=2", "pairs.val_scenes=1", "pairs.per_scene=8", "train.batch_size=8",
        "train.eval_every=40", "threads=1", "progress=false", "renderer=raycast"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def depth_cli(*args, check=True):
    proc = subprocess.run([sys.executable, "-m", "rvn_rl.depth.cli", *args], capture_output=True, text=True,
                          env=ENV, timeout=600)
    if check:
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("depth") / "run"
    proc = depth_cli(f"out_dir={out}", "train.steps=100", *TINY)
    return out, proc


def test_cli_writes_a_loadable_model_that_reproduces_its_metrics(run):
    from rvn_rl.depth import load_depth_model
    from rvn_rl.depth.pairs import read_pairs
    from rvn_rl.depth.train import depth_metrics

    out, proc = run
    for name in ("model.safetensors", "model.json", "metrics.json", "predictions.png", "config.yaml"):
        assert (out / name).is_file(), name
    assert (out / "predictions.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "AbsRel" in proc.stdout and "constant train median" in proc.stdout
    metrics = json.loads((out / "metrics.json").read_text())
    predictor = load_depth_model(out)
    assert not predictor.net.training and not any(p.requires_grad for p in predictor.net.parameters())
    rgb, depth = read_pairs(out / "pairs" / "val.h5")
    assert rgb.shape == (8, 32, 32, 3) and depth.shape == (8, 32, 32)
    pred = predictor(rgb)
    assert pred.dtype == np.float32 and pred.shape == depth.shape and np.all(pred > 0)
    again = depth_metrics(pred, depth)
    assert again["absrel"] == pytest.approx(metrics["val"]["absrel"], rel=1e-4)
    assert again["delta1"] == pytest.approx(metrics["val"]["delta1"], rel=1e-4)
    # another frame size: resized to the training size and back
    big = np.repeat(np.repeat(rgb[:2], 2, axis=1), 2, axis=2)
    assert predictor(big).shape == (2, 64, 64)
    # the model file alone loads too
    assert np.allclose(load_depth_model(out / "model.safetensors")(rgb[:1]), pred[:1])


def test_metrics_hold_val_errors_baselines_and_the_training_log(run):
    metrics = json.loads((run[0] / "metrics.json").read_text())
    for block in (metrics["val"], metrics["baselines"]["constant_median"], metrics["baselines"]["pixel_median"]):
        assert block["frames"] == 8 and block["absrel"] > 0 and 0 <= block["delta1"] <= 1
    assert metrics["pairs"]["train"] == 16 and metrics["pairs"]["val"] == 8
    assert any("val" in row for row in metrics["history"])
    assert metrics["history"][-1]["step"] == 100


def test_training_lowers_the_error(run):
    """AbsRel on the training frames: the untrained model predicts about the training median
    everywhere; after 100 steps it must fit the frames far better."""
    sub = json.loads((run[0] / "metrics.json").read_text())["train_subset"]
    assert sub["final"]["absrel"] < 0.6 * sub["init"]["absrel"], sub
    assert sub["final"]["delta1"] > sub["init"]["delta1"] + 0.1, sub


def test_pairs_are_reproducible_and_reused(run, tmp_path):
    from rvn_rl.depth.pairs import read_pairs

    out = tmp_path / "second"
    depth_cli(f"out_dir={out}", f"pairs.dir={run[0] / 'pairs'}", "train.steps=2", *TINY)
    assert json.loads((out / "metrics.json").read_text())["pairs"]["reused"] == {"train": True, "val": True}
    fresh = tmp_path / "fresh"
    depth_cli(f"out_dir={fresh}", "train.steps=1", *TINY)
    for split in ("train", "val"):
        a, b = read_pairs(run[0] / "pairs" / f"{split}.h5"), read_pairs(fresh / "pairs" / f"{split}.h5")
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    # a file rendered by code of another dataset version (before a renderer or navmesh fix) is made anew
    import h5py

    with h5py.File(fresh / "pairs" / "val.h5", "r+") as f:
        meta = json.loads(f.attrs["meta"])
        assert meta.pop("dataset_version") >= 3
        f.attrs["meta"] = json.dumps(meta)
    again = tmp_path / "again"
    depth_cli(f"out_dir={again}", f"pairs.dir={fresh / 'pairs'}", "train.steps=1", *TINY)
    assert json.loads((again / "metrics.json").read_text())["pairs"]["reused"] == {"train": True, "val": False}


@pytest.mark.parametrize("arg, words", [
    ("pairs.per_scene=0", "pairs.per_scene"),
    ("image_size=8", "image_size"),
    ("train.lr=0", "train.lr"),
    ("train.stepz=3", "stepz"),
    ("pairs.val_scenes=500", "val_scenes"),
    ("camera.width=64", "camera.width=64 differs from image_size=32"),  # model.json would say 32
])
def test_bad_input_gets_a_one_line_error(tmp_path, arg, words):
    proc = depth_cli(f"out_dir={tmp_path / 'x'}", *TINY, arg, check=False)
    assert proc.returncode == 2 and not (tmp_path / "x").exists()
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and lines[0].startswith("rvn_rl.depth.cli: error:"), proc.stderr


def test_loader_and_predictor_refuse_bad_input(run, tmp_path):
    from rvn_rl.depth import load_depth_model

    with pytest.raises(ValueError, match="model.safetensors not found"):
        load_depth_model(tmp_path)
    (tmp_path / "model.safetensors").write_bytes((run[0] / "model.safetensors").read_bytes())
    (tmp_path / "model.json").write_text(json.dumps({"kind": "rl"}))
    with pytest.raises(ValueError, match="not a depth checkpoint"):
        load_depth_model(tmp_path)
    with pytest.raises(ValueError, match=r"uint8 \[N,H,W,3\]"):
        load_depth_model(run[0])(np.zeros((1, 32, 32, 3), np.float32))
    with pytest.raises(ValueError, match="threads=0"):
        load_depth_model(run[0], threads=0)


def test_predictor_runs_with_its_own_thread_count_and_restores_torch_s(run):
    import torch

    from rvn_rl.depth import load_depth_model

    before = torch.get_num_threads()
    torch.set_num_threads(2)
    seen = []
    predictor = load_depth_model(run[0], threads=1)
    net_forward = predictor.net.forward
    predictor.net.forward = lambda x: (seen.append(torch.get_num_threads()), net_forward(x))[1]
    predictor(np.zeros((1, 32, 32, 3), np.uint8))
    try:
        assert seen == [1] and torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


def test_a_save_cut_off_between_its_two_files_is_refused_on_load(tmp_path):
    """model.json records the digest of the weights saved with it: the weights of another model beside it (a save
    cut off after model.json, or one file copied over alone) are refused instead of loading under its settings."""
    import torch

    from rvn_rl.depth import DepthNet, load_depth_model, save_depth_model

    torch.manual_seed(0)
    old, new = tmp_path / "old", tmp_path / "new"
    save_depth_model(DepthNet(widths=[4, 8]), old, 32)
    save_depth_model(DepthNet(widths=[4, 8], init_depth=3.0), new, 32)
    assert load_depth_model(new).image_size == 32
    (new / "model.safetensors").write_bytes((old / "model.safetensors").read_bytes())  # model.json new, weights old
    with pytest.raises(ValueError, match="model.safetensors is not the one model.json was saved with"):
        load_depth_model(new)


def _room(path, z_up: bool):
    """A 3 m x 3 m room (conftest's boxes), written y-up or z-up (as HM3D's meshes are)."""
    import trimesh

    from conftest import box_scene, room_boxes

    v, f = box_scene(room_boxes(3.0, 3.0)).triangles()
    if z_up:
        v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], 1)
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.Trimesh(v.astype(np.float64), f, process=False).export(path)


def test_pairs_load_scenes_with_the_scenes_group_options(tmp_path):
    """The ``scenes`` group as rvn-gen's and rvn-rl's (scenes=hm3d: up_axis z): a z-up mesh folder read with
    scenes.up_axis=z renders the pairs the same room written y-up renders with the defaults, and pair files record
    the options only when they are not the defaults, so files made with the defaults keep their meta."""
    from rvn_rl.depth.cli import compose, make_all_pairs, scene_specs
    from rvn_rl.depth.pairs import pair_meta, read_meta, read_pairs

    assert compose(["scenes=hm3d", "scenes.root=/data/hm3d"]).scenes.up_axis == "z"
    tiny = ["image_size=32", "pairs.train_scenes=1", "pairs.val_scenes=1", "pairs.per_scene=4", "progress=false",
            "renderer=raycast", "scenes=mesh_dir"]
    made = {}
    for axis in ("y", "z"):
        for split in ("train", "val"):
            _room(tmp_path / axis / split / f"room_{split}.glb", z_up=axis == "z")
        cfg = compose([*tiny, f"scenes.root={tmp_path / axis}", *(["scenes.up_axis=z"] if axis == "z" else [])])
        made[axis] = make_all_pairs(cfg, scene_specs(cfg), tmp_path / f"out_{axis}")["train"][0]
    (_, depth_y), (_, depth_z) = read_pairs(made["y"]), read_pairs(made["z"])
    assert depth_z.shape == (4, 32, 32) and np.allclose(depth_z, depth_y, atol=1e-3)
    assert read_meta(made["z"])["scene_options"] == {"up_axis": "z", "unit_scale": 1.0, "level": False}
    assert "scene_options" not in read_meta(made["y"])
    default = compose(["image_size=32"])
    args = ("train", [("procedural:train/0", 0)], 4, 0, default.camera, default.renderer, default.navmesh)
    assert pair_meta(*args, {"up_axis": "y", "unit_scale": 1.0, "level": False}) == pair_meta(*args)
    for bad, said in (("scenes.num_scenes=3", "scenes.num_scenes=3 does nothing in the depth CLI"),
                      ("scenes.up_axis=x", "scenes.up_axis='x': choose y or z")):
        with pytest.raises(ValueError, match=said):
            compose([bad])


def test_val_scenes_that_are_train_scenes_are_noted_and_recorded(tmp_path):
    """A mesh folder without train/ and val/ folders gives both splits the same meshes: the CLI says so (as rvn-gen
    and rvn-eval do) and metrics.json and the summary record it; split folders keep the splits apart, no note."""
    for name in ("a", "b"):
        _room(tmp_path / "flat" / f"room_{name}.glb", z_up=False)
    out = tmp_path / "run"
    proc = depth_cli(f"out_dir={out}", *TINY, "pairs.train_scenes=2", "pairs.per_scene=4", "train.steps=2",
                     "scenes=mesh_dir", f"scenes.root={tmp_path / 'flat'}")
    assert "rvn_rl.depth.cli: note: 1 of the 1 val scenes are train scenes too" in proc.stderr, proc.stderr
    shared = json.loads((out / "metrics.json").read_text())["shared_scenes"]
    assert shared == {"folder": str(tmp_path / "flat"), "val_scenes": 1, "in_train": 1}
    assert "warning: 1 of the 1 val scenes are train scenes too" in proc.stdout
    from rvn_rl.depth.cli import compose, scene_specs, shared_scenes

    for split in ("train", "val"):
        _room(tmp_path / "split" / split / f"room_{split}.glb", z_up=False)
    cfg = compose(["scenes=mesh_dir", f"scenes.root={tmp_path / 'split'}", "pairs.train_scenes=1", "pairs.val_scenes=1"])
    assert shared_scenes(cfg, scene_specs(cfg)) is None

"""The one cache root (rvn_data.cache_root): cache_dir= > $RVN_CACHE_DIR > <out_dir>/cache; rvn-train
reads a read-only dataset and packs it under the root, rvn-eval keeps one episode set per settings
there, the notebook's paths start from the folder Jupyter was started in."""
from __future__ import annotations

import json
import logging
import os
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from rvn_data.cache_root import ENV, cache_root
from rvn_data.inspect.paths import clips_dir, dataset_path
from rvn_il.data import make_dataset
from rvn_il.data.synthetic import write_synthetic_gnm
from rvn_il.models.checkpoint import latest_checkpoint
from rvn_il.models import load_model_config
from rvn_il.train.cli import train


def snapshot(root: Path) -> dict:
    """Every path under ``root`` with its size and mtime."""
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(root.rglob("*"))}


def set_writable(root: Path, writable: bool) -> None:
    for p in [root, *root.rglob("*")]:
        mode = p.stat().st_mode
        write = stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH
        p.chmod(mode | stat.S_IWUSR if writable else mode & ~write)


def test_cache_root_order(tmp_path, monkeypatch, caplog):
    monkeypatch.delenv(ENV, raising=False)
    assert cache_root(None, tmp_path / "run") == tmp_path / "run" / "cache"
    monkeypatch.setenv(ENV, str(tmp_path / "shared"))
    assert cache_root(None, tmp_path / "run") == tmp_path / "shared"
    assert cache_root(str(tmp_path / "setting"), tmp_path / "run") == tmp_path / "setting"
    monkeypatch.delenv(ENV)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))  # the system's temporary folder
    with caplog.at_level(logging.WARNING, logger="rvn_data.cache_root"):
        fallback = cache_root()
    assert fallback.parent == tmp_path / "tmp" and fallback.name.startswith("rvn-cache-")
    assert str(fallback) in caplog.text and ENV in caplog.text


def test_packed_caches_of_same_named_datasets_do_not_collide(tmp_path):
    a = write_synthetic_gnm(tmp_path / "a" / "expert", 2, 12, image_size=32, seed=0)
    b = write_synthetic_gnm(tmp_path / "b" / "expert", 2, 12, image_size=32, seed=1)
    cfg = load_model_config("vint_pointgoal", "small")
    data = {"progress": False, "cache_dir": str(tmp_path / "cache")}
    ds_a, ds_b = make_dataset(a, cfg, data), make_dataset(b, cfg, data)
    assert ds_a.cache.path != ds_b.cache.path and ds_a.cache.path.name == ds_b.cache.path.name
    assert ds_a.cache.path.is_relative_to(tmp_path / "cache")
    mtime = ds_a.cache.path.stat().st_mtime_ns
    assert make_dataset(a, cfg, data).cache.path.stat().st_mtime_ns == mtime  # reused, not rebuilt by b
    assert (ds_a.get_batch([0])["obs_image"] != ds_b.get_batch([0])["obs_image"]).any()
    name = ds_a.cache.names[0]  # another trajectory list of the same split (data.splits_dir): another file
    (tmp_path / "splits" / "expert" / "train").mkdir(parents=True)
    (tmp_path / "splits" / "expert" / "train" / "traj_names.txt").write_text(name + "\n")
    one = make_dataset(a, cfg, {**data, "splits_dir": str(tmp_path / "splits"), "name": "expert"})
    assert one.cache.names == [name] and one.cache.path != ds_a.cache.path
    assert ds_a.cache.path.stat().st_mtime_ns == mtime


@pytest.mark.slow
def test_train_reads_a_read_only_dataset(tmp_path, monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home").mkdir()
    root = write_synthetic_gnm(tmp_path / "shared_storage" / "expert", 3, 24, image_size=64, seed=0)
    before = snapshot(root)
    common = ["model=vint_pointgoal", "model.size=small", "train.batch_size=4", "train.max_steps=2",
              "data.num_workers=0", f"data.root={root}", "data.negative_root=null"]
    set_writable(root, False)
    try:
        out = train([*common, f"out_dir={tmp_path / 'run'}"])
        monkeypatch.setenv(ENV, str(tmp_path / "scratch"))
        out2 = train([*common, f"out_dir={tmp_path / 'run2'}"])
    finally:
        set_writable(root, True)
    assert snapshot(root) == before  # nothing written into the dataset
    assert latest_checkpoint(out / "model").name == latest_checkpoint(out2 / "model").name == "ckpt_00000002"
    assert len(list((out / "cache" / "packed").glob("*/expert_train_*.h5"))) == 1  # default: <out_dir>/cache
    assert len(list((tmp_path / "scratch" / "packed").glob("*/expert_train_*.h5"))) == 1  # $RVN_CACHE_DIR
    assert not (out2 / "cache").exists() and not list((tmp_path / "home").iterdir())


def rvn_eval(cwd: Path, env: dict, *overrides: str) -> subprocess.CompletedProcess:
    small = ["policy=oracle", "split=val", "episodes.num_scenes=1", "episodes.per_scene=1", "camera.width=32",
             "camera.height=32", "progress=false", "renderer=raycast"]
    proc = subprocess.run([sys.executable, "-m", "rvn_data.benchmark.cli", *small, *overrides], capture_output=True,
                          text=True, timeout=600, cwd=cwd, env={**os.environ, "OMP_NUM_THREADS": "1", **env})
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


@pytest.mark.slow
def test_eval_keeps_one_episode_set_per_settings(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    env = {"HOME": str(home), ENV: ""}
    rvn_eval(tmp_path, env, "out_dir=a", "episodes.n_goals=2")
    shared = tmp_path / "a" / "cache" / "episodes" / "procedural"  # default: <out_dir>/cache
    assert len(list(shared.glob("val-*/index.json"))) == 1
    # another n_goals into the same root (here through $RVN_CACHE_DIR): its own set, no clash
    rvn_eval(tmp_path, {**env, ENV: str(tmp_path / "a" / "cache")}, "out_dir=b", "episodes.n_goals=3")
    indexes = [json.loads(p.read_text()) for p in sorted(shared.glob("val-*/index.json"))]
    assert sorted(i["settings"]["episodes"]["n_goals"] for i in indexes) == [2, 3]
    assert json.loads((tmp_path / "b" / "metrics.json").read_text())["n_goals"] == 3
    assert not (tmp_path / "b" / "cache").exists() and not list(home.iterdir())


def test_notebook_paths_start_from_the_launch_folder(tmp_path, monkeypatch):
    launch, kernel = tmp_path / "repo", tmp_path / "repo" / "notebooks"
    kernel.mkdir(parents=True)
    monkeypatch.chdir(kernel)  # Jupyter runs the kernel in the notebook's folder
    monkeypatch.setenv("PWD", str(launch))  # the shell's folder when `jupyter lab` started
    monkeypatch.delenv("RVN_LAUNCH_DIR", raising=False)
    monkeypatch.delenv("RVN_CLIPS_OUT", raising=False)
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.setenv("RVN_DATASET", "outputs/rvn_negative")
    with pytest.raises(ValueError) as err:
        dataset_path()
    msg = str(err.value)
    assert "\n" not in msg and f"{launch / 'outputs' / 'rvn_negative'} does not exist" in msg
    assert "RVN_DATASET = outputs/rvn_negative" in msg and f"relative to {launch}" in msg
    (launch / "outputs" / "rvn_negative").mkdir(parents=True)
    ds = dataset_path()
    assert ds == launch / "outputs" / "rvn_negative"
    out = clips_dir(ds)
    assert out.parent == launch / "outputs" / "cache" / "clips" and out.name.startswith("rvn_negative-")
    other = tmp_path / "elsewhere" / "rvn_negative"
    other.mkdir(parents=True)
    assert dataset_path(str(other)) == other and clips_dir(other) != out  # same name, other folder
    monkeypatch.setenv(ENV, str(tmp_path / "scratch"))
    assert clips_dir(ds).parent == tmp_path / "scratch" / "clips"
    monkeypatch.setenv("RVN_CLIPS_OUT", "my_clips")
    assert clips_dir(ds) == launch / "my_clips"


def test_unwritable_cache_is_one_line_naming_it(tmp_path):
    from rvn_data.benchmark.episodes_source import EnvConfig, ensure_scene_episodes

    blocker = tmp_path / "a_file"
    blocker.write_text("")
    root = write_synthetic_gnm(tmp_path / "expert", 2, 12, image_size=32)
    with pytest.raises(ValueError, match=rf"cannot create cache folder {blocker}/packed.*set cache_dir= or {ENV}"):
        make_dataset(root, load_model_config("vint_pointgoal", "small"),
                     {"progress": False, "cache_dir": str(blocker / "packed")})
    cfg = EnvConfig.from_kwargs(mode="eval", split="val", scenes={"num_scenes": 1}, per_scene=1,
                                episodes={"n_goals": 1, "dir": str(blocker / "episodes")})
    with pytest.raises(ValueError, match=rf"cannot write episode file {blocker}/episodes/.*set cache_dir= or {ENV}"):
        ensure_scene_episodes(cfg, cfg.scene_slots()[0])

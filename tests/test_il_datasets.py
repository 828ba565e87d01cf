"""rvn-train on several GNM datasets at once (data.datasets; visualnav-transformer's own config files): an
RVN-like dataset beside a foreign one (160x120 JPEGs, 0.12 m per frame with odometry noise, its spacing under
its dataset name), exact resume, the dataset report, the sampler's stream, bad input in one line."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import interrupted_copy
import torch
import yaml
from safetensors.torch import load_file

from rvn_il.data.mixture import MixtureSampler, mixture_weights
from rvn_il.data.synthetic import write_synthetic_gnm
from rvn_il.models.checkpoint import latest_checkpoint
from rvn_il.policies import load_policy
from rvn_il.train.cli import train

pytestmark = pytest.mark.slow  # end-to-end runs of rvn-train

torch.set_num_threads(1)
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
SMALL = ["model=nomad_pointgoal", "model.size=small", "train.batch_size=4", "data.num_workers=0", "device=cpu"]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    base = tmp_path_factory.mktemp("datasets")
    write_synthetic_gnm(base / "rvn", 3, 24, image_size=64, seed=0)
    write_synthetic_gnm(base / "real", 4, 30, image_size=(160, 120), seed=1, spacing=0.12, pose_noise=0.01,
                        name="go_stanford")
    return base


def mixture(data, **second) -> str:
    entry = ", ".join(f"{k}: {v}" for k, v in {"root": data / "real", "waypoint_spacing": 2, **second}.items())
    return f"data.datasets=[{{root: {data / 'rvn'}, weight: 0.7}}, {{{entry}}}]"


def rvn_train(*args):
    return subprocess.run([sys.executable, "-m", "rvn_il.train.cli", *args], capture_output=True, text=True, env=ENV,
                          timeout=300)


def test_mixture_trains_through_the_cli_and_reports_each_dataset(data, tmp_path):
    out = tmp_path / "mix"
    proc = rvn_train(*SMALL, "train.max_steps=3", mixture(data, weight=0.3), f"out_dir={out}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    log = (out / "rvn-train.log").read_text()
    assert "rvn: 3 trajectories, 72 frames" in log and "70.0 % of each batch" in log
    assert "go_stanford: 4 trajectories, 120 frames" in log and "0.240 m per step (0.120 m x 2 frames)" in log
    assert "images 160x120" in log and "30.0 % of each batch" in log
    stats = json.loads((latest_checkpoint(out / "model") / "stats.json").read_text())
    real = stats["datasets"][1]
    assert (real["name"], real["image_sizes"], real["step_m"], real["share"]) == ("go_stanford", ["160x120"], 0.24, 0.3)
    assert stats["metric_waypoint_spacing"] == 0.25  # the first dataset's: the deployment robot's step
    cfg = yaml.safe_load((out / "config.yaml").read_text())
    assert [d["weight"] for d in cfg["data"]["datasets"]] == [0.7, 0.3]
    policy = load_policy(out)  # the checkpoint alone rebuilds the policy
    frames = np.zeros((64, 64, 3), np.uint8)
    assert policy.act({"rgb": frames, "pointgoal": np.array([2.0, 0.5], np.float32)}) in (1, 2, 3)


def test_mixture_resumes_exactly(data, tmp_path):
    args = [*SMALL, "train.max_steps=4", "train.ckpt_every=2", mixture(data, weight=0.3)]
    full = train([f"out_dir={tmp_path / 'full'}", *args])
    part = interrupted_copy(full, tmp_path / "part")
    train([f"out_dir={part}", *args])
    a, b = latest_checkpoint(full / "model"), latest_checkpoint(part / "model")
    assert a.name == b.name == "ckpt_00000004"
    for f in ("weights.safetensors", "ema.safetensors"):
        wa, wb = load_file(str(a / f)), load_file(str(b / f))
        for k in wa:
            torch.testing.assert_close(wa[k], wb[k], rtol=0, atol=0, msg=f"{f}:{k}")


def test_sampler_stream_is_a_function_of_seed_and_position():
    weights = mixture_weights([50, 200], [0.8, 0.2])
    head = iter(MixtureSampler([50, 200], weights, seed=3))
    stream = [next(head) for _ in range(9000)]
    later = iter(MixtureSampler([50, 200], weights, seed=3, start=5000))  # a resumed run, past a block boundary
    assert [next(later) for _ in range(4000)] == stream[5000:]
    which = np.array(stream) % 2
    assert abs(np.mean(which == 0) - 0.8) < 0.02  # the weights hold
    firsts = [i // 2 for i in stream if i % 2 == 0][:50]
    assert sorted(firsts) == list(range(50))  # dataset 0's first epoch: each of its samples once
    assert mixture_weights([50, 200], [None, None]).tolist() == [0.2, 0.8]  # no weights: in proportion to size


def test_official_config_and_data_config_train_without_conversion(data, tmp_path):
    official = tmp_path / "nomad.yaml"
    official.write_text(yaml.safe_dump({"image_size": [96, 96], "datasets": {"go_stanford": {
        "data_folder": str(data / "real"), "train": str(data / "real" / "data_splits" / "go_stanford" / "train") + "/",
        "test": str(data / "real" / "data_splits" / "go_stanford" / "test") + "/", "end_slack": 1, "goals_per_obs": 2,
        "negative_mining": True}}}))
    data_config = tmp_path / "data_config.yaml"
    data_config.write_text(yaml.safe_dump({"action_stats": {"min": [-2.5, -4], "max": [5, 4]},
                                           "go_stanford": {"metric_waypoint_spacing": 0.12}}))
    out = tmp_path / "official"
    proc = rvn_train(*SMALL, "train.max_steps=2", f"data.official_config={official}",
                     f"data.official_data_config={data_config}", f"out_dir={out}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    log = (out / "rvn-train.log").read_text()
    assert "go_stanford: 4 trajectories" in log and "0.120 m per step" in log
    assert "go_stanford.goals_per_obs, go_stanford.negative_mining read but not applied" in log
    stats = json.loads((latest_checkpoint(out / "model") / "stats.json").read_text())
    assert stats["crop"] == "official" and stats["metric_waypoint_spacing"] == 0.12
    # the official data_config.yaml without this dataset: one line naming it
    data_config.write_text(yaml.safe_dump({"recon": {"metric_waypoint_spacing": 0.25}}))
    r = rvn_train(*SMALL, f"data.official_config={official}", f"data.official_data_config={data_config}",
                  f"out_dir={tmp_path / 'o1'}")
    assert r.returncode == 2 and "dataset 'go_stanford' has no metric_waypoint_spacing" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / "o1").exists()


@pytest.mark.parametrize("second, message", [
    ({"weight": -1}, "data.datasets[1].weight=-1.0 must be a positive number"),
    ({}, "data.datasets: give a weight for every dataset or for none"),
    ({"weight": 0.3, "waypoint_spacing": 0}, "data.datasets[1].waypoint_spacing=0 must be a whole number"),
    ({"weight": 0.3, "crop": "square"}, "data.datasets[1].crop='square'"),
])
def test_bad_dataset_settings_are_one_line(data, tmp_path, second, message):
    r = rvn_train(*SMALL, mixture(data, **second), f"out_dir={tmp_path / 'o'}")
    assert r.returncode == 2 and message in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_a_dataset_folder_that_does_not_exist_is_one_line(tmp_path):
    r = rvn_train(*SMALL, f"data.datasets=[{{root: {tmp_path / 'nowhere'}}}]", f"out_dir={tmp_path / 'o'}")
    assert r.returncode == 2 and f"data.datasets[0].root={tmp_path / 'nowhere'} does not exist" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / "o").exists()

"""Typed configs: one source of defaults (the dataclasses), YAML holds only what differs,
one loader (`rvn_data.config.load_config`), and typos / wrong types stop every CLI at start-up."""
from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import asdict, fields

import pytest
from omegaconf import OmegaConf

from rvn_data.config import load_config, typed
from rvn_data.config_schemas import GenConfig
from rvn_data.render import RendererConfig
from rvn_data.scenes.sets import ScenesConfig
from rvn_data.conventions import AgentConfig
from rvn_data.dataset.settings import DatasetConfig, GenSettings
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.render.camera import CameraConfig
from rvn_il.models import load_model_config
from rvn_il.train.settings import DataConfig, TrainLoopConfig, complete_config, register_schema

register_schema()  # conf/train.yaml's schema, as rvn-train registers it

ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def plain(cfg) -> dict:
    return OmegaConf.to_container(cfg, resolve=True)


@pytest.mark.slow
@pytest.mark.parametrize("module, typo, wrong_type, messages", [
    ("rvn_data.gen.cli", "camera.widht=3", "camera.width=abc", ("camera.widht is not a setting of rvn-gen; nearest: "
                                                                "camera.width", "camera.width")),
    ("rvn_il.train.cli", "train.bach_size=4", "train.max_steps=many", ("train.bach_size is not a setting of rvn-train; "
                                                                        "nearest: train.batch_size", "train.max_steps")),
    ("rvn_data.benchmark.cli", "episodes.per_scne=3", "env.t_max=long", ("episodes.per_scne is not a setting of rvn-eval; "
                                                                         "nearest: episodes.per_scene", "env.t_max")),
])
def test_cli_rejects_typo_and_wrong_type_at_start_up(tmp_path, module, typo, wrong_type, messages):
    for arg, message in ((typo, messages[0]), (wrong_type, "could not be converted to Integer")):
        r = subprocess.run([sys.executable, "-m", module, f"out_dir={tmp_path / 'out'}", arg],
                           capture_output=True, text=True, env=ENV, timeout=120)
        assert r.returncode == 2, (arg, r.stdout, r.stderr)  # bad input, as every tool
        assert message in r.stderr and (arg == typo or messages[1] in r.stderr), r.stderr
    assert not (tmp_path / "out").exists()  # nothing was started


def test_group_yaml_holds_only_what_differs():
    cfg = plain(load_config("gen"))
    assert cfg["agent"] == asdict(AgentConfig())
    assert cfg["camera"] == asdict(CameraConfig())
    nav = asdict(NavMeshSettings(agent_radius=cfg["agent"]["r_robot"], agent_height=cfg["agent"]["h_robot"]))
    assert cfg["navmesh"] == nav
    assert cfg["dataset"] == asdict(DatasetConfig())
    assert cfg["renderer"] == asdict(RendererConfig())
    assert cfg["scenes"] == {**asdict(ScenesConfig()), "split": "train", "num_scenes": 4}
    other = plain(load_config("gen", ["agent.r_robot=0.2", "renderer=gl", "scenes=hm3d", "scenes.root=/data/hm3d"]))
    assert other["navmesh"]["agent_radius"] == 0.2
    assert other["renderer"] == {"backend": "gl", "device": 0}
    assert other["scenes"]["up_axis"] == "z" and other["scenes"]["root"] == "/data/hm3d"


def test_dataset_settings_agree_with_their_config():
    """GenSettings' defaults are DatasetConfig's: the default (expert) dataset plans with the
    same soft clearance whether built from the composed config or from the dataclass."""
    expert = GenSettings.resolve(typed(GenConfig, load_config("gen")))
    assert (expert.clearance_pref, expert.clearance_weight) == (GenSettings.clearance_pref, GenSettings.clearance_weight)
    assert expert.margin == pytest.approx(AgentConfig().r_robot + DatasetConfig().margin_offset)
    assert expert.stop_radius == pytest.approx(2 * AgentConfig().r_robot)
    negative = GenSettings.resolve(typed(GenConfig, load_config("gen", ["dataset=negative"])))
    assert negative.kind == "negative" and negative.name == "rvn_negative"
    assert negative.margin == pytest.approx(AgentConfig().r_robot - 0.1)
    assert "clearance_pref" not in negative.identity()  # plain shortest paths, as before clearance existed
    for name in ("k_pre", "k_post", "max_steps", "d_min", "jpeg_quality"):
        assert getattr(negative, name) == getattr(DatasetConfig, name)


def test_eval_config_defaults():
    cfg = load_config("eval", ["policy=random", "episodes.per_scene=2"])
    assert cfg.episodes.n_goals == 32 and cfg.episodes.per_scene == 2 and cfg.env.t_max == 500
    assert cfg.policy._target_.endswith("RandomPolicy")
    assert cfg.scenes.num_scenes is None and cfg.split == "val"


def test_train_config_defaults_and_completion():
    cfg = plain(load_config("train", ["model=vint_pointgoal", "train.lr=1e-3"]))
    assert list(cfg) == ["agent", "model", "seed", "device", "out_dir", "cache_dir", "data", "train"]
    assert cfg["data"] == asdict(DataConfig())
    assert cfg["train"] == {**asdict(TrainLoopConfig()), "lr": 1e-3}
    assert cfg["out_dir"] == "runs/train/vint_pointgoal"
    assert complete_config(cfg) == cfg
    partial = complete_config({"model": {"name": "vint_pointgoal"}, "data": {"root": "/d"}})
    assert partial["train"]["epochs"] == TrainLoopConfig.epochs and partial["data"]["crop"] == "aspect"
    assert partial["out_dir"] == "runs/train/vint_pointgoal"
    with pytest.raises(ValueError, match="train.epochs"):
        complete_config({**cfg, "train": {**cfg["train"], "epochs": "many"}})


def test_model_configs_compose_through_hydra():
    neg, base = load_model_config("nomad_neg"), load_model_config("nomad_pointgoal")
    assert neg["name"] == "nomad_neg" and neg["context_size"] == base["context_size"]
    assert neg["policy"]["selection"] == "argmax" and neg["policy"]["lookahead_min_dist"] == 0.125
    small = load_model_config("nomad_neg", "small", lr=3e-4)
    assert small["image_size"] == [64, 64] and small["batch_size"] == 32 and small["lr"] == 3e-4
    assert "sizes" not in small and small["size"] == "small"
    with pytest.raises(ValueError, match="unknown model 'nomad_big'"):
        load_model_config("nomad_big")
    assert {f.name for f in fields(DataConfig)} == set(load_config("train").data)

"""rvn-rl's typed settings (issue 33): conf/rl.yaml and conf/rl/algo/*.yaml hold only what differs from
`RLConfig`'s dataclasses, Hydra's config becomes one `RLConfig`, its checks give one line naming the setting,
and config.yaml records the settings in the layout rvn-rl has always written (rvn-eval's loader reads it)."""
from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import asdict, fields
from pathlib import Path

import pytest
import yaml

from rvn_data.benchmark.episodes import EpisodeSettings
from rvn_rl.cli import compose
from rvn_rl.config import TRAIN_EPISODE_KEYS, RLConfig
from rvn_rl.settings import CONF_RL, LAGRANGIAN, AlgoConfig, PPOConfig

TINY = ["env.size=32", "env.num_envs=2", "env.num_scenes=2", "ppo.num_mini_batch=2", "model.backbone=resnet18"]


def test_rl_yaml_holds_only_the_interpolations():
    raw = yaml.safe_load((CONF_RL.parent / "rl.yaml").read_text())
    assert raw["defaults"][0] == "base_rl"
    assert {k: v for k, v in raw.items() if k not in ("defaults", "hydra")} == {
        "camera": {"width": "${env.size}", "height": "${env.size}"}, "scenes": {"num_scenes": "${env.num_scenes}"}}


@pytest.mark.parametrize("path", sorted((CONF_RL / "algo").glob("*.yaml")), ids=lambda p: p.stem)
def test_algo_files_hold_only_what_differs(path: Path):
    raw = yaml.safe_load(path.read_text())
    assert raw["name"] == path.stem
    assert all(getattr(AlgoConfig, k) != v for k, v in raw.items() if k != "name"), raw


@pytest.mark.parametrize("path", sorted((CONF_RL / "scale").glob("*.yaml")), ids=lambda p: p.stem)
def test_scale_files_hold_only_what_differs(path: Path):
    defaults = asdict(RLConfig())  # scale=paper: the defaults are the paper's
    raw = yaml.safe_load(path.read_text()) or {}
    assert all(defaults[group][k] != v for group, values in raw.items() for k, v in values.items()), raw


def test_scale_paper_updates_by_ddppo_pointnav_settings():
    """scale=paper's ppo is habitat-baselines' ddppo_pointnav.yaml (PPO section; use_clipped_value_loss from its
    defaults): advantages as GAE gives them, not standardised; scale=small standardises them, as its runs always did."""
    ddppo_pointnav = {"clip_param": 0.2, "ppo_epoch": 2, "num_mini_batch": 2, "value_loss_coef": 0.5,
                      "entropy_coef": 0.01, "lr": 2.5e-4, "eps": 1e-5, "max_grad_norm": 0.2, "num_steps": 128,
                      "gamma": 0.99, "tau": 0.95, "use_normalized_advantage": False, "use_clipped_value_loss": True}
    paper = asdict(compose(["scale=paper"]).ppo)
    assert {k: paper[k] for k in ddppo_pointnav} == ddppo_pointnav
    assert compose([]).ppo.use_normalized_advantage is True  # scale=small, the default scale


def test_compose_gives_the_typed_tree():
    cfg = compose(TINY + ["train.total_steps=4e5", "algo=ddppo_depth", "depth.source=true"])
    assert isinstance(cfg, RLConfig) and isinstance(cfg.ppo, PPOConfig) and isinstance(cfg.episodes, EpisodeSettings)
    assert cfg.train.total_steps == 400000 and type(cfg.train.total_steps) is int  # 4e5 reads as a float
    assert cfg.depth.source == "true" and cfg.uses_true_depth and cfg.env_kwargs()["depth"] is True
    assert (cfg.camera.width, cfg.camera.height, cfg.scenes.num_scenes) == (32, 32, 2)  # they follow env
    assert cfg.ppo.num_steps == 64 and cfg.ppo.ppo_epoch == 4  # scale=small
    assert cfg.model_kwargs() == {"obs_size": 32, "backbone": "resnet18", "base_planes": 32, "ngroups": 16,
                                  "input_size": 128, "hidden_size": 512, "rnn_layers": 2, "use_depth": True,
                                  "cost_critic": False}


def test_record_keeps_config_yaml_layout():
    ppo = compose(TINY).record()
    assert list(ppo) == [f.name for f in fields(RLConfig)]
    assert list(ppo["algo"]) == ["name", "distributed", "lagrangian", "use_depth"]  # the Lagrangian settings act only there
    assert list(ppo["episodes"]) == list(TRAIN_EPISODE_KEYS)  # episodes.seed draws eval sets only
    assert ppo["ppo"] == {**asdict(PPOConfig()), "num_steps": 64, "ppo_epoch": 4, "num_mini_batch": 2,
                          "max_grad_norm": 0.5, "use_normalized_advantage": True}
    lag = compose(TINY + ["algo=ppo_lag", "algo.lambda_max=1.0"]).record()
    assert list(lag["algo"]) == ["name", "distributed", "lagrangian", "use_depth", *LAGRANGIAN]
    assert lag["algo"]["lambda_max"] == 1.0 and lag["algo"]["cost_limit"] == 1e-4


@pytest.mark.parametrize("args, line", [
    (["ppo.num_mini_batch=3"], "env.num_envs=2 is below ppo.num_mini_batch=3"),
    (["env.workers=3"], "env.workers=3 must be between 0 (in process) and env.num_envs=2"),
    (["camera.width=48"], "camera.width=48 differs from env.size=32"),
    (["train.total_steps=4.5"], "train.total_steps=4.5 must be a positive integer"),
    (["algo=ppo_lag", "algo.lambda_max=0"], "algo.lambda_max=0.0 must be > 0"),
    (["algo=ddppo_depth", "depth.source=sensor"], "depth.source='sensor': choose model"),
    (["algo=ddppo_depth", "depth.model_path=.", "env.depth=true"],
     "env.depth=true puts the rendered depth in the observation, which depth.source=model would train on"),
    (["episodes.seed=4"], "episodes.seed=4 does nothing in rvn-rl"),
    (["train.double_buffered=true", "env.workers=1"], "train.double_buffered=true steps one half of the env workers "
     "while the policy acts for the other: it needs env.workers >= 2 (env.workers=1)"),
])
def test_validate_names_the_setting(args, line):
    cfg = compose(TINY + args)
    with pytest.raises(ValueError) as err:
        cfg.validate()
    assert line in str(err.value) and "\n" not in str(err.value)


def test_group_dataclasses_check_their_values_at_conversion():
    """env first (camera.width and height follow env.size), then every group's own dataclass."""
    from rvn_data.cli.common import ConfigError

    with pytest.raises(ConfigError, match=r"^env.num_envs=0 must be a positive integer$"):
        compose(TINY + ["env.num_envs=0"])
    with pytest.raises(ConfigError, match=r"^env.size=0 must be a positive integer$"):
        compose(TINY + ["env.size=0"])
    with pytest.raises(ConfigError, match="camera setting hfov_deg=200.0 must be in"):
        compose(TINY + ["camera.hfov_deg=200"])
    with pytest.raises(ConfigError, match="d_min=9.0, d_max=8.0 must satisfy"):
        compose(TINY + ["episodes.d_min=9"])
    with pytest.raises(ConfigError, match=r"^env.scene_switch_every=0 and env.scene_switch_steps=0: an env would never"):
        compose(TINY + ["env.scene_switch_every=0"])


def test_scene_switch_steps_reach_the_envs():
    """env.scene_switch_steps (Habitat's max_scene_repeat_steps) goes to the train-mode envs and config.yaml."""
    cfg = compose(TINY + ["env.scene_switch_steps=10000", "env.scene_switch_every=0"])
    kw = cfg.env_kwargs()
    assert (kw["scene_switch_every"], kw["scene_switch_steps"]) == (0, 10000)
    assert cfg.record()["env"]["scene_switch_steps"] == 10000
    assert compose(TINY).env_kwargs()["scene_switch_steps"] == 0  # off by default: every 8 resets, as before


@pytest.mark.parametrize("world, args, line", [
    ("1", ["ppo.gamma=1.5"], "rvn-rl: error: ppo.gamma=1.5 must be in [0, 1]"),
    ("2", ["algo=ppo"], "rvn-rl: error: algo=ppo runs in one process; use algo=ddppo"),  # torchrun's WORLD_SIZE
])
def test_the_command_answers_bad_settings_before_loading_torch(tmp_path, world, args, line):
    """rvn-rl checks every settings rule (`RLConfig.validate`, at torchrun's world size) before it imports the
    trainer: one line and status 2 in about a second instead of after torch's ~2 s import; nothing written."""
    code = ("import sys, rvn_rl.cli\nsys.argv = ['rvn-rl', *sys.argv[1:]]\ntry:\n    rvn_rl.cli.main()\n"
            "except SystemExit as e:\n    print(e.code, 'torch' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code, f"out_dir={tmp_path / 'x'}", *TINY, *args], capture_output=True,
                          text=True, timeout=120, env={**os.environ, "WORLD_SIZE": world})
    assert proc.stdout.split() == ["2", "False"], proc.stdout + proc.stderr[-2000:]
    assert proc.stderr.strip().startswith(line), proc.stderr
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("size", [32, 48, 80, 100, 256])
def test_every_observation_size_validation_passes_builds_a_policy_that_acts(size):
    """env.size need not be a multiple of 32: the ResNet's output side is ceil(size / 32) (its stride-2 layers round
    up), which the compression and visual_fc are built for (48, 80 and 100 passed validation and failed at the first
    act on visual_fc's shape)."""
    import torch

    from rvn_rl.model import PointNavResNetPolicy

    cfg = compose(TINY + [f"env.size={size}"])
    cfg.validate()
    kw = {**cfg.model_kwargs(), "base_planes": 8, "ngroups": 4, "hidden_size": 16, "rnn_layers": 1}
    policy = PointNavResNetPolicy(**kw)
    obs = {"rgb": torch.zeros(2, size, size, 3, dtype=torch.uint8), "pointgoal": torch.ones(2, 2)}
    with torch.no_grad():
        action, _, values, _ = policy.act(obs, policy.initial_state(2), torch.zeros(2), torch.zeros(2))
    assert action.shape == (2,) and values.shape == (2, 1)


@pytest.mark.parametrize("failure", [False, True])
def test_stop_far_from_the_goal_ends_the_training_episode_only_when_asked(tmp_path, failure):
    """env.stop_far_is_failure goes to the train-mode envs: a STOP at an episode's start (the goal >= d_min away) is a
    no-op step by default (the benchmark's rule), the end of the episode with it (Habitat's PointNav)."""
    from rvn_rl.vec_env import BatchEnv

    cfg = compose(TINY + [f"out_dir={tmp_path / 'run'}", f"cache_dir={tmp_path / 'cache'}", "renderer=raycast",
                          f"env.stop_far_is_failure={str(failure).lower()}"])
    assert cfg.record()["env"]["stop_far_is_failure"] is failure
    envs = BatchEnv(cfg.env_kwargs(), 1, seed=0, prefetch=False)
    try:
        envs.reset()
        _, _, _, done, infos = envs.step([0])  # STOP
        assert bool(done[0]) is failure
        if failure:
            assert infos[0]["episode"]["termination"] == "stop_far" and infos[0]["episode"]["goals_reached"] == 0
    finally:
        envs.close()

"""rvn-rl's settings as one typed tree, `RLConfig` (conf/rl.yaml names it first, ``base_rl``, and holds only what
differs from it): the task side's groups (agent, camera, navmesh, renderer, scenes, episodes), rvn-rl's own
(`rvn_rl.settings`, ``ppo`` among them). rvn-rl turns Hydra's config into it once (`settings_of`), checks it
in one place (`RLConfig.validate`: types come from the schema, ranges and cross-field rules there) and derives
the environments' and the network's keyword arguments and the record config.yaml keeps from it."""
from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

from rvn_data.benchmark.episodes import EpisodeSettings
from rvn_data.cache_root import cache_root
from rvn_data.config import register, register_configs, typed
from rvn_data.conventions import AgentConfig
from rvn_data.embodiment import check_robot_settings
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.render import RendererConfig
from rvn_data.render.camera import CameraConfig
from rvn_data.scenes.sets import ScenesConfig
from rvn_il.train.choices import check_compile_mode, check_precision  # rvn-train's, for the same settings

from .settings import (ALGOS, LAGRANGIAN, AlgoConfig, DDPPOSettings, DepthSettings, EnvSettings, ModelSettings, PPOConfig,
                       TrainSettings, at_least)

# the episode settings that act in train mode, in the order config.yaml records them (seed draws eval sets only)
TRAIN_EPISODE_KEYS = ("n_goals", "d_min", "d_max", "max_tries", "max_restarts")


@dataclass
class RLConfig:
    """rvn-rl: algo=ppo|ppo_lag|ddppo|ddppo_depth scale=small|paper out_dir=... (conf/rl.yaml)."""

    agent: AgentConfig = field(default_factory=AgentConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)  # conf/rl.yaml: width = height = env.size
    navmesh: NavMeshSettings = field(default_factory=NavMeshSettings)
    renderer: RendererConfig = field(default_factory=RendererConfig)
    scenes: ScenesConfig = field(default_factory=ScenesConfig)  # conf/rl.yaml: num_scenes = env.num_scenes
    split: str = "train"  # RL trains on the train scenes
    seed: int = 0
    out_dir: str = "runs/rl/${algo.name}"
    cache_dir: str | None = None  # cache root (rvn_data/cache_root.py): null = $RVN_CACHE_DIR, else <out_dir>/cache
    device: str = "auto"  # auto | cpu | cuda (DD-PPO ranks use cuda:<local rank>)
    progress: bool = True
    env: EnvSettings = field(default_factory=EnvSettings)
    model: ModelSettings = field(default_factory=ModelSettings)
    ppo: PPOConfig = field(default_factory=PPOConfig)  # DD-PPO PointNav hyperparameters
    ddppo: DDPPOSettings = field(default_factory=DDPPOSettings)
    depth: DepthSettings = field(default_factory=DepthSettings)
    train: TrainSettings = field(default_factory=TrainSettings)
    episodes: EpisodeSettings = field(default_factory=EpisodeSettings)  # goal distances of the train episodes
    algo: AlgoConfig = field(default_factory=AlgoConfig)  # the algo group (conf/rl/algo/<name>.yaml)

    def validate(self, world_size: int = 1) -> None:
        """Every range and cross-field rule of an rvn-rl run; a one-line ValueError naming the setting."""
        if self.algo.name not in ALGOS:
            raise ValueError(f"algo={self.algo.name!r} is not an RL algorithm; choose one of {', '.join(ALGOS)}")
        env, ppo = self.env, self.ppo
        check_env(env)
        for key in ("width", "height"):  # conf/rl.yaml sets both to ${env.size}; a value given on its own would disagree
            value = getattr(self.camera, key)
            if value != env.size:
                raise ValueError(f"camera.{key}={value} differs from env.size={env.size}: the observation is "
                                 f"env.size pixels square; set env.size={value} (camera.width and height follow it)")
        check_robot_settings(self.agent, self.camera, self.navmesh)
        if not 0 <= env.workers <= env.num_envs:
            raise ValueError(f"env.workers={env.workers!r} must be between 0 (in process) and env.num_envs={env.num_envs}")
        for key in ("num_steps", "ppo_epoch", "num_mini_batch"):
            at_least(f"ppo.{key}", getattr(ppo, key))
        if env.num_envs < ppo.num_mini_batch:
            raise ValueError(f"env.num_envs={env.num_envs} is below ppo.num_mini_batch={ppo.num_mini_batch}: "
                             "each mini-batch holds whole rollouts of some envs; raise env.num_envs or lower num_mini_batch")
        self._check_ppo_values()
        at_least("seed", self.seed, minimum=0)
        at_least("train.keep_checkpoints", self.train.keep_checkpoints)
        if self.train.threads is not None:  # null: torch's setting
            at_least("train.threads", self.train.threads)
        at_least("train.total_steps", self.train.total_steps)
        check_precision(self.train.precision)
        check_compile_mode(self.train.compile_mode)
        at_least("train.checkpoint_every", self.train.checkpoint_every)
        if self.model.backbone not in ("resnet18", "resnet50"):
            raise ValueError(f"model.backbone={self.model.backbone!r}: choose resnet50 or resnet18")
        if world_size > 1 and not self.algo.distributed:
            raise ValueError(f"algo={self.algo.name} runs in one process; use algo=ddppo (or ddppo_depth) under torchrun")
        if self.train.overlap and (self.algo.distributed or world_size > 1):
            raise ValueError(f"train.overlap=true learns in a thread of one process; algo={self.algo.name} runs "
                             "DD-PPO's ranks, whose collectives that thread would interleave: use train.overlap=false")
        if self.train.double_buffered and env.workers < 2:
            raise ValueError(f"train.double_buffered=true steps one half of the env workers while the policy acts for "
                             f"the other: it needs env.workers >= 2 (env.workers={env.workers}); set env.workers=2 or "
                             "more, or train.double_buffered=false")
        if not 0.0 < self.ddppo.sync_frac <= 1.0:
            raise ValueError(f"ddppo.sync_frac={self.ddppo.sync_frac!r} must be in (0, 1]")
        self._check_depth()
        self._check_lagrangian()
        if self.episodes.seed != EpisodeSettings.seed:  # a setting that would act nowhere (and config.yaml omits)
            raise ValueError(f"episodes.seed={self.episodes.seed} does nothing in rvn-rl: its episodes are drawn "
                             f"from seed={self.seed}; leave episodes.seed out")

    def _check_ppo_values(self) -> None:
        """ppo's real-valued settings (else torch refuses some of them after out_dir is written)."""
        p = self.ppo
        for key in ("lr", "eps", "clip_param", "max_grad_norm"):
            if not getattr(p, key) > 0:
                raise ValueError(f"ppo.{key}={getattr(p, key)!r} must be > 0")
        for key in ("value_loss_coef", "entropy_coef"):
            if not getattr(p, key) >= 0:
                raise ValueError(f"ppo.{key}={getattr(p, key)!r} must be >= 0")
        for key in ("gamma", "tau"):
            if not 0 <= getattr(p, key) <= 1:
                raise ValueError(f"ppo.{key}={getattr(p, key)!r} must be in [0, 1]")

    def _check_depth(self) -> None:
        if not self.algo.use_depth:
            return
        source = self.depth.source
        if source not in ("model", "true"):
            raise ValueError(f"depth.source={source!r}: choose model (predicted depth) or true (rendered depth)")
        if source == "model":
            path = self.depth.model_path
            if not path:
                raise ValueError("algo=ddppo_depth with depth.source=model needs depth.model_path=<trained depth "
                                 "model> (or depth.source=true for the rendered depth)")
            if not Path(str(path)).expanduser().exists():
                raise ValueError(f"depth.model_path={path}: no such file or directory")
            if self.env.depth:  # the envs' rendered depth would fill obs["depth"], so the depth model would never run
                raise ValueError("env.depth=true puts the rendered depth in the observation, which depth.source=model "
                                 "would train on instead of the depth model's: leave env.depth out (or use "
                                 "depth.source=true)")

    def _check_lagrangian(self) -> None:
        algo = self.algo
        if not algo.lagrangian:  # the Lagrangian settings would act nowhere (and config.yaml omits them)
            given = [f"algo.{k}={getattr(algo, k)}" for k in LAGRANGIAN if getattr(algo, k) != getattr(AlgoConfig, k)]
            if given:
                raise ValueError(f"{given[0]} acts only in a Lagrangian algorithm (algo=ppo_lag), not algo={algo.name}")
            return
        if not float(algo.cost_limit) >= 0.0:
            raise ValueError(f"algo.cost_limit={algo.cost_limit!r} must be >= 0")
        if algo.lambda_max is not None and not float(algo.lambda_max) > 0.0:
            raise ValueError(f"algo.lambda_max={algo.lambda_max!r} must be > 0 (or null: no upper bound)")

    @property
    def uses_true_depth(self) -> bool:
        """The rendered depth is the 4th channel (algo=ddppo_depth depth.source=true)."""
        return bool(self.algo.use_depth) and self.depth.source == "true"

    @property
    def uses_predicted_depth(self) -> bool:
        """A frozen depth network predicts the 4th channel (algo=ddppo_depth depth.source=model)."""
        return bool(self.algo.use_depth) and self.depth.source == "model"

    def episode_kwargs(self) -> dict:
        return {k: getattr(self.episodes, k) for k in TRAIN_EPISODE_KEYS}

    def env_kwargs(self) -> dict:
        """`RVNEnv` keyword arguments of the train-mode environments (the typed groups as they are; the cache
        root, for the scenes' built navmeshes)."""
        scenes = {k: v for k, v in asdict(self.scenes).items() if k != "split"}
        e = self.env
        return {"mode": "train", "split": "train", "scenes": scenes, "agent": self.agent,
                "navmesh": self.navmesh, "camera": self.camera, "renderer": asdict(self.renderer),
                "episodes": self.episode_kwargs(), "t_max": e.t_max, "stop_far_is_failure": bool(e.stop_far_is_failure),
                "scene_switch_every": e.scene_switch_every,
                "scene_switch_steps": e.scene_switch_steps,
                "goal_pool": int(self.env.goal_pool), "depth": bool(self.env.depth) or self.uses_true_depth,
                "cache_dir": str(cache_root(self.cache_dir, self.out_dir).absolute())}

    def model_kwargs(self) -> dict:
        """`PointNavResNetPolicy` keyword arguments (also what a checkpoint's config.yaml records as ``policy``)."""
        m = self.model
        return {"obs_size": int(self.env.size), "backbone": m.backbone, "base_planes": int(m.base_planes),
                "ngroups": int(m.ngroups), "input_size": int(m.input_size), "hidden_size": int(m.hidden_size),
                "rnn_layers": int(m.rnn_layers), "use_depth": bool(self.algo.use_depth),
                "cost_critic": bool(self.algo.lagrangian)}

    def record(self) -> dict:
        """The settings as config.yaml records them (rvn_rl.policy.load_rl_policy reads agent, camera, depth, algo):
        every group in field order, the train-mode episode settings, the algo's settings that act; with predicted
        depth the depth model's digest (``depth.model_digest``: `rvn_rl.depth.model.model_digest`), which a resumed
        run must match (`rvn_rl.checkpoint.resume_point`)."""
        out = asdict(self)
        out["episodes"] = self.episode_kwargs()
        out["algo"] = self.algo.record()
        if self.uses_predicted_depth:
            from .depth.model import model_digest

            out["depth"]["model_digest"] = model_digest(str(self.depth.model_path))
        return out


def check_env(env: EnvSettings) -> None:
    """``env``'s ranges (`RLConfig.validate`'s first rules; `settings_of` applies them before the groups that follow env)."""
    for key in ("num_envs", "size", "t_max"):
        at_least(f"env.{key}", getattr(env, key))
    for key in ("scene_switch_every", "scene_switch_steps"):
        at_least(f"env.{key}", getattr(env, key), minimum=0)
    if not (env.scene_switch_every or env.scene_switch_steps):
        raise ValueError("env.scene_switch_every=0 and env.scene_switch_steps=0: an env would never draw another "
                         "scene; set one of them (e.g. env.scene_switch_steps=10000 env.scene_switch_every=0, Habitat's)")
    at_least("env.scene_cache + 1", env.scene_cache + 1)
    at_least("env.goal_pool", env.goal_pool, minimum=0)  # else the envs refuse these after out_dir is written
    if env.num_scenes is not None:  # null: all of the split's scenes
        at_least("env.num_scenes", env.num_scenes)


def world_size_from_env() -> int:
    """The number of processes of this run: torchrun's ``WORLD_SIZE``, else 1."""
    return int(os.environ.get("WORLD_SIZE", "1"))


def settings_of(cfg) -> RLConfig:
    """Hydra's composed rvn-rl config as `RLConfig` (`rvn_data.config.typed`: interpolations resolved; each group's
    dataclass checks its own values, ``env`` first: the camera's size and the scene count follow it, so env.size=0
    is named as itself); `ConfigError` (one line) for a missing or bad value. `RLConfig.validate` checks the rest."""
    from rvn_data.cli.common import validating

    with validating():
        check_env(typed(EnvSettings, cfg.env))
        return typed(RLConfig, cfg)


def register_schema() -> None:
    """Store rvn-rl's schema (``base_rl``, conf/rl.yaml's first default) and the task side's in Hydra's ConfigStore;
    rvn-rl calls it before composing."""
    register_configs()
    register("base_rl", RLConfig)

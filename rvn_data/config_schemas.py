"""Schemas of the task side's primary configs: rvn-gen (`GenConfig`, conf/gen.yaml) and
rvn-eval (`EvalConfig`, conf/eval.yaml). Field order is the order of the composed config.
Registered in Hydra's ConfigStore by `rvn_data.config.register_configs`."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rvn_data.benchmark.episodes import EpisodeSettings
from rvn_data.benchmark.episodes_source import EnvConfig
from rvn_data.render import RendererConfig
from rvn_data.scenes.sets import ScenesConfig
from rvn_data.conventions import AgentConfig
from rvn_data.dataset.settings import DatasetConfig
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.render.camera import CameraConfig


@dataclass
class GenConfig:
    """rvn-gen: which dataset, on which scenes, how much of it, in how many pieces."""

    agent: AgentConfig = field(default_factory=AgentConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    navmesh: NavMeshSettings = field(default_factory=NavMeshSettings)
    renderer: RendererConfig = field(default_factory=RendererConfig)
    scenes: ScenesConfig = field(default_factory=ScenesConfig)
    dataset: DatasetConfig = field(default_factory=DatasetConfig)
    split: str = "train"  # scene split (scenes.split follows it)
    seed: int = 0
    out_dir: str = "outputs/${dataset.name}"
    trajectories_per_scene: int = 10  # paper: 400
    shard_index: int = 0  # this process does scenes shard_index, shard_index + num_shards, ...
    num_shards: int = 1
    workers: int = 1  # processes on this node, one scene at a time each
    mode: str = "generate"  # generate | merge (write splits + manifest from the scenes done)
    allow_partial: bool = False  # merge: also when some scenes are not done yet
    progress: bool = True  # tqdm bars


_E = EpisodeSettings


@dataclass(frozen=True)
class EvalEpisodesConfig:
    """rvn-eval's ``episodes``: which episodes are run, and how they are drawn (the fields of
    `EpisodeSettings`, with its defaults and meaning)."""

    # cache of generated episode sets, one folder per episode settings inside (null: <cache root>/episodes)
    dir: str | None = None
    num_scenes: int | None = None  # null = every scene of the split (paper: 800 train / 50 val / 50 test)
    first_scene: int = 0
    per_scene: int | None = None  # null = paper: 2 per train scene, 20 per val / test scene
    n_goals: int = _E.n_goals
    d_min: float = _E.d_min
    d_max: float = _E.d_max
    seed: int = _E.seed
    max_tries: int = _E.max_tries
    max_restarts: int = _E.max_restarts


@dataclass(frozen=True)
class EvalEnvConfig:
    """rvn-eval's ``env``: the episode rules (defaults: `EnvConfig`)."""

    t_max: int = EnvConfig.t_max  # steps allowed per goal
    success_distance: float | None = EnvConfig.success_distance  # m; null = 2 * agent.r_robot (geodesic, as Habitat)
    success_metric: str = EnvConfig.success_metric  # geodesic | euclidean
    stop_far_is_failure: bool = EnvConfig.stop_far_is_failure  # STOP far from the goal: a no-op step (false) or a failure
    depth: bool = EnvConfig.depth  # also render depth into the observations


@dataclass
class EvalConfig:
    """rvn-eval: one policy on a split's fixed episode set."""

    agent: AgentConfig = field(default_factory=AgentConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    navmesh: NavMeshSettings = field(default_factory=NavMeshSettings)
    renderer: RendererConfig = field(default_factory=RendererConfig)
    scenes: ScenesConfig = field(default_factory=ScenesConfig)
    policy: Any = field(default_factory=dict)  # any object with reset() and act(obs), built from its _target_
    split: str = "val"
    seed: int = 0
    method: str | None = None  # row label in the table; null = the checkpoint folder's name, else the policy config's
    # runs/eval/<split>/<method, else the checkpoint folder's name, else the policy's> (config.eval_run_name)
    out_dir: str = ("runs/eval/${split}/${rvn_eval_name:${method},${hydra:runtime.choices.policy},"
                    "${oc.select:policy.checkpoint_path,null}}")
    # cache root (rvn_data/cache_root.py): null = $RVN_CACHE_DIR, else <out_dir>/cache; set
    # RVN_CACHE_DIR (or cache_dir=) to one folder to share episode sets between evaluations
    cache_dir: str | None = None
    workers: int = 1  # worker processes, each with its own env and renderer
    resume: bool = True  # skip episodes already in out_dir/episodes.jsonl
    progress: bool = True
    # a policy trained for another robot or camera (rvn_data/embodiment.py): error (one line, before any episode) |
    # allow (announced, recorded in run.json and metrics.json as embodiment_mismatch)
    embodiment_mismatch: str = "error"
    episodes: EvalEpisodesConfig = field(default_factory=EvalEpisodesConfig)
    env: EvalEnvConfig = field(default_factory=EvalEnvConfig)

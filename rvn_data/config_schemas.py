"""Schemas of the task side's primary configs: rvn-gen (`GenConfig`, conf/gen.yaml) and
rvn-eval (`EvalConfig`, conf/eval.yaml). Field order is the order of the composed config.
Registered in Hydra's ConfigStore by `rvn_data.config.register_configs`."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Any

from rvn_data.benchmark.episodes import EpisodeSettings
from rvn_data.benchmark.episodes_source import EnvConfig, EpisodeRules
from rvn_data.render import RendererConfig
from rvn_data.scenes.sets import ScenesConfig
from rvn_data.conventions import AgentConfig
from rvn_data.dataset.settings import DatasetConfig
from rvn_data.embodiment import check_robot_settings
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

    def __post_init__(self) -> None:
        if not 0 <= self.shard_index < self.num_shards:
            raise ValueError(f"shard_index={self.shard_index} must be in [0, num_shards={self.num_shards})")
        if self.trajectories_per_scene < 0:
            raise ValueError(f"trajectories_per_scene={self.trajectories_per_scene} must be >= 0")
        if self.mode not in ("generate", "merge"):
            raise ValueError(f"mode={self.mode!r} must be generate or merge")
        if self.workers < 1:
            raise ValueError(f"workers={self.workers} must be >= 1")
        check_robot_settings(self.agent, self.camera, self.navmesh)


@dataclass(frozen=True)
class EvalEpisodesConfig(EpisodeSettings):
    """rvn-eval's ``episodes``: how episodes are drawn (`EpisodeSettings`, whose fields it inherits) and
    which of them are run."""

    # cache of generated episode sets, one folder per episode settings inside (null: <cache root>/episodes)
    dir: str | None = None
    num_scenes: int | None = None  # null = every scene of the split (paper: 800 train / 50 val / 50 test)
    first_scene: int = 0
    per_scene: int | None = None  # null = paper: 2 per train scene, 20 per val / test scene


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
    # runs/eval/<split>/<method, else the checkpoint folder's name (+ _ckpt<n> with policy.step or policy.env_steps),
    # else the policy's>, + _first_scene<N> when
    # episodes.first_scene is not 0: the shards of a multirun over it get a folder each (config.eval_run_name)
    out_dir: str = ("runs/eval/${split}/${rvn_eval_name:${method},${hydra:runtime.choices.policy},"
                    "${oc.select:policy.checkpoint_path,null},${episodes.first_scene},${oc.select:policy.step,null},"
                    "${oc.select:policy.env_steps,null}}")
    # cache root (rvn_data/cache_root.py): null = $RVN_CACHE_DIR, else <out_dir>/cache; set
    # RVN_CACHE_DIR (or cache_dir=) to one folder to share episode sets between evaluations
    cache_dir: str | None = None
    workers: int = 1  # worker processes, each with its own env and renderer
    resume: bool = True  # skip episodes already in out_dir/episodes.jsonl
    progress: bool = True
    # record each episode's poses (out_dir/paths/) and draw a map a scene of where they went and how they ended
    # (out_dir/maps/; collision clips: python -m rvn_data.benchmark.trace_maps out_dir --clips N); not in the run's
    # identity: it changes no result
    paths: bool = False
    # a policy trained for another robot or camera (rvn_data/embodiment.py): error (one line, before any episode) |
    # allow (announced, recorded in run.json and metrics.json as embodiment_mismatch)
    embodiment_mismatch: str = "error"
    episodes: EvalEpisodesConfig = field(default_factory=EvalEpisodesConfig)
    env: EpisodeRules = field(default_factory=EpisodeRules)

    def __post_init__(self) -> None:
        if self.workers < 1:
            raise ValueError(f"workers={self.workers!r} must be a positive integer (worker processes)")

    def env_config(self) -> EnvConfig:
        """`RVNEnv`'s settings (eval mode) for this run: the typed groups as they are, the episode cache under
        ``episodes.dir``, else the cache root's ``episodes/`` (`rvn_data.cache_root`), built navmeshes in its
        ``navmesh/``."""
        from rvn_data.cache_root import cache_root

        eps, root = self.episodes, cache_root(self.cache_dir, self.out_dir)
        draw = {f.name: getattr(eps, f.name) for f in fields(EpisodeSettings)}
        scenes = {k: v for k, v in asdict(self.scenes).items() if k != "split"}
        return EnvConfig.from_kwargs(
            mode="eval", split=self.split, scenes=scenes, agent=self.agent, navmesh=self.navmesh, camera=self.camera,
            renderer=asdict(self.renderer), episodes=EpisodeSettings(**draw),
            episodes_dir=str(eps.dir or root / "episodes"), cache_dir=str(root.absolute()), per_scene=eps.per_scene,
            **asdict(self.env))

    def record(self) -> dict:
        """The run's settings as plain data (its identity: `rvn_data.benchmark.results.run_identity`)."""
        return asdict(self)

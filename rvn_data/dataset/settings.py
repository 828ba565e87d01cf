"""Settings of a trajectory dataset (`DatasetConfig`: conf/dataset/*.yaml), validated, with its identity.

A dataset's *identity* is everything that changes the bytes of a trajectory: the kind,
margins, ranges, budgets, the agent, navmesh, camera, renderer request, JPEG quality and
the seed. How much is generated (scenes, trajectories per scene, shards, workers) is not
part of it, so a run can be extended or resumed into the same output directory.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from rvn_data.conventions import AgentConfig
from rvn_data.navmesh.settings import NavMeshSettings, recorded
from rvn_data.render.camera import CameraConfig

KINDS = ("expert", "negative")


@dataclass(frozen=True)
class DatasetConfig:
    """The ``dataset`` group of rvn-gen (conf/dataset/*.yaml hold only what differs from these).

    Expert trajectories: A* on the occupancy grid with obstacles inflated by a margin LARGER
    than r_robot; kept only when the follower reaches the goal without a collision. Negative
    trajectories: a margin SMALLER than r_robot; the follower runs into an obstacle at t_c and
    frames t_c - k_pre .. t_c + k_post are kept (image frozen at I_{t_c} after it).
    """

    kind: str = "expert"  # expert | negative
    name: str = "rvn_expert"  # dataset name: data_splits/<name>/, data_config.yaml key
    margin: float | None = None  # m, obstacle inflation for A*; null = agent.r_robot + margin_offset
    margin_offset: float = 0.1  # m, margin - r_robot (expert > 0, negative < 0)
    # m; soft clearance on top of the margin: A* moves closer than this to an obstacle cost up to
    # 1 + clearance_weight times their length (ROS-costmap-style decaying inflation, planning/astar.py), so
    # paths keep to corridor middles; clearance_pref null / clearance_weight 0: plain shortest paths that graze the margin
    clearance_pref: float | None = 0.5
    clearance_weight: float = 4.0
    d_min: float = 4.0  # m, path length range [d_min, d_max]
    d_max: float = 8.0
    # chance per step of a perturbing turn the expert then recovers from (DART-style noise injection;
    # labels stay the expert path's positions): 1..perturb_max_turns turns of theta_step to one side
    perturb_prob: float = 0.0
    perturb_max_turns: int = 2
    # starts anywhere on the navmesh like the benchmark's (inside the margin too: the path first
    # leaves it); false: only starts outside the margin
    start_anywhere: bool = True
    k_pre: int = 8  # negative only: steps kept before the collision
    k_post: int = 6  # negative only: steps kept after it (k_post + 1 collision/post-collision frames)
    max_steps: int = 400  # step budget of one rollout
    max_attempts: int = 40  # start/goal draws per trajectory before it is given up
    goal_candidates: int = 32  # goal draws per start (geodesic distance in [d_min, d_max])
    resolution: float = 0.05  # m, occupancy grid cell
    stop_radius: float | None = None  # m, STOP this close to the goal; null = 2 * agent.r_robot
    jpeg_quality: int = 90
    # also write <traj>/depth.npy: float16 [T, S, S] rendered depth in metres (frame i of i.jpg; S = depth_size:
    # block mean over the pixels that hit something, 0 where none did) for rvn-train's model.depth_aux_weight;
    # false: the folders hold exactly the GNM files and rvn_meta.json
    save_depth: bool = False
    depth_size: int = 16
    train_fraction: float = 0.8  # share of scenes in data_splits/<name>/train

    def __post_init__(self) -> None:
        """Ranges and rules; the types are the schema's (Hydra and `rvn_data.config.typed` check them)."""
        if self.kind not in KINDS:
            raise ValueError(f"dataset.kind={self.kind!r} must be one of {KINDS}")
        if not self.name or any(c in self.name for c in "/\\ \n"):
            raise ValueError(f"dataset.name={self.name!r} must be a non-empty folder name")
        for key in ("margin", "d_min", "d_max", "resolution", "stop_radius", "train_fraction"):
            value = getattr(self, key)
            if value is not None and not (math.isfinite(value) and value >= 0):
                raise ValueError(f"dataset.{key}={value!r} must be a finite number >= 0")
        if not 0 < self.d_min <= self.d_max:
            raise ValueError(f"dataset.d_min={self.d_min} and dataset.d_max={self.d_max} need 0 < d_min <= d_max")
        if self.resolution <= 0 or self.resolution > 0.5:
            raise ValueError(f"dataset.resolution={self.resolution} must be in (0, 0.5] metres")
        if self.train_fraction > 1:
            raise ValueError(f"dataset.train_fraction={self.train_fraction} must be in [0, 1]")
        if self.clearance_pref is not None and not (math.isfinite(self.clearance_pref) and self.clearance_pref > 0):
            raise ValueError(f"dataset.clearance_pref={self.clearance_pref!r} must be null or a positive distance in metres "
                             f"(at or below the margin, {self.margin} m, it changes nothing)")
        if not (math.isfinite(self.clearance_weight) and self.clearance_weight >= 0):
            raise ValueError(f"dataset.clearance_weight={self.clearance_weight!r} must be a finite number >= 0")
        if not 0 <= self.perturb_prob < 1:
            raise ValueError(f"dataset.perturb_prob={self.perturb_prob!r} must be a probability in [0, 1)")
        for key in ("k_pre", "k_post", "jpeg_quality"):
            if getattr(self, key) < 0:
                raise ValueError(f"dataset.{key}={getattr(self, key)!r} must be an integer >= 0")
        for key in ("perturb_max_turns", "max_steps", "max_attempts", "goal_candidates", "depth_size"):
            if getattr(self, key) < 1:
                raise ValueError(f"dataset.{key}={getattr(self, key)} must be >= 1")
        if not 1 <= self.jpeg_quality <= 100:
            raise ValueError(f"dataset.jpeg_quality={self.jpeg_quality} must be in [1, 100]")



# What a dataset's trajectories depend on beyond its settings, recorded in .rvn/settings.json: bump when the same
# settings make other trajectories, so a dataset begun by other code is not resumed, extended or repaired with this
# one's; rvn-rl's depth pairs files record it too (made anew when it differs). 3: gl's batched depth at image sizes
# whose W x H is not a multiple of 4 (depth sidecars were 0 or another batch's). 2: the navmesh's clearance exact
# near thin obstacles and corners (7001f36: the expert's occupancy grid and the simulator's edges move by up to a
# cell). 1: a record without it.
DATASET_VERSION = 3

# how a scene's mesh is read (rvn_data.scenes.sets.ScenesConfig), at its defaults: a trajectory's bytes depend on them
# (a scan read z-up or y-up is another scene); .rvn/settings.json records them, a trajectory's record where not these
SCENE_LOADING = {"up_axis": "y", "unit_scale": 1.0, "level": False}


@dataclass(frozen=True)
class GenSettings(DatasetConfig):
    """One dataset's resolved generation settings: the ``dataset`` group (`DatasetConfig`, whose fields
    and defaults it inherits) with margin and stop_radius resolved against the agent, plus the seed,
    agent, navmesh, camera and renderer request. Made by `resolve` from rvn-gen's typed config."""

    margin: float = 0.28  # m, the resolved obstacle inflation (r_robot + margin_offset unless given)
    stop_radius: float = AgentConfig().success_distance  # m, the resolved STOP radius (2 * r_robot unless given)
    seed: int = 0
    renderer: str = "auto"
    render_device: int = 0  # GPU index for the GL back-end (not part of the identity)
    agent: AgentConfig = field(default_factory=AgentConfig)
    navmesh: NavMeshSettings = field(default_factory=NavMeshSettings)
    camera: CameraConfig = field(default_factory=CameraConfig)
    scenes: dict = field(default_factory=lambda: dict(SCENE_LOADING))  # how meshes are read (`SCENE_LOADING`)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.seed < 0:
            raise ValueError(f"dataset.seed={self.seed!r} must be an integer >= 0")
        from rvn_data.render import BACKENDS

        if self.renderer not in BACKENDS or self.render_device < 0:
            raise ValueError(f"renderer.backend={self.renderer!r}, renderer.device={self.render_device!r}: choose a "
                             f"backend of {', '.join(BACKENDS)} and a device index >= 0")

    @property
    def max_frames(self) -> int:
        """Frames of one negative trajectory at most: k_pre + k_post + 1."""
        return self.k_pre + self.k_post + 1

    def identity(self) -> dict[str, Any]:
        """JSON-able dict of everything that determines a trajectory's bytes."""
        out = asdict(self)
        out["navmesh"] = recorded(out["navmesh"])  # navmesh source/file only when not the defaults
        del out["render_device"], out["margin_offset"]  # margin_offset: the resolved margin is recorded
        if self.clearance_pref is None or self.clearance_weight == 0:  # off: datasets made before it keep their identity
            del out["clearance_pref"], out["clearance_weight"]
        if self.perturb_prob == 0:
            del out["perturb_prob"], out["perturb_max_turns"]
        if not self.save_depth:
            del out["save_depth"], out["depth_size"]
        if self.scenes == SCENE_LOADING:  # the defaults: trajectories' records as before they were recorded
            del out["scenes"]
        return out

    @classmethod
    def resolve(cls, config) -> "GenSettings":
        """From rvn-gen's typed config (`rvn_data.config_schemas.GenConfig`)."""
        ds, agent = config.dataset, config.agent
        values = {f.name: getattr(ds, f.name) for f in fields(DatasetConfig)}
        if ds.margin is None:
            values["margin"] = round(agent.r_robot + ds.margin_offset, 6)
        if ds.stop_radius is None:
            values["stop_radius"] = agent.success_distance
        return cls(**values, seed=config.seed, renderer=str(config.renderer.backend).lower(),
                   render_device=config.renderer.device, agent=agent, navmesh=config.navmesh, camera=config.camera,
                   scenes={k: type(default)(getattr(config.scenes, k)) for k, default in SCENE_LOADING.items()})

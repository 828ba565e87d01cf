"""Settings of a trajectory dataset (`DatasetConfig`: conf/dataset/*.yaml), validated, with its identity.

A dataset's *identity* is everything that changes the bytes of a trajectory: the kind,
margins, ranges, budgets, the agent, navmesh, camera, renderer request, JPEG quality and
the seed. How much is generated (scenes, trajectories per scene, shards, workers) is not
part of it, so a run can be extended or resumed into the same output directory.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping

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


_D = DatasetConfig


@dataclass(frozen=True)
class GenSettings:
    """One dataset's resolved generation settings: a `DatasetConfig` with margin and stop_radius
    resolved against the agent, plus the seed, agent, navmesh, camera and renderer request.
    Defaults and the meaning of each field: `DatasetConfig`."""

    kind: str = _D.kind
    name: str = _D.name
    seed: int = 0
    margin: float = 0.28  # m, the resolved obstacle inflation (default: r_robot + margin_offset)
    clearance_pref: float | None = _D.clearance_pref
    clearance_weight: float = _D.clearance_weight
    d_min: float = _D.d_min
    d_max: float = _D.d_max
    k_pre: int = _D.k_pre
    k_post: int = _D.k_post
    perturb_prob: float = _D.perturb_prob
    perturb_max_turns: int = _D.perturb_max_turns
    start_anywhere: bool = _D.start_anywhere
    max_steps: int = _D.max_steps
    max_attempts: int = _D.max_attempts
    goal_candidates: int = _D.goal_candidates
    resolution: float = _D.resolution
    stop_radius: float = AgentConfig().success_distance  # m, the resolved STOP radius (2 * r_robot)
    jpeg_quality: int = _D.jpeg_quality
    save_depth: bool = _D.save_depth
    depth_size: int = _D.depth_size
    train_fraction: float = _D.train_fraction
    renderer: str = "auto"
    render_device: int = 0  # GPU index for the GL back-end (not part of the identity)
    agent: AgentConfig = field(default_factory=AgentConfig)
    navmesh: dict = field(default_factory=dict)
    camera: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"dataset.kind={self.kind!r} must be one of {KINDS}")
        if not self.name or any(c in self.name for c in "/\\ \n"):
            raise ValueError(f"dataset.name={self.name!r} must be a non-empty folder name")
        for key in ("margin", "d_min", "d_max", "resolution", "stop_radius", "train_fraction"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise ValueError(f"dataset.{key}={value!r} must be a finite number >= 0")
        if not 0 < self.d_min <= self.d_max:
            raise ValueError(f"dataset.d_min={self.d_min} and dataset.d_max={self.d_max} need 0 < d_min <= d_max")
        if self.resolution <= 0 or self.resolution > 0.5:
            raise ValueError(f"dataset.resolution={self.resolution} must be in (0, 0.5] metres")
        if self.train_fraction > 1:
            raise ValueError(f"dataset.train_fraction={self.train_fraction} must be in [0, 1]")
        if self.clearance_pref is not None and (isinstance(self.clearance_pref, bool) or not isinstance(
                self.clearance_pref, (int, float)) or not math.isfinite(self.clearance_pref) or self.clearance_pref <= 0):
            raise ValueError(f"dataset.clearance_pref={self.clearance_pref!r} must be null or a positive distance in metres "
                             f"(at or below the margin, {self.margin} m, it changes nothing)")
        if isinstance(self.clearance_weight, bool) or not isinstance(self.clearance_weight, (int, float)) \
                or not math.isfinite(self.clearance_weight) or self.clearance_weight < 0:
            raise ValueError(f"dataset.clearance_weight={self.clearance_weight!r} must be a finite number >= 0")
        if not isinstance(self.start_anywhere, bool):
            raise ValueError(f"dataset.start_anywhere={self.start_anywhere!r} must be true or false")
        if isinstance(self.perturb_prob, bool) or not isinstance(self.perturb_prob, (int, float)) \
                or not 0 <= self.perturb_prob < 1:
            raise ValueError(f"dataset.perturb_prob={self.perturb_prob!r} must be a probability in [0, 1)")
        for key in ("k_pre", "k_post", "perturb_max_turns", "max_steps", "max_attempts", "goal_candidates", "jpeg_quality", "seed"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f"dataset.{key}={value!r} must be an integer >= 0")
        for key in ("perturb_max_turns", "max_steps", "max_attempts", "goal_candidates"):
            if getattr(self, key) < 1:
                raise ValueError(f"dataset.{key}={getattr(self, key)} must be >= 1")
        if not isinstance(self.save_depth, bool):
            raise ValueError(f"dataset.save_depth={self.save_depth!r} must be true or false")
        if isinstance(self.depth_size, bool) or not isinstance(self.depth_size, int) or self.depth_size < 1:
            raise ValueError(f"dataset.depth_size={self.depth_size!r} must be a positive integer")
        if not 1 <= self.jpeg_quality <= 100:
            raise ValueError(f"dataset.jpeg_quality={self.jpeg_quality} must be in [1, 100]")

    @property
    def max_frames(self) -> int:
        """Frames of one negative trajectory at most: k_pre + k_post + 1."""
        return self.k_pre + self.k_post + 1

    def identity(self) -> dict[str, Any]:
        """JSON-able dict of everything that determines a trajectory's bytes."""
        out = asdict(self)
        out["agent"] = asdict(self.agent)
        out["navmesh"] = recorded(self.navmesh)  # navmesh source/file only when not the defaults
        del out["render_device"]
        if self.clearance_pref is None or self.clearance_weight == 0:  # off: datasets made before it keep their identity
            del out["clearance_pref"], out["clearance_weight"]
        if self.perturb_prob == 0:
            del out["perturb_prob"], out["perturb_max_turns"]
        if not self.save_depth:
            del out["save_depth"], out["depth_size"]
        return out

    @classmethod
    def from_config(cls, cfg: Mapping[str, Any]) -> "GenSettings":
        """From the composed `rvn-gen` config (keys dataset, agent, navmesh, camera, renderer, seed)."""
        ds = dict(cfg["dataset"])
        agent = AgentConfig(**{k: v for k, v in dict(cfg["agent"]).items()})
        offset = ds.pop("margin_offset", _D.margin_offset if ds.get("kind", _D.kind) == "expert" else -_D.margin_offset)
        if ds.get("margin") is None:
            ds["margin"] = round(agent.r_robot + float(offset), 6)
        if ds.get("stop_radius") is None:
            ds["stop_radius"] = agent.success_distance
        renderer, device = cfg.get("renderer", "auto"), 0
        if isinstance(renderer, Mapping):
            renderer, device = renderer.get("backend", "auto"), int(renderer.get("device", 0) or 0)
        known = {f for f in cls.__dataclass_fields__} - {"agent", "navmesh", "camera", "renderer", "render_device", "seed"}
        unknown = sorted(set(ds) - known)
        if unknown:
            raise ValueError(f"unknown dataset setting(s) {unknown}; known: {sorted(known)}")
        floats = {"margin", "clearance_pref", "clearance_weight", "perturb_prob", "d_min", "d_max", "resolution", "stop_radius", "train_fraction"}
        ds = {k: (float(v) if k in floats and isinstance(v, int) and not isinstance(v, bool) else v) for k, v in ds.items()}
        navmesh = dict(cfg.get("navmesh", {}))
        NavMeshSettings.from_config(navmesh)  # checked here, before any scene: a bad value is one error, not one per scene
        CameraConfig.from_dict(cfg.get("camera", {}))  # likewise
        from rvn_data.render import BACKENDS

        if str(renderer).lower() not in BACKENDS or isinstance(device, bool) or device < 0:
            raise ValueError(f"renderer.backend={renderer!r}, renderer.device={device!r}: choose a backend of "
                             f"{', '.join(BACKENDS)} and a device index >= 0")
        return cls(seed=cfg.get("seed", 0), renderer=str(renderer), render_device=device, agent=agent,
                   navmesh=navmesh, camera=dict(cfg.get("camera", {})), **ds)

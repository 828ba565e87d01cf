"""Benchmark episodes: a start pose and N_goal sequential goals.

Each goal lies at geodesic distance in [d_min, d_max] from the previous one (the first
from the start), on the start's island and floor (within `SAME_FLOOR` = 0.5 m of the start's height, Habitat's
PointNav rule: stairs join floors into one island, and a point goal (x, y) upstairs would lie above the agent);
starts are drawn over the navmesh's sampled islands
(`NavMesh.sampled_islands`: the main island, island 0, unless navmesh.islands=all). Episode
``e`` of scene ``s`` (its index in the split) of split ``split`` is a pure function of the settings and of
``np.random.default_rng([seed, SPLIT_CODES[split], s, e])``, so episode ``e`` is the same
whatever the number of episodes or scenes asked for. Goals are drawn by rejection:
uniform navigable points of the start's island, kept when the geodesic distance field of
the previous goal puts them in range. Files and caching: `rvn_data.benchmark.episodes_store`.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from rvn_data.conventions import SAME_FLOOR, AgentConfig
from rvn_data.navmesh.settings import NavMeshSettings, recorded
from rvn_data.scenes import SceneError

# Part of every episode set's key: bump when the same settings draw other episodes. 2: the
# navmesh's doorway fix (issue 17: a lintel no longer widens one jamb) moves procedural edges. 3: goals on the
# start's floor (SAME_FLOOR), which changes the episodes of scenes with stairs only (single-floor scenes draw the
# same episodes: the rule rejects none of their candidates and draws nothing from the random stream). 4: the
# navmesh's clearance exact near thin and slanted obstacles and inner corners (it was up to a cell too large there):
# every scene loses 13-66 cells of its edges, so starts and goals are drawn on another area.
GENERATOR_VERSION = 4
SCENE_OPTION_KEYS = ("source", "up_axis", "unit_scale", "level")  # scene loading options an episode depends on
SPLIT_CODES = {"train": 0, "val": 1, "test": 2}
DEFAULT_PER_SCENE = {"train": 2, "val": 20, "test": 20}


@dataclass(frozen=True)
class EpisodeSettings:
    """How episodes are drawn (rvn-eval's ``episodes``, schema `rvn_data.config_schemas.EvalEpisodesConfig`, a subclass).

    d_min, d_max: geodesic distance range between consecutive goals (m); n_goals: goals
    per episode (N_goal); seed: the set's seed; max_tries: candidate points drawn per goal
    before the episode restarts from a new start; max_restarts: restarts before the scene
    is declared too small (SceneError).
    """

    d_min: float = 4.0  # m, geodesic distance between consecutive goals
    d_max: float = 8.0
    n_goals: int = 32  # N_goal
    seed: int = 0  # rvn-eval: its top-level seed
    max_tries: int = 500  # candidate points per goal before restarting the episode
    max_restarts: int = 20  # restarts before the scene is declared too small

    def __post_init__(self) -> None:
        if not (math.isfinite(self.d_min) and math.isfinite(self.d_max) and 0 <= self.d_min < self.d_max):
            raise ValueError(f"episode settings d_min={self.d_min!r}, d_max={self.d_max!r} "
                             "must satisfy 0 <= d_min < d_max (metres)")
        for name in ("n_goals", "max_tries", "max_restarts"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"episode setting {name}={value!r} must be a positive integer")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"episode setting seed={self.seed!r} must be a non-negative integer")

    @classmethod
    def from_dict(cls, cfg) -> "EpisodeSettings":
        """Build from a mapping; keys that are not settings (dir, per_scene, ...) are ignored."""
        data = dict(cfg.items()) if hasattr(cfg, "items") else dict(cfg)
        names = {f.name for f in fields(cls)}
        kw = {k: v for k, v in data.items() if k in names and v is not None}
        for k in ("n_goals", "seed", "max_tries", "max_restarts"):
            if isinstance(kw.get(k), float) and float(kw[k]).is_integer():
                kw[k] = int(kw[k])
        for k in ("d_min", "d_max"):
            if k in kw:
                kw[k] = float(kw[k])
        return cls(**kw)

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass
class Episode:
    """One benchmark episode. Positions are world [3] (y up); goals float64 [n_goals, 3];
    goal_distances[k] = geodesic distance of goal k from goal k-1 (goal 0: from start)."""

    scene_id: str
    scene_index: int
    episode_index: int
    start_position: np.ndarray
    start_yaw: float
    goals: np.ndarray
    goal_distances: list[float] = field(default_factory=list)

    @property
    def episode_id(self) -> str:
        return f"{self.scene_id}#{self.episode_index}"

    def to_json(self) -> dict:
        return {
            "episode_index": int(self.episode_index),
            "start_position": [float(v) for v in self.start_position],
            "start_yaw": float(self.start_yaw),
            "goals": [[float(v) for v in g] for g in self.goals],
            "goal_distances": [float(d) for d in self.goal_distances],
        }

    @classmethod
    def from_json(cls, data: dict, scene_id: str, scene_index: int) -> "Episode":
        return cls(
            scene_id=scene_id,
            scene_index=int(scene_index),
            episode_index=int(data["episode_index"]),
            start_position=np.asarray(data["start_position"], dtype=np.float64),
            start_yaw=float(data["start_yaw"]),
            goals=np.asarray(data["goals"], dtype=np.float64).reshape(-1, 3),
            goal_distances=[float(d) for d in data["goal_distances"]],
        )


def split_code(split: str) -> int:
    """The integer that keys a split's random streams."""
    try:
        return SPLIT_CODES[split]
    except KeyError:
        raise ValueError(f"unknown split {split!r}; expected one of {sorted(SPLIT_CODES)}") from None


def episode_rng(seed: int, split: str, scene_index: int, episode_index: int) -> np.random.Generator:
    """The random stream of one episode."""
    return np.random.default_rng([int(seed), split_code(split), int(scene_index), int(episode_index)])


def sample_goal(navmesh, source_field, rng: np.random.Generator, d_min: float, d_max: float,
                max_tries: int, island: int = 0, floor_y: float | None = None) -> tuple[np.ndarray, float] | None:
    """A point of ``island`` (the source's) at geodesic distance in [d_min, d_max] from the field's
    source, within `SAME_FLOOR` of the height ``floor_y`` (None: any height), with that distance; None after
    ``max_tries`` rejected candidates."""
    for _ in range(max_tries):
        p = np.asarray(navmesh.sample(rng, island=island), dtype=np.float64)
        if floor_y is not None and abs(p[1] - floor_y) > SAME_FLOOR:
            continue
        d = float(source_field.distance(p))
        if d_min <= d <= d_max:
            return p, d
    return None


def sample_start(navmesh, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """A position uniform over the navmesh's sampled islands and a uniform yaw in [-π, π)."""
    p = np.asarray(navmesh.sample(rng), dtype=np.float64)
    return p, float(rng.uniform(-math.pi, math.pi))


def sample_episode(navmesh, settings: EpisodeSettings, split: str, scene_id: str,
                   scene_index: int, episode_index: int) -> tuple[Episode, list]:
    """Draw one episode; also returns the distance fields of its goals (field k = to goal
    k), which an evaluation can reuse. Raises SceneError naming the scene when no valid
    goal chain is found."""
    rng = episode_rng(settings.seed, split, scene_index, episode_index)
    for _ in range(settings.max_restarts):
        start, yaw = sample_start(navmesh, rng)
        island = navmesh.goal_island(start)
        source, goals, dists, goal_fields = start, [], [], []
        src_field = navmesh.distance_field(start)
        while len(goals) < settings.n_goals:
            found = sample_goal(navmesh, src_field, rng, settings.d_min, settings.d_max, settings.max_tries, island,
                                float(start[1]))
            if found is None:
                break
            source, d = found
            goals.append(source)
            dists.append(d)
            src_field = navmesh.distance_field(source)
            goal_fields.append(src_field)
        if len(goals) == settings.n_goals:
            ep = Episode(scene_id, scene_index, episode_index, start, yaw, np.stack(goals), dists)
            return ep, goal_fields
    raise SceneError(
        f"scene {scene_id}: no chain of {settings.n_goals} goals {settings.d_min}-{settings.d_max} m "
        f"apart found on {'the main island' if navmesh.sampled_islands == [0] else 'its islands'} after "
        f"{settings.max_restarts} restarts "
        f"(episode {episode_index}); the scene is too small for d_min/d_max: lower episodes.d_min/d_max")


def sample_episodes(navmesh, settings: EpisodeSettings, split: str, scene_id: str,
                    scene_index: int, episode_indices) -> list[Episode]:
    """Episodes with the given indices (each from its own random stream)."""
    return [sample_episode(navmesh, settings, split, scene_id, scene_index, e)[0] for e in episode_indices]


def _floats(d: dict) -> dict:
    return {k: (float(v) if isinstance(v, int) and not isinstance(v, bool) else v) for k, v in d.items()}


def settings_record(episodes: EpisodeSettings, agent: AgentConfig, navmesh: NavMeshSettings, scenes: dict,
                  split: str) -> dict:
    """What an episode set depends on, as recorded in (and checked against) every episode file of it and
    hashed into its cache folder's name (`rvn_data.benchmark.episodes_store`): the generator, split, episode,
    agent and navmesh settings and the scene loading options."""
    scene_opts = {k: scenes.get(k) for k in SCENE_OPTION_KEYS}
    if scene_opts["unit_scale"] is not None:
        scene_opts["unit_scale"] = float(scene_opts["unit_scale"])
    return {
        "generator_version": GENERATOR_VERSION,
        "split": split,
        "episodes": episodes.as_dict(),
        "agent": _floats(asdict(agent)),
        "navmesh": _floats(recorded(asdict(navmesh))),  # source/file only when not the defaults
        "scenes": scene_opts,
    }

"""Where `RVNEnv` gets its scenes and episodes: the env settings (`EnvConfig`), one loaded
scene with its navmesh, simulator, renderer and cached episodes (`SceneSlot`), and the
order in which an evaluation walks a fixed episode set (`eval_schedule`)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace

from rvn_data.cache_root import cache_root
from rvn_data.render import RendererConfig
from rvn_data.scenes.sets import ScenesConfig
from rvn_data.conventions import AgentConfig
from rvn_data.embodiment import check_robot_settings
from rvn_data.benchmark.episodes import DEFAULT_PER_SCENE, EpisodeSettings, sample_goal, settings_record, split_code
from rvn_data.benchmark.episodes_store import EpisodeStore
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.navmesh.source import open_scene
from rvn_data.render.camera import CameraConfig

SCENE_DEFAULTS = {k: v for k, v in asdict(ScenesConfig()).items() if k != "split"}


def _mapping(obj) -> dict:
    if obj is None:
        return {}
    return dict(obj.items()) if hasattr(obj, "items") else dict(obj)


@dataclass
class EpisodeRules:
    """The rules an episode is run by (rvn-eval's ``env`` group; part of `EnvConfig`): steps allowed per
    goal, when a goal counts as reached, what STOP far from it means, and whether depth is rendered."""

    t_max: int = 500  # steps allowed per goal
    success_distance: float | None = None  # m; null = 2 * agent.r_robot (geodesic, as Habitat)
    success_metric: str = "geodesic"  # geodesic | euclidean
    stop_far_is_failure: bool = False  # STOP far from the goal: a no-op step (false) or a failure
    depth: bool = False  # also render depth into the observations


@dataclass
class EnvConfig(EpisodeRules):
    """`RVNEnv` settings: the `EpisodeRules` and where scenes and episodes come from. Nested settings may be given as dataclasses or mappings (the
    Hydra groups ``agent``, ``navmesh``, ``camera``, ``scenes``, ``renderer``, ``episodes``).

    scene_specs: explicit scene specs (overrides ``scenes``); per_scene: eval episodes per
    scene (default 2 train / 20 val, test); scene_switch_every: train mode draws another scene every this many resets
    (0: not by resets); scene_switch_steps: ... or at the first reset after this many steps in the scene (0: not by
    steps; Habitat's ``max_scene_repeat_steps``, 10,000 there, each visit's budget within +-20 % of it, Habitat's
    ``step_repetition_range``, so envs started together do not switch together), whichever comes first;
    episodes_dir: cache of eval episode sets (None: ``<cache root>/episodes``; one folder per settings inside);
    cache_dir: the cache root (`rvn_data.cache_root`; None: ``$RVN_CACHE_DIR``, else a temporary folder, with a
    warning), whose ``navmesh/`` keeps every scene's built navmesh (`rvn_data.navmesh.disk_cache`).
    """

    mode: str = "train"
    split: str | None = None
    scenes: dict = field(default_factory=dict)
    scene_specs: list | None = None
    agent: AgentConfig = field(default_factory=AgentConfig)
    navmesh: NavMeshSettings | None = None
    camera: CameraConfig = field(default_factory=CameraConfig)
    renderer: dict = field(default_factory=dict)
    episodes: EpisodeSettings = field(default_factory=EpisodeSettings)
    episodes_dir: str | None = None
    cache_dir: str | None = None
    per_scene: int | None = None
    scene_switch_every: int = 8
    scene_switch_steps: int = 0
    goal_pool: int = 0
    reward_goal: float = 1.0
    reward_collision: float = -0.1
    slack_penalty: float = 0.01

    @classmethod
    def from_kwargs(cls, **kw) -> "EnvConfig":
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(kw) - known)
        if unknown:
            raise ValueError(f"unknown RVNEnv setting(s) {unknown}; known: {sorted(known)}")
        agent = kw.get("agent")
        if not isinstance(agent, AgentConfig):
            agent = AgentConfig(**_mapping(agent))
        nav = kw.get("navmesh")
        if not isinstance(nav, NavMeshSettings):
            nav = NavMeshSettings.from_config({"agent_radius": agent.r_robot, "agent_height": agent.h_robot,
                                               **_mapping(nav)})
        cam = kw.get("camera")
        if not isinstance(cam, CameraConfig):
            cam = CameraConfig.from_dict(_mapping(cam))
        eps = kw.get("episodes")
        eps_map = {} if isinstance(eps, EpisodeSettings) else _mapping(eps)
        if not isinstance(eps, EpisodeSettings):
            eps = EpisodeSettings.from_dict(eps_map)
        kw = dict(kw, agent=agent, navmesh=nav, camera=cam, episodes=eps,
                  scenes={**SCENE_DEFAULTS, **_mapping(kw.get("scenes"))},
                  renderer={**asdict(RendererConfig()), **_mapping(kw.get("renderer"))})
        for key in ("dir", "per_scene"):  # accepted inside the `episodes` mapping too
            name = "episodes_dir" if key == "dir" else key
            if eps_map.get(key) is not None and kw.get(name) is None:
                kw[name] = eps_map[key]
        cfg = cls(**kw)
        cfg.validate()
        return cfg

    def validate(self) -> None:
        """Fill the split's defaults (split, success_distance, per_scene) and check every range; idempotent."""
        if self.mode not in ("train", "eval"):
            raise ValueError(f"RVNEnv mode={self.mode!r} must be 'train' or 'eval'")
        if self.split is None:
            self.split = "train" if self.mode == "train" else "val"
        split_code(self.split)
        if self.success_metric not in ("geodesic", "euclidean"):
            raise ValueError(f"success_metric={self.success_metric!r} must be 'geodesic' or 'euclidean'")
        if self.success_distance is None:
            self.success_distance = self.agent.success_distance
        if self.per_scene is None:
            self.per_scene = DEFAULT_PER_SCENE[self.split]
        for name in ("t_max", "per_scene", "scene_switch_every", "scene_switch_steps", "goal_pool"):
            v, least = getattr(self, name), 1 if name in ("t_max", "per_scene") else 0
            if isinstance(v, bool) or not isinstance(v, int) or v < least:
                raise ValueError(f"RVNEnv setting {name}={v!r} must be a "
                                 f"{'non-negative' if least == 0 else 'positive'} integer")
        if not (self.scene_switch_every or self.scene_switch_steps):
            raise ValueError("RVNEnv settings scene_switch_every=0 and scene_switch_steps=0: train mode would never "
                             "draw another scene; set one of them (e.g. scene_switch_steps=10000, Habitat's)")
        if not self.success_distance > 0:
            raise ValueError(f"RVNEnv setting success_distance={self.success_distance!r} must be > 0")
        check_robot_settings(self.agent, self.camera, self.navmesh)

    @property
    def split_code(self) -> int:
        return split_code(self.split)

    def scene_slots(self, setting: str = "scenes.first_scene") -> list[tuple[str, int]]:
        """(spec, scene index within the split) of every scene this env uses; ``setting``: the
        command's name for ``scenes.first_scene`` (rvn-eval: episodes.first_scene), for its errors."""
        first = int(self.scenes.get("first_scene") or 0)
        if self.scene_specs is not None:
            specs = [str(s) for s in self.scene_specs]
        else:
            from rvn_data.scenes.sets import scene_specs
            s = self.scenes
            specs = list(scene_specs(s["source"], self.split, root=s.get("root"),
                                     num_scenes=s.get("num_scenes"), first_scene=first, setting=setting))
        if not specs:
            group = setting.rsplit(".", 1)[0]
            raise ValueError(f"no scenes for split {self.split!r} ({group}.num_scenes={self.scenes.get('num_scenes')}, "
                             f"{setting}={first}); ask for at least one scene")
        return [(spec, first + i) for i, spec in enumerate(specs)]

    def store(self) -> EpisodeStore:
        settings = settings_record(self.episodes, self.agent, self.navmesh, self.scenes, self.split)
        root = self.episodes_dir or self.cache_folder() / "episodes"
        return EpisodeStore(root, self.split, settings, self.scenes.get("root"))

    def cache_folder(self):
        """The cache root: ``cache_dir``, else ``$RVN_CACHE_DIR``, else a temporary folder (with a warning)."""
        return cache_root(self.cache_dir)

    def pool_folder(self):
        """Where train-mode goal pools are kept (`rvn_data.benchmark.pool_cache`): the cache root's ``goal_pools``."""
        return self.cache_folder() / "goal_pools"

    def with_(self, **changes) -> "EnvConfig":
        return replace(self, **changes)


class SceneSlot:
    """One loaded scene: navmesh, simulator, renderer and its episode list (eval)."""

    def __init__(self, pos, spec, scene_index, scene, navmesh, simulator, renderer):
        self.pos, self.spec, self.scene_index = pos, spec, scene_index
        self.scene, self.navmesh, self.simulator, self.renderer = scene, navmesh, simulator, renderer
        self._episodes = self._goal_sampler = None
        self.gl_arrays = None  # the scene's `mesh_arrays` when made ahead (`prepared_parts`), until `with_renderer`

    @property
    def scene_id(self) -> str:
        return self.scene.scene_id

    @classmethod
    def open(cls, config: EnvConfig, slot: tuple[str, int], pos: int) -> "SceneSlot":
        return cls.load(config, slot, pos).with_renderer(config)

    @classmethod
    def load(cls, config: EnvConfig, slot: tuple[str, int], pos: int) -> "SceneSlot":
        """The scene, its navmesh and simulator, without a renderer (`with_renderer`): what may be prepared in another
        thread, since a GL context belongs to the thread that renders."""
        return cls.from_parts(config, slot, pos, *cls.scene_and_navmesh(config, slot))

    @staticmethod
    def scene_and_navmesh(config: EnvConfig, slot: tuple[str, int]) -> tuple:
        """The slot's scene and its navmesh (built, or read from the cache root's navmesh cache)."""
        return open_scene(slot[0], config.scenes, config.navmesh, config.cache_folder())

    @classmethod
    def from_parts(cls, config: EnvConfig, slot: tuple[str, int], pos: int, scene, navmesh) -> "SceneSlot":
        """The slot of a loaded scene and navmesh (its simulator made here), without a renderer."""
        from rvn_data.sim import Simulator

        return cls(pos, *slot, scene, navmesh, Simulator(navmesh, config.agent), None)

    @classmethod
    def prepared_parts(cls, config: EnvConfig, slot: tuple[str, int], with_pool: bool) -> tuple:
        """(scene, navmesh, goal pool or None, GL mesh arrays or None) of a slot, as `load`, `goal_sampler` and
        `with_renderer` make them: what rvn-rl's scene prefetch has a helper process prepare (`rvn_data.helper_process`)
        and send back; the pool only ``with_pool``, the GL renderer's arrays (`rvn_data.render.mesh_arrays`, ~9 ms of
        the ~11 ms a GL renderer took to make at the switch) unless the renderer is raycast.
        The navmesh comes with its geodesic graph built (5-10 MB more to send, ~2 ms to read back), which a pool's
        solves make and the env's first goal draw needs: where this process keeps the pool (``with_pool`` false), the
        env's own thread built it at that draw, 26-110 ms a procedural scene in the middle of a batched step."""
        from rvn_data.benchmark.goal_pool import GoalPool

        scene, navmesh = cls.scene_and_navmesh(config, slot)
        navmesh._ensure_graph()
        pool = None
        if with_pool:
            pool = GoalPool.build(navmesh, config.goal_pool, config.split_code, slot[1], config.pool_folder())
        arrays = None
        if str(config.renderer.get("backend", "auto")).lower() != "raycast":
            from rvn_data.render.mesh_arrays import mesh_arrays
            arrays = mesh_arrays(scene)
        return scene, navmesh, pool, arrays

    def with_renderer(self, config: EnvConfig) -> "SceneSlot":
        from rvn_data.render import make_renderer

        self.renderer = make_renderer(self.scene, config.camera, backend=config.renderer.get("backend", "auto"),
                                      device=int(config.renderer.get("device", 0)), gl_arrays=self.gl_arrays)
        self.gl_arrays = None
        return self

    def episodes(self, config: EnvConfig) -> list:
        """The scene's first ``config.per_scene`` episodes (generated and cached if missing)."""
        if self._episodes is None:
            store = config.store()
            self._episodes = store.episodes_for(self.scene_index, self.spec, config.per_scene, None,
                                                loaded=(self.scene, self.navmesh))
        return self._episodes

    def goal_sampler(self, config: EnvConfig, pool=None):
        """This scene's train-mode goal pool (`rvn_data.benchmark.goal_pool`), on first use taken from the process's
        cache of pools or built (``pool``: built elsewhere, which the cache then keeps)."""
        if self._goal_sampler is None:
            from rvn_data.benchmark.goal_pool import PoolSampler, pool_for
            pool = pool_for(self.navmesh, pool_key(config, (self.spec, self.scene_index)), pool, config.pool_folder())
            self._goal_sampler = PoolSampler(self.navmesh, pool)
        return self._goal_sampler

    def draw_goal(self, config: EnvConfig, position, rng):
        """(goal, its field or None) for train mode from ``position``: from this scene's goal pool when
        ``goal_pool`` > 0 and one is in range, else a fresh uniform draw (two distance fields, 8.9 ms median; with a
        pool of 64 none of 200 procedural train scenes' 10,000 random starts or 12,800 pool goals, where a trained
        policy draws its next goal, had none in range: benchmarks/pool_fallback.py); None if none was found."""
        s = config.episodes
        if config.goal_pool:
            found = self.goal_sampler(config).sample(position, rng, s.d_min, s.d_max)
            if found is not None:
                return found
        found = sample_goal(self.navmesh, self.navmesh.distance_field(position), rng, s.d_min, s.d_max, s.max_tries,
                            self.navmesh.goal_island(position), float(position[1]))
        return None if found is None else (found[0], None)

    def close(self) -> None:
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None


def pool_key(config: EnvConfig, slot: tuple[str, int]):
    """The `rvn_data.benchmark.goal_pool.PoolKey` of a scene slot's goal pool under ``config``."""
    from rvn_data.benchmark.goal_pool import PoolKey

    spec, scene_index = slot
    return PoolKey((spec, repr(config.navmesh), repr(sorted(config.scenes.items()))), int(config.goal_pool),
                   int(config.split_code), int(scene_index))


def eval_schedule(slots: list, per_scene: int) -> list[tuple[int, int]]:
    """(scene position, episode index) pairs in evaluation order: scene by scene."""
    return [(pos, e) for pos in range(len(slots)) for e in range(per_scene)]


def next_in_schedule(schedule: list, slots: list, cursor: int, options: dict, split: str, rewind: bool) -> int:
    """Index in ``schedule`` of the episode an eval-mode reset gives: ``options`` ``episode`` (k-th of
    the set) or ``scene_index`` [+ ``episode_index``]; else the one at ``cursor`` (0 with ``rewind``:
    a reset with a seed), wrapping at the end."""
    cursor = 0 if rewind else cursor
    if "episode" in options:
        cursor = int(options["episode"])
        if not 0 <= cursor < len(schedule):
            raise ValueError(f"episode={cursor} out of range: this {split} set has {len(schedule)} episodes")
    elif "scene_index" in options:
        key = (int(options["scene_index"]), int(options.get("episode_index", 0)))
        matches = [k for k, (pos, e) in enumerate(schedule) if (slots[pos][1], e) == key]
        if not matches:
            raise ValueError(f"no episode {key[1]} of scene index {key[0]} in this {split} set")
        cursor = matches[0]
    return cursor if 0 <= cursor < len(schedule) else cursor % max(1, len(schedule))


def ensure_scene_episodes(config: EnvConfig, slot: tuple[str, int]) -> int:
    """Make sure the first ``config.per_scene`` episodes of a scene are cached; loads the
    scene and builds its navmesh only when they must be generated. Returns the count."""
    spec, scene_index = slot

    return len(config.store().episodes_for(scene_index, spec, config.per_scene,
                                           lambda: open_scene(spec, config.scenes, config.navmesh,
                                                              config.cache_folder())))

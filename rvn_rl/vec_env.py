"""`BatchEnv`: N `RVNEnv`s stepped in one process, one call per batch, with same-step
autoreset: when an episode ends, the returned observation is the first one of the next
episode and ``done`` is set, so a rollout never attributes a new episode's frame to the
last action of the previous one (the transition's reward is the ending step's; the
recurrent state and previous action are masked out from the next step on).

Each env keeps its last few loaded scenes (navmesh, simulator, renderer) in a small LRU
cache, so switching back to a scene does not rebuild its navmesh, and has the next scene it
will switch to prepared in a helper process while it steps (``env.prefetch_scenes``: the same
scenes and episodes). An optional
``depth_fn(rgb uint8 [N,H,W,3]) -> float32 [N,H,W]`` fills ``obs["depth"]`` from the RGB
batch (predicted depth); with ``depth=True`` in the env settings the rendered depth is used.
"""
from __future__ import annotations

import logging
from collections import OrderedDict
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from rvn_data.benchmark.env import RVNEnv
from rvn_data.benchmark.episodes_source import SceneSlot, pool_key
from rvn_data.benchmark.goal_pool import cached_pool
from rvn_data.helper_process import HelperProcess
from rvn_data.render import render_views


class CachedSceneEnv(RVNEnv):
    """`RVNEnv` that keeps up to ``scene_cache`` scenes loaded besides the current one and, with ``prefetch``,
    has the scene its next switch will draw prepared while it steps (`_draw_scene`)."""

    def __init__(self, scene_cache: int = 2, prefetch: bool = True, **kwargs):
        super().__init__(**kwargs)
        self.scene_cache, self.prefetch = int(scene_cache), bool(prefetch)
        self._cache: OrderedDict[int, SceneSlot] = OrderedDict()
        self._ahead = None  # (scene stream, position, Future of its SceneSlot or None): the next switch's scene
        self._ready: tuple[int, Future] | None = None  # the drawn scene's prepared slot, for `_load`
        self._threads: ThreadPoolExecutor | None = None
        self.prefetched = 0  # switches that found their scene prepared (or being prepared)
        self._helper: HelperProcess | None = None  # where `_prepare` has the scene made, started on first use

    def _draw_scene(self) -> int:
        """The scene stream's next draw; with ``prefetch``, also the one after it, whose scene (navmesh, simulator,
        goal pool: all but the renderer) is prepared (`_prepare`) while this scene's episodes run. The stream is used
        for nothing else, so drawing ahead gives the same scenes in the same order: only the wait at a switch goes.
        Vectorised envs step together, so an env loading a scene (~0.1 s) and building its goal pool (~0.3 s)
        held up every env of the batch; in 15 workers, one or another of them did at most steps."""
        ahead, self._ahead = self._ahead, None
        if ahead is not None and ahead[0] is self._scene_rng:
            pos, future = ahead[1], ahead[2]
        else:  # the stream was started again (a reset with a seed): what was drawn ahead is not next
            pos, future = super()._draw_scene(), None
        self._ready = None if future is None else (pos, future)
        if self.prefetch:  # prepared by `_prepare_ahead` once `_load` has made ``pos`` current
            self._ahead = (self._scene_rng, super()._draw_scene(), None)
        return pos

    def _prepare_ahead(self) -> None:
        """Start preparing the scene drawn ahead, unless it is being prepared already or is loaded: the current
        scene or in the cache, which only `_load` changes."""
        if self._ahead is None or self._ahead[2] is not None:
            return
        stream, nxt, _ = self._ahead
        if nxt != self._scene.pos and nxt not in self._cache:
            self._ahead = (stream, nxt, self._executor().submit(self._prepare, nxt))

    def _executor(self) -> ThreadPoolExecutor:
        if self._threads is None:
            self._threads = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rvn-scene-prefetch")
        return self._threads

    def _prepare(self, pos: int) -> SceneSlot:
        """The scene's slot without its renderer, run in a thread: the scene, its navmesh and goal pool (unless this
        process keeps it) are made in the env's helper process (`rvn_data.helper_process`), and this thread, which only
        waits for them, makes the simulator. Made in the thread (with the pool's solves alone in a helper), they took
        turns with the env's steps for the GIL: a scene took 0.9 s to load there against 0.05-0.1 s alone, and a
        switch often waited for it (2 envs in one process, 200 scenes, goal pool 64, 2-core development CPU: 349-364
        env steps/s, 433-442 so; benchmarks/scene_prefetch.py, 2 envs in one worker: 300-327 and 357-472)."""
        config, slot = self.config, self._slots[pos]
        config = config.with_(cache_dir=str(config.cache_folder()))  # the helper's cache root is this process's
        with_pool = bool(config.goal_pool) and cached_pool(pool_key(config, slot)) is None
        if self._helper is None:
            self._helper = HelperProcess()
        scene, navmesh, pool, gl_arrays = self._helper.call(SceneSlot.prepared_parts, config, slot, with_pool)
        prepared = SceneSlot.from_parts(config, slot, pos, scene, navmesh)
        prepared.gl_arrays = gl_arrays  # the GL renderer's numpy work, done: the switch only uploads it
        if config.goal_pool:
            prepared.goal_sampler(config, pool)
        return prepared

    def _load(self, pos: int) -> None:
        self._switch_to(pos)
        self._prepare_ahead()

    def _switch_to(self, pos: int) -> None:
        ready, self._ready = self._ready, None
        if self._scene is not None and self._scene.pos == pos:
            return
        slot = self._cache.pop(pos, None)
        if slot is None and ready is not None and ready[0] == pos:
            slot = ready[1].result().with_renderer(self.config)  # its error, if it failed, is this reset's
            self.prefetched += 1
        if slot is None:
            slot = SceneSlot.open(self.config, self._slots[pos], pos)
        if self._scene is not None:
            self._cache[self._scene.pos] = self._scene
        while len(self._cache) > self.scene_cache:
            self._cache.popitem(last=False)[1].close()
        self._scene = slot

    def close(self) -> None:
        if self._threads is not None:
            self._threads.shutdown(wait=True, cancel_futures=True)
            self._threads = None
        if self._helper is not None:
            self._helper.close()
            self._helper = None
        self._ahead = self._ready = None
        while self._cache:
            self._cache.popitem()[1].close()
        super().close()


def quiet_scene_logs() -> None:
    """After a run's first reset, in every process that steps envs: the first scenes' lines (each env's renderer, and
    why ``renderer=auto`` picked it) are in the run's log, the thousands of scene switches after them are not."""
    logging.getLogger("rvn").setLevel(logging.WARNING)


def env_seed(seed: int, rank: int, index: int) -> int:
    """The reset seed of env ``index`` of rank ``rank``, a pure function of the config seed."""
    return int(np.random.SeedSequence([int(seed), int(rank), int(index)]).generate_state(1)[0])


class BatchEnv:
    """``num_envs`` train-mode envs; ``reset()`` then ``step(actions)`` on batches."""

    def __init__(self, env_kwargs: dict, num_envs: int, seed: int = 0, rank: int = 0, scene_cache: int = 2,
                 depth_fn=None, index_offset: int = 0, prefetch: bool = True):
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"env.num_envs={num_envs!r} must be a positive integer")
        self.num_envs, self.seed, self.rank, self.offset = num_envs, int(seed), int(rank), int(index_offset)
        self.depth_fn = depth_fn
        self.envs: list[CachedSceneEnv] = []
        try:
            for _ in range(num_envs):
                self.envs.append(CachedSceneEnv(scene_cache=scene_cache, prefetch=prefetch, **env_kwargs))
        except Exception:
            self.close()
            raise
        self.observation_space = self.envs[0].observation_space
        self._ret = np.zeros(num_envs)
        self._cost = np.zeros(num_envs)

    def _batch(self, obs_list: list[dict]) -> dict:
        out = {"rgb": np.stack([o["rgb"] for o in obs_list]),
               "pointgoal": np.stack([o["pointgoal"] for o in obs_list]).astype(np.float32)}
        if "depth" in obs_list[0]:
            out["depth"] = np.stack([o["depth"] for o in obs_list]).astype(np.float32)
        elif self.depth_fn is not None:
            out["depth"] = np.asarray(self.depth_fn(out["rgb"]), dtype=np.float32)
        return out

    def _observe(self) -> list[dict]:
        """Every env's observation, their frames rendered together (`render_views`: with gl, one pass
        and one GPU synchronisation for the envs' scenes instead of one per env)."""
        frames = render_views([env.view() for env in self.envs], depth=self.envs[0].config.depth)
        return [env.observation(rgb, depth) for env, (rgb, depth) in zip(self.envs, frames)]

    def reset(self) -> dict:
        self._ret[:] = 0.0
        self._cost[:] = 0.0
        for i, env in enumerate(self.envs):
            env.reset_state(seed=env_seed(self.seed, self.rank, self.offset + i))
        return self._batch(self._observe())

    def step(self, actions) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray, list[dict]]:
        """(obs, reward [N], cost [N], done [N], infos). A finished episode's info holds
        ``episode`` (its record with ``return`` and ``cost`` added); its obs is the next
        episode's first."""
        actions = np.asarray(actions).reshape(-1)
        if actions.shape[0] != self.num_envs:
            raise ValueError(f"BatchEnv.step: {actions.shape[0]} actions for {self.num_envs} envs")
        infos = []
        reward = np.zeros(self.num_envs, np.float32)
        cost = np.zeros(self.num_envs, np.float32)
        done = np.zeros(self.num_envs, bool)
        for i, (env, a) in enumerate(zip(self.envs, actions)):
            r, terminated, truncated, info = env.step_state(int(a))
            reward[i], cost[i] = r, info["cost"]
            self._ret[i] += r
            self._cost[i] += info["cost"]
            if terminated or truncated:
                done[i] = True
                info["episode"] = {**info["episode"], "return": float(self._ret[i]), "cost": float(self._cost[i])}
                self._ret[i] = self._cost[i] = 0.0
                env.reset_state()
            infos.append(info)
        return self._batch(self._observe()), reward, cost, done, infos

    def close(self) -> None:
        for env in self.envs:
            env.close()
        self.envs = []

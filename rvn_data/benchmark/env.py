"""`RVNEnv`: the RVN task as a Gymnasium environment (observations,
the paper's reward and the Safe-RL collision cost).

Observation: ``rgb`` uint8 [H,W,3], ``pointgoal`` float32 [2] (x forward, y left,
metres), ``depth`` float32 [H,W] when ``depth=True``. Actions: ``Discrete(4)``
(`rvn_data.conventions.Action`).

Per step the env moves the agent, builds a `measures.StepRecord` and takes the reward,
``info["cost"]`` and the episode's ending from `rvn_data.benchmark.measures` (the one
definition of each; the paper's values): STOP within ``success_distance`` (default 2·r_robot,
geodesic as Habitat's Success; ``success_metric="euclidean"``: the straight-line floor
distance) → +1.0 and the next goal (train: sampled from the current pose; eval: the episode's
next goal), scene and pose kept, terminated (success) after N_goal goals; a collision
(`Simulator` step with ``collided``) → −0.1, cost 1.0, terminated (failure); STOP farther
away → a no-op step (or a terminating failure with ``stop_far_is_failure``); otherwise
−Δ(geodesic distance to goal) − 0.01. No goal within ``t_max`` steps of being given →
truncated (failure).

Modes: ``train`` draws random episodes with the benchmark sampler from ``np_random`` (goals from a fixed per-scene
pool with ``goal_pool`` > 0: `rvn_data.benchmark.goal_pool`) and switches scene every ``scene_switch_every`` resets,
or at the first reset after ``scene_switch_steps`` steps in the scene (Habitat's ``max_scene_repeat_steps``; each
visit's budget within +-20 %, `SCENE_STEPS_RANGE`); ``eval`` walks the fixed episode set of the split in order (scene,
then episode); ``reset(seed=...)`` rewinds it to the first episode and ``options={"episode": k}`` (k-th of the set) or
``{"scene_index": s, "episode_index": e}`` picks one.
"""
from __future__ import annotations

import math
import operator

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from rvn_data.conventions import Action, relative_goal, to_planar
from rvn_data.benchmark import measures
from rvn_data.benchmark.episodes import sample_start
from rvn_data.benchmark.episodes_source import EnvConfig, SceneSlot, eval_schedule, next_in_schedule
from rvn_data.benchmark.metrics import EpisodeTracker
from rvn_data.scenes import SceneError

SCENE_STEPS_RANGE = 0.2  # a visit's step budget: scene_switch_steps x (1 +- this) (Habitat's step_repetition_range)


class RVNEnv(gym.Env):
    """Collision-aware point-goal navigation; settings as `EnvConfig` keywords, or ``config=`` a typed `EnvConfig`."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, render_mode: str | None = None, *, config: EnvConfig | None = None, **kwargs):
        if config is not None and kwargs:
            raise ValueError(f"RVNEnv takes config= or settings as keywords, not both (got {sorted(kwargs)})")
        if config is not None:
            config.validate()  # fills the split's defaults of a config built directly
        self.config = config if config is not None else EnvConfig.from_kwargs(**kwargs)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode={render_mode!r}: only 'rgb_array' is supported")
        self.render_mode = render_mode
        cam = self.config.camera
        obs = {"rgb": spaces.Box(0, 255, (cam.height, cam.width, 3), np.uint8),
               "pointgoal": spaces.Box(-np.inf, np.inf, (2,), np.float32)}
        if self.config.depth:
            obs["depth"] = spaces.Box(0.0, np.inf, (cam.height, cam.width), np.float32)
        self.observation_space = spaces.Dict(obs)
        self.action_space = spaces.Discrete(len(Action))
        self.agent = self.config.agent
        c = self.config
        self.rules = measures.TaskRules(  # what the reward, the cost and the episode's ending read
            success_distance=c.success_distance, n_goals=c.episodes.n_goals, t_max=c.t_max,
            stop_far_is_failure=c.stop_far_is_failure, reward_goal=c.reward_goal,
            reward_collision=c.reward_collision, slack_penalty=c.slack_penalty)
        self.success_distance = self.rules.success_distance
        self._slots = self.config.scene_slots()
        self._scene: SceneSlot | None = None
        self._schedule = eval_schedule(self._slots, self.config.per_scene) if self.config.mode == "eval" else []
        self._cursor = 0
        self._resets = 0
        self._visit_resets = 0  # train mode: resets in the current scene's visit
        self._scene_steps = self._scene_budget = 0  # train mode: steps in this scene's visit, and the visit's budget
        self._scene_rng = None
        self._episode = None
        self._done = True
        self._obs = None

    # ---- privileged state (for `rvn_data.benchmark.policies.OraclePolicy` and tools) ----------------
    @property
    def scene(self):
        """The current `Scene` (its triangles: what the trajectory oracle's planner rasterises)."""
        return self._scene.scene

    navmesh = property(lambda self: self._scene.navmesh)
    simulator = property(lambda self: self._scene.simulator)
    position = property(lambda self: self._pos, doc="The agent's floor position [3].")
    yaw = property(lambda self: self._yaw, doc="The agent's heading (rad).")
    goal = property(lambda self: self._goal, doc="The current goal [3].")
    goal_field = property(lambda self: self._field, doc="Geodesic distance field to the goal (``.distance(p)``).")
    episode = property(lambda self: self._episode, doc="Eval mode: the current `Episode` (start, goals).")
    scene_spec = property(lambda self: self._scene.spec, doc="The current scene's spec (what `open_scene` reads).")

    @property
    def episode_key(self) -> tuple[int, int, int]:
        """(split code, scene index, episode index) of the current episode."""
        return self._key

    def distance_to_goal(self, position: np.ndarray | None = None) -> float:
        """Geodesic distance (m) from ``position`` (default: the agent) to the goal."""
        p = self._pos if position is None else position
        d = float(self._field.distance(p))
        return d if math.isfinite(d) else float(np.linalg.norm(to_planar(p) - to_planar(self._goal)))

    def success_distance_now(self, position: np.ndarray | None = None) -> float:
        """The distance (from ``position``, default the agent) that the success test compares
        with ``success_distance``: geodesic, or planar straight-line with ``success_metric="euclidean"``."""
        p = self._pos if position is None else position
        if self.config.success_metric == "euclidean":
            return float(np.linalg.norm(to_planar(p) - to_planar(self._goal)))
        return self.distance_to_goal(p)

    def at_goal(self, position: np.ndarray | None = None) -> bool:
        """A STOP at ``position`` (default: the agent's) would reach the goal (`measures`' test)."""
        return measures.within_success_distance(self.success_distance_now(position), self.success_distance)

    # ---- gymnasium API ------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        info = self.reset_state(seed=seed, options=options)
        return self._observe(), info

    def reset_state(self, *, seed: int | None = None, options: dict | None = None) -> dict:
        """`reset` without its observation: the info. Batched envs render the first observations of
        many together: `view` for each, `rvn_data.render.render_views`, then `observation`."""
        super().reset(seed=seed)
        options = dict(options or {})
        if self.config.mode == "eval":
            self._reset_eval(seed, options)
        else:
            self._reset_train(seed, options)
        self._done = False
        self._ended = None
        self._goal_steps = 0
        return self._info(None)

    def _load(self, pos: int) -> None:
        if self._scene is None or self._scene.pos != pos:
            if self._scene is not None:
                self._scene.close()
            self._scene = None
            self._scene = SceneSlot.open(self.config, self._slots[pos], pos)

    def _reset_eval(self, seed, options) -> None:
        self._cursor = next_in_schedule(self._schedule, self._slots, self._cursor, options, self.config.split,
                                        rewind=seed is not None)
        pos, e = self._schedule[self._cursor]
        self._cursor += 1
        self._load(pos)
        ep = self._scene.episodes(self.config)[e]
        self._episode = ep
        self._begin(ep.scene_id, ep.scene_index, ep.episode_index, ep.start_position, ep.start_yaw)
        self._next_goal()

    def _reset_train(self, seed, options) -> None:
        if seed is not None or self._scene_rng is None:
            self._resets = 0  # scene draws: their own stream, a pure function of the reset seed
            self._scene_rng = np.random.default_rng(int(self.np_random.integers(2**63)))
        c = self.config
        drawn = "scene" in options or self._scene is None or seed is not None or self._visit_spent()
        if "scene" in options:
            pos = int(options["scene"]) % len(self._slots)
        else:
            pos = self._draw_scene() if drawn else self._scene.pos
        if drawn:  # a new visit: its reset count and step budget (within +-SCENE_STEPS_RANGE) start again
            self._visit_resets = 0
        if drawn and c.scene_switch_steps:
            spread = c.scene_switch_steps * SCENE_STEPS_RANGE
            self._scene_steps = 0
            self._scene_budget = max(1, round(c.scene_switch_steps + self.np_random.uniform(-spread, spread)))
        self._resets += 1
        self._visit_resets += 1
        self._load(pos)
        ep_index = self._resets - 1
        for _ in range(self.config.episodes.max_restarts):
            start, yaw = sample_start(self.navmesh, self.np_random)
            self._begin(self._scene.scene_id, self._scene.scene_index, ep_index, start, yaw)
            if self._next_goal():
                return
        raise SceneError(f"scene {self._scene.scene_id}: no goal found {self.config.episodes.d_min}-"
                           f"{self.config.episodes.d_max} m from {self.config.episodes.max_restarts} starts")

    def _visit_spent(self) -> bool:
        """Train mode: whether this reset draws another scene: after ``scene_switch_every`` episodes in the scene, or
        at the first reset after the visit's step budget, whichever comes first; each switch starts both counts again,
        as Habitat's episode iterator (the reset count ran from the seeded reset: after a switch by steps, the next
        scene could be left after a few episodes)."""
        c = self.config
        return bool((c.scene_switch_every and self._visit_resets >= c.scene_switch_every)
                    or (c.scene_switch_steps and self._scene_steps >= self._scene_budget))

    def _draw_scene(self) -> int:
        """The next scene of train mode's scene stream (``_scene_rng``, used for nothing else: its draws are known ahead)."""
        return int(self._scene_rng.integers(len(self._slots)))

    def _begin(self, scene_id, scene_index, episode_index, position, yaw) -> None:
        self.simulator.reset(np.asarray(position, dtype=np.float64), float(yaw))
        self._pos, self._yaw = self.simulator.position.copy(), float(self.simulator.yaw)
        self._key = (self.config.split_code, int(scene_index), int(episode_index))
        self._episode_id = f"{scene_id}#{episode_index}"
        self._tracker = EpisodeTracker(scene_id, scene_index, episode_index, self._episode_id)
        self._goals_reached = 0

    def _next_goal(self) -> bool:
        """Give the next goal; False when none could be sampled (train mode)."""
        if self.config.mode == "eval":
            goal, field = self._episode.goals[self._goals_reached], None
        else:
            found = self._scene.draw_goal(self.config, self._pos, self.np_random)
            if found is None:
                return False
            goal, field = found
        self._goal = np.asarray(goal, dtype=np.float64)
        self._field = field or self.navmesh.distance_field(self._goal)
        self._dist = self.distance_to_goal()
        self._goal_steps = 0
        self._tracker.new_goal(self._dist)
        return True

    def step(self, action):
        reward, terminated, truncated, info = self.step_state(action)
        return self._observe(), reward, terminated, truncated, info

    def step_state(self, action) -> tuple[float, bool, bool, dict]:
        """`step` without its observation: (reward, terminated, truncated, info); see `reset_state`."""
        if self._done:
            raise RuntimeError("RVNEnv.step() called on a finished episode; call reset() first")
        try:
            a = Action(operator.index(action))
        except (ValueError, TypeError):
            raise ValueError(f"invalid action {action!r}: expected one of "
                             f"{[f'{x.value}={x.name}' for x in Action]}") from None
        step = self._act(a)
        self._scene_steps += 1
        self._tracker.step(step.displacement, step.collided, int(a))
        self._goal_steps, self._dist = step.goal_steps, step.dtg_after
        ending, reward = measures.termination(self.rules, step), measures.reward(self.rules, step)
        if measures.goal_reached(self.rules, step):
            self._goals_reached += 1
            self._tracker.goal_reached()
            if ending is None and not self._next_goal():
                e = self.config.episodes
                raise SceneError(f"scene {self._tracker.record['scene_id']}: no goal found "
                                 f"{e.d_min}-{e.d_max} m from {self._pos.tolist()}")
        self._ended = ending
        truncated = measures.is_truncation(ending)
        terminated = ending is not None and not truncated
        self._done = ending is not None
        info = self._info(step)
        if self._done:
            info["episode"] = self._tracker.finish(ending)
        return float(reward), terminated, truncated, info

    def _act(self, a: Action) -> measures.StepRecord:
        """Carry out action ``a`` (the simulator moves or turns the agent; STOP stays) and
        record what it did for the measures."""
        collided, displacement = False, 0.0
        if a != Action.STOP:
            res = self.simulator.step(a)
            self._pos, self._yaw = np.asarray(res.position, dtype=np.float64), float(res.yaw)
            collided, displacement = bool(res.collided), float(res.displacement)
        dtg = self._dist if a == Action.STOP else self.distance_to_goal()
        # geodesic success: the distance just looked up (a third of a state step's time when looked up again)
        success = dtg if self.config.success_metric != "euclidean" else self.success_distance_now()
        return measures.StepRecord(action=int(a), collided=collided, displacement=displacement,
                                   dtg_before=self._dist, dtg_after=dtg, goal_distance=success,
                                   goal_steps=self._goal_steps + 1, goals_reached=self._goals_reached)

    def episode_record(self) -> dict:
        """The per-episode record so far (`rvn_data.benchmark.metrics`); final once the episode ended."""
        return self._tracker.record

    def view(self) -> tuple:
        """(renderer, position, yaw) of the current observation's frame."""
        return self._scene.renderer, self._pos, self._yaw

    def _observe(self) -> dict:
        renderer, position, yaw = self.view()
        return self.observation(*renderer.render(position, yaw, depth=self.config.depth))

    def observation(self, rgb: np.ndarray, depth: np.ndarray | None) -> dict:
        """The observation of the current state from its `view`'s frame (depth used with ``depth=True``)."""
        obs = {"rgb": np.ascontiguousarray(rgb, dtype=np.uint8),
               "pointgoal": relative_goal(self._pos, self._yaw, self._goal)}
        if self.config.depth:
            obs["depth"] = np.ascontiguousarray(depth, dtype=np.float32)
        self._obs = obs
        return obs

    def _info(self, step: measures.StepRecord | None) -> dict:
        """The step's ``info`` (None: the reset's, before any step)."""
        return {
            "cost": 0.0 if step is None else measures.cost(step),
            "collided": step is not None and step.collided,
            "displacement": 0.0 if step is None else step.displacement,
            "goals_reached": int(self._goals_reached),
            "distance_to_goal": float(self._dist),  # the agent's, kept wherever its pose or goal changes
            "goal_steps": int(self._goal_steps),
            "episode_id": self._episode_id,
            "scene_id": self._tracker.record["scene_id"],
            "scene_index": int(self._key[1]),
            "episode_index": int(self._key[2]),
            "termination": self._ended,
            "success": self._ended == measures.SUCCESS,
        }

    def render(self):
        if self.render_mode == "rgb_array" and self._obs is not None:
            return self._obs["rgb"].copy()
        return None

    def close(self) -> None:
        if self._scene is not None:
            self._scene.close()
            self._scene = None
        super().close()


if "RVN-v0" not in gym.registry:
    gym.register(id="RVN-v0", entry_point="rvn_data.benchmark.env:RVNEnv")

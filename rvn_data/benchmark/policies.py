"""Task-side reference policies for the benchmark (no model code).

Policy contract (docs/ARCHITECTURE.md): ``reset()`` at every episode start and
``act(obs) -> int`` (an `Action`). Optional: ``bind(env)``, called once by the
evaluator after the environment is built, hands a policy the `RVNEnv` (its
``unwrapped``) for privileged state: the oracle reads the navmesh, the agent pose and
the goal's geodesic distance field; the random policy keys its random stream on the
current episode so that results do not depend on how episodes are spread over workers.
"""
from __future__ import annotations

import heapq
import math

import numpy as np

from rvn_data.conventions import Action, AgentConfig, StopRule, turn_toward


def _checked(name: str, value, kind: type, ok, rule: str):
    """``value`` as ``kind`` (int: a whole number; float: a finite one) where ``ok`` of it holds; else a ValueError
    naming ``policy.<name>``."""
    try:
        number = not isinstance(value, bool) and math.isfinite(float(value))
        number = number and (kind is float or float(value).is_integer())
    except (TypeError, ValueError):
        number = False
    if number and ok(kind(float(value))):
        return kind(float(value))
    raise ValueError(f"policy.{name}={value!r}: must be a {'whole ' if kind is int else ''}number {rule}")


class OraclePolicy:
    """Geodesic shortest-path follower with the discrete actions (privileged).

    Far from the goal, greedy: for each heading reachable by turning (yaw + k·θ_step),
    simulate one MOVE_FORWARD on a private `Simulator`, drop headings that collide, and
    score the landing point by its geodesic distance to the goal (the goal's distance
    field) + ``turn_cost``·|k| + ``revisit_cost``·(earlier visits of that point for this
    goal); move forward when the best heading is the current one, else turn towards it.
    Within ``near_radius`` of the goal: a breadth-first search over action sequences
    (at most ``plan_depth`` actions, ``plan_nodes`` poses) for the shortest one that ends
    where the env's success test passes, then STOP. Never takes a colliding step.

    Where the greedy rule circles (the navmesh's shortest route passes where the discrete
    steps cannot), the goal's geodesic distance stops falling; after ``replan_after`` steps
    without a new best for the goal (0: never), the oracle plans the whole way there over
    the discrete actions instead: A* over poses (landing point in ``replan_cell`` cells,
    heading; cost: actions; heuristic: geodesic distance over d_step), at most
    ``replan_nodes`` poses, and follows the plan; none found, greedy again for as long.
    (A search that saw every pose it reaches at that cell size does not prove the goal out of
    reach from elsewhere: procedural:val/27#1 reaches its goal by a later search.)
    """

    def __init__(self, turn_cost: float = 0.01, revisit_cost: float = 0.3, cell: float = 0.05,
                 near_radius: float = 1.2, plan_depth: int = 12, plan_nodes: int = 4000,
                 replan_after: int = 20, replan_nodes: int = 20000, replan_cell: float = 0.1):
        self.turn_cost = float(turn_cost)
        self.revisit_cost = float(revisit_cost)
        self.cell = float(cell)
        self.near_radius = float(near_radius)
        self.plan_depth = int(plan_depth)
        self.plan_nodes = int(plan_nodes)
        self.replan_after = _checked("replan_after", replan_after, int, lambda v: v >= 0, ">= 0 (0: never plan)")
        self.replan_nodes = _checked("replan_nodes", replan_nodes, int, lambda v: v > 0, "> 0")
        self.replan_cell = _checked("replan_cell", replan_cell, float, lambda v: v > 0, "> 0 (metres)")
        self.env = None
        self._best, self._stalled = math.inf, 0
        self._sim = None
        self._sim_navmesh = None
        self._visits: dict = {}
        self._goal_key = None
        self._plan: list[int] = []
        self._planned = False

    def bind(self, env) -> None:
        """Use ``env`` (an `RVNEnv` or a wrapper of one) for privileged state."""
        self.env = env.unwrapped

    def reset(self) -> None:
        self._visits.clear()
        self._best, self._stalled = math.inf, 0
        self._goal_key = None
        self._plan, self._planned = [], False

    def _key(self, p, cell: float | None = None) -> tuple[int, int]:
        """The planar cell of position ``p`` (``cell`` metres; default the greedy rule's ``self.cell``)."""
        cell = self.cell if cell is None else cell
        return int(round(p[0] / cell)), int(round(p[2] / cell))

    def _forward(self, position, yaw):
        """(landing position, collided) of a MOVE_FORWARD from a pose."""
        self._sim.reset(position, yaw)
        res = self._sim.step(Action.MOVE_FORWARD)
        return np.asarray(res.position), bool(res.collided)

    def act(self, obs) -> int:
        env = self.env
        if env is None:
            raise RuntimeError("OraclePolicy needs privileged state: call policy.bind(env) first")
        from rvn_data.sim import Simulator

        goal_key = tuple(np.round(env.goal, 6))
        if goal_key != self._goal_key:
            self._goal_key = goal_key
            self._visits.clear()
            self._best, self._stalled = math.inf, 0
            self._plan, self._planned = [], False
        if env.at_goal():
            return int(Action.STOP)
        if self._sim is None or self._sim_navmesh is not env.navmesh:
            self._sim, self._sim_navmesh = Simulator(env.navmesh, env.agent), env.navmesh
        if not self._plan and not self._planned and env.distance_to_goal() <= self.near_radius:
            self._plan, self._planned = self._search(env), True
        if self._plan:
            return self._plan.pop(0)
        return self._greedy(env)

    def _greedy(self, env) -> int:
        here = self._key(env.position)
        self._visits[here] = self._visits.get(here, 0) + 1
        d_now = env.distance_to_goal()
        if d_now < self._best - 1e-6:
            self._best, self._stalled = d_now, 0
        else:
            self._stalled += 1
        if 0 < self.replan_after <= self._stalled:
            self._stalled = 0
            self._plan = self._astar(env)
            if self._plan:
                return self._plan.pop(0)
        theta = env.agent.theta_step
        n = max(1, int(round(2 * math.pi / theta)))
        ks, targets = [], []
        for k in range(-((n - 1) // 2), n // 2 + 1):
            target, collided = self._forward(env.position, env.yaw + k * theta)
            if not collided:
                ks.append(k)
                targets.append(target)
        best_k, best_score = None, math.inf
        if targets:
            dist = np.asarray(env.goal_field.distance(np.stack(targets)), dtype=np.float64).reshape(-1)
            for k, target, d in zip(ks, targets, dist):
                d = d if math.isfinite(d) else env.distance_to_goal(target)
                score = d + self.turn_cost * abs(k) + self.revisit_cost * self._visits.get(self._key(target), 0)
                if score < best_score:
                    best_k, best_score = k, score
        if best_k is None:
            return int(Action.TURN_LEFT)  # every heading blocked here: turn and look again
        if best_k == 0:
            return int(Action.MOVE_FORWARD)
        return int(Action.TURN_LEFT if best_k > 0 else Action.TURN_RIGHT)

    def _astar(self, env) -> list[int]:
        """Fewest actions to a pose passing the success test, A* over (landing cell, heading) with
        the geodesic distance over d_step as the heuristic ([] if none within ``replan_nodes``)."""
        theta, d_step, cell = env.agent.theta_step, env.agent.d_step, self.replan_cell
        field = env.goal_field
        yaw0 = float(env.yaw)
        start = np.asarray(env.position, dtype=np.float64)
        n_turns = max(1, int(round(2 * math.pi / theta)))
        heap = [(float(field.distance(start)) / d_step, 0, 0, start, 0, [])]
        seen, tie = set(), 0
        while heap and len(seen) < self.replan_nodes:
            _, g, _, p, k, acts = heapq.heappop(heap)
            key = (*self._key(p, cell), k % n_turns)
            if key in seen:
                continue
            seen.add(key)
            yaw = yaw0 + k * theta
            q, collided = self._forward(p, yaw)
            children = [(q, k, Action.MOVE_FORWARD)] if not collided else []
            children += [(p, k + 1, Action.TURN_LEFT), (p, k - 1, Action.TURN_RIGHT)]
            for c, kc, a in children:
                if (*self._key(c, cell), kc % n_turns) in seen:
                    continue
                plan = acts + [int(a)]
                if a == Action.MOVE_FORWARD and env.at_goal(c):
                    return plan
                d = float(field.distance(c))
                if not math.isfinite(d):
                    continue
                tie += 1
                heapq.heappush(heap, (g + 1 + d / d_step, g + 1, tie, c, kc, plan))
        return []

    def _search(self, env) -> list[int]:
        """Shortest collision-free action list to a pose passing the success test ([] if none found)."""
        theta = env.agent.theta_step
        start = (np.asarray(env.position, dtype=np.float64), float(env.yaw))
        frontier = [(start, [])]
        seen = {(*self._key(start[0]), round(math.remainder(start[1], 2 * math.pi), 3))}
        expanded = 0
        while frontier and expanded < self.plan_nodes:
            nxt = []
            for (p, yaw), acts in frontier:
                if len(acts) >= self.plan_depth or expanded >= self.plan_nodes:
                    continue
                expanded += 1
                for a in (Action.MOVE_FORWARD, Action.TURN_LEFT, Action.TURN_RIGHT):
                    if a == Action.MOVE_FORWARD:
                        q, collided = self._forward(p, yaw)
                        if collided:
                            continue
                        y = yaw
                    else:
                        q, y = p, yaw + (theta if a == Action.TURN_LEFT else -theta)
                    key = (*self._key(q), round(math.remainder(y, 2 * math.pi), 3))
                    if key in seen:
                        continue
                    seen.add(key)
                    plan = acts + [int(a)]
                    if a == Action.MOVE_FORWARD and env.at_goal(q):
                        return plan
                    nxt.append(((q, y), plan))
            frontier = nxt
        return []


class RandomPolicy:
    """Uniformly random actions (``probs`` over STOP, MOVE_FORWARD, TURN_LEFT, TURN_RIGHT).

    Its generator is ``default_rng([seed, *env.episode_key])`` at each ``reset()`` when
    bound to an env, else one stream from ``seed``.
    """

    def __init__(self, seed: int = 0, probs: list[float] | None = None):
        self.seed = int(seed)
        p = np.full(len(Action), 1.0 / len(Action)) if probs is None else np.asarray(probs, dtype=np.float64)
        if p.shape != (len(Action),) or np.any(p < 0) or not math.isclose(p.sum(), 1.0, abs_tol=1e-6):
            raise ValueError(f"RandomPolicy probs={probs!r} must be {len(Action)} non-negative numbers summing to 1")
        self.probs = p / p.sum()
        self.env = None
        self.rng = np.random.default_rng(self.seed)

    def bind(self, env) -> None:
        self.env = env.unwrapped

    def reset(self) -> None:
        if self.env is not None:
            self.rng = np.random.default_rng([self.seed, *self.env.episode_key])

    def act(self, obs) -> int:
        return int(self.rng.choice(len(Action), p=self.probs))


class GoalFollowerPolicy:
    """Blind goal follower (habitat-baselines' ``GoalFollower``): only the point goal, no image.

    Steer toward ``obs["pointgoal"]`` with `turn_toward` (turn while its bearing exceeds
    θ_step/2, else move forward); STOP once it is closer than ``stop_radius`` (`StopRule`: a step on
    toward the goal after a STOP the env did not count). Unset settings
    come from the bound env's agent (the success radius 2·r_robot and its θ_step), or from the
    default `AgentConfig` when unbound.
    The same steering rule as the IL policies' action adapter, fed the straight line to the
    goal instead of predicted waypoints: the score a policy gets without looking.
    """

    def __init__(self, stop_radius: float | None = None, theta_step_deg: float | None = None):
        for name, value in (("stop_radius", stop_radius), ("theta_step_deg", theta_step_deg)):
            if value is not None and not (math.isfinite(float(value)) and float(value) > 0):
                raise ValueError(f"GoalFollowerPolicy {name} must be a positive number (got {value!r})")
        self._stop_radius = None if stop_radius is None else float(stop_radius)
        self._theta_step = None if theta_step_deg is None else math.radians(float(theta_step_deg))
        self._use(AgentConfig())

    def _use(self, agent) -> None:
        self.stop_radius = agent.success_distance if self._stop_radius is None else self._stop_radius
        self.theta_step = agent.theta_step if self._theta_step is None else self._theta_step
        self.stop = StopRule(self.stop_radius, self.theta_step)

    def bind(self, env) -> None:
        """Take r_robot and θ_step from the env's agent unless given."""
        self._use(env.unwrapped.agent)

    def reset(self) -> None:
        self.stop.reset()

    def act(self, obs) -> int:
        goal = np.asarray(obs["pointgoal"], dtype=np.float64)
        near = self.stop.act(goal)  # STOP within stop_radius (a step on after one the env did not count)
        if near is not None:
            return int(near)
        return int(turn_toward(math.atan2(goal[1], goal[0]), self.theta_step))

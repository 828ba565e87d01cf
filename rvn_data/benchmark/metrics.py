"""Collision-aware benchmark metrics (the paper's "Metrics": SR_1, E(G), CPK, SPL_1).

One record per episode (a JSON-able dict, written one per line to ``episodes.jsonl``)
holds everything the metrics need; `compute_metrics(records)` is a pure function of
them, so a metrics file can always be recomputed from its JSONL.

Record keys: ``scene_id``, ``scene_index``, ``episode_index``, ``episode_id``,
``goals_reached`` (int), ``first_goal_success`` (bool), ``path_length`` (m, sum of the
actual displacements), ``collisions`` (int), ``steps`` (int), ``d0`` (geodesic distance
start → first goal, m), ``termination`` (``success|collision|timeout|stop_far``) and
``goals``: a list with one dict per attempted goal: ``d0`` (geodesic distance from the
pose where the goal was given), ``reached``, ``steps``, ``path_length``, ``collisions`` and
``actions`` (how many of each action, in `Action` order: STOP, MOVE_FORWARD, TURN_LEFT,
TURN_RIGHT; records written before it lack it).

Metrics:
- ``SR_1``: fraction of episodes whose first goal was reached.
- ``E_G``: mean number of goals reached per episode.
- ``CPK``: collisions per kilometre travelled, aggregated over the set as
  total collisions / total km (``None`` when nothing moved and nothing collided is
  impossible to rate; 0 collisions over 0 m gives 0.0, >0 collisions over 0 m gives None).
- ``SPL_1``: Habitat SPL of the first goal: success · d0 / max(d0, L), L = path length
  until the first goal was reached (or the episode ended), averaged over episodes.
- ``path_length``: mean path length per episode (m).
- ``goal_ends``: how the attempted goals ended, counts of ``success`` (reached), ``collision``,
  ``timeout`` and ``stop_far`` (the episode's last goal ends with its termination).
- ``CPK_excl_timeout``: CPK over the kilometres outside timed-out stretches (the last goal of an
  episode that timed out): a policy that stalls or circles until ``T_max`` drives collision-free
  kilometres that the paper's CPK counts; this one does not (``None`` as CPK when nothing is left).
- ``policy_stats``: sums over episodes of what the policy counted (``policy_stats`` of the records,
  e.g. ``vetoes``, ``decisions``); absent when no record has any.
"""
from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path
from rvn_data.atomic import write_text_atomic  # noqa: F401 (re-exported: eval code imports it from here)
from rvn_data.benchmark.measures import TERMINATIONS, episode_success

RECORD_KEYS = (
    "scene_id", "scene_index", "episode_index", "episode_id", "goals_reached",
    "first_goal_success", "path_length", "collisions", "steps", "d0", "termination", "goals",
)


def spl(success: bool, d0: float, length: float) -> float:
    """Success weighted by path length (Habitat): success · d0 / max(d0, L)."""
    if not success:
        return 0.0
    denom = max(float(d0), float(length))
    return 1.0 if denom <= 0 else float(d0) / denom


def check_record(rec: dict) -> None:
    """Raise ValueError naming the episode and key when a record is malformed."""
    missing = [k for k in RECORD_KEYS if k not in rec]
    if missing:
        raise ValueError(f"episode record {rec.get('episode_id', '?')!r} lacks keys {missing}")
    if rec["termination"] not in TERMINATIONS:
        raise ValueError(f"episode record {rec['episode_id']!r}: termination "
                         f"{rec['termination']!r} is not one of {TERMINATIONS}")
    if rec["goals_reached"] > len(rec["goals"]):
        raise ValueError(f"episode record {rec['episode_id']!r}: goals_reached "
                         f"{rec['goals_reached']} > {len(rec['goals'])} goals listed")


def first_goal_spl(rec: dict) -> float:
    """SPL of the episode's first goal."""
    goals = rec["goals"]
    if not goals:
        return 0.0
    g = goals[0]
    return spl(bool(g["reached"]), g["d0"], g["path_length"])


def compute_metrics(records: Sequence[dict]) -> dict:
    """All benchmark metrics from per-episode records (pure function)."""
    records = list(records)
    for rec in records:
        check_record(rec)
    n = len(records)
    if n == 0:
        raise ValueError("no episode records to compute metrics from")
    collisions = sum(int(r["collisions"]) for r in records)
    km = sum(float(r["path_length"]) for r in records) / 1000.0
    km_timeout = sum(float(r["goals"][-1]["path_length"]) for r in records
                     if r["termination"] == "timeout" and r["goals"]) / 1000.0
    ends = {t: 0 for t in TERMINATIONS}
    ends["success"] = sum(int(r["goals_reached"]) for r in records)
    for r in records:
        if r["termination"] != "success":
            ends[r["termination"]] += 1
    stats: dict[str, int] = {}
    for r in records:
        for key, v in (r.get("policy_stats") or {}).items():
            stats[key] = stats.get(key, 0) + int(v)
    out = {
        "SR_1": sum(bool(r["first_goal_success"]) for r in records) / n,
        "E_G": sum(int(r["goals_reached"]) for r in records) / n,
        "CPK": _rate(collisions, km),
        "CPK_excl_timeout": _rate(collisions, km - km_timeout),
        "goal_ends": ends,
        "SPL_1": sum(first_goal_spl(r) for r in records) / n,
        "path_length": km * 1000.0 / n,
        "episodes": n,
        "collisions": collisions,
        "distance_km": km,
        "steps": sum(int(r["steps"]) for r in records),
        "success_all_goals": sum(episode_success(r) for r in records) / n,
    }
    if stats:
        out["policy_stats"] = stats
    return out


def _rate(collisions: int, km: float) -> float | None:
    """Collisions per km; 0 collisions over 0 m gives 0.0, > 0 collisions over 0 m None."""
    if km > 1e-12:
        return collisions / km
    return 0.0 if collisions == 0 else None


class EpisodeTracker:
    """Builds one episode's record step by step (used by `rvn_data.benchmark.env.RVNEnv`)."""

    def __init__(self, scene_id: str, scene_index: int, episode_index: int, episode_id: str):
        self.record = {
            "scene_id": scene_id, "scene_index": int(scene_index), "episode_index": int(episode_index),
            "episode_id": episode_id, "goals_reached": 0, "first_goal_success": False,
            "path_length": 0.0, "collisions": 0, "steps": 0, "d0": None, "termination": None,
            "goals": [],
        }

    def new_goal(self, d0: float) -> None:
        """A goal was given; ``d0`` is its geodesic distance from the agent."""
        if not self.record["goals"]:
            self.record["d0"] = float(d0)
        self.record["goals"].append({"d0": float(d0), "reached": False, "steps": 0,
                                     "path_length": 0.0, "collisions": 0, "actions": [0, 0, 0, 0]})

    def step(self, displacement: float, collided: bool, action: int | None = None) -> None:
        goal = self.record["goals"][-1]
        for r in (self.record, goal):
            r["steps"] += 1
            r["path_length"] += float(displacement)
            r["collisions"] += int(bool(collided))
        if action is not None:
            goal["actions"][int(action)] += 1

    def goal_reached(self) -> None:
        self.record["goals"][-1]["reached"] = True
        self.record["goals_reached"] += 1
        if len(self.record["goals"]) == 1:
            self.record["first_goal_success"] = True

    def finish(self, termination: str) -> dict:
        if termination not in TERMINATIONS:
            raise ValueError(f"termination {termination!r} is not one of {TERMINATIONS}")
        self.record["termination"] = termination
        return self.record


def dumps_record(rec: dict) -> str:
    """One JSONL line (sorted keys, no trailing newline)."""
    return json.dumps(rec, sort_keys=True, separators=(",", ":"), allow_nan=False)


def read_records(path: str | Path, drop_partial_tail: bool = False) -> list[dict]:
    """Records of a JSONL file. A torn last line (an interrupted append) is dropped when
    ``drop_partial_tail``; otherwise any unreadable line is a ValueError naming it."""
    path = Path(path)
    lines = path.read_text().split("\n")
    out = []
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError as err:
            if drop_partial_tail and i == len(lines) - 1:
                break  # last line without its newline: an append that was cut short
            raise ValueError(f"{path}:{i + 1}: not a JSON record ({err.msg})") from None
    return out


def write_records(path: str | Path, records: Iterable[dict]) -> None:
    """Write a JSONL file atomically (temp file then os.replace)."""
    text = "".join(dumps_record(r) + "\n" for r in records)
    write_text_atomic(path, text)


def metrics_from_jsonl(path: str | Path) -> dict:
    """Recompute every metric from an ``episodes.jsonl`` file."""
    return compute_metrics(read_records(path))


"""SR_1 of each row on the first goals inside the expert's margin (closer to an obstacle than r_robot + 0.1 m on the
expert's occupancy grid, where rvn-gen never puts a goal) and outside it, on the recipe's 200 val episodes:
    python docs/results/2026-12-06_trajectory_oracle/margin_split.py > docs/results/2026-12-06_trajectory_oracle/margin_split.md
"""
import glob
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from rvn_data.benchmark.env import RVNEnv
from rvn_il.policies.trajectory_oracle import TrajectoryOraclePolicy

HERE = Path(__file__).resolve().parent
env = RVNEnv(mode="eval", split="val", scenes={"num_scenes": 50}, per_scene=4, camera={"width": 16, "height": 16},
             episodes={"n_goals": 32, "dir": tempfile.mkdtemp()}, t_max=500)
oracle = TrajectoryOraclePolicy()
oracle.bind(env)
inside = {}
for _ in range(200):
    _, info = env.reset()
    start = np.asarray(env.episode.start_position, np.float64)
    inside[info["episode_id"]] = not oracle._planner().is_free(np.asarray(env.goal, np.float64), floor_y=float(start[1]))
env.close()
print(f"{sum(inside.values())} of {len(inside)} first goals inside the expert's margin\n")
print("| row | folder | SR_1 inside | SR_1 outside | first goals inside ended: collision / timeout |")
print("|---|---|---:|---:|---:|")
for f in sorted(glob.glob(str(HERE.parent / "2026-12-0[56]*" / "eval" / "*" / "episodes.jsonl"))):
    recs = [json.loads(line) for line in open(f)]
    if len(recs) != 200:
        continue
    method = json.loads((Path(f).parent / "metrics.json").read_text())["method"]
    a = [e for e in recs if inside[e["episode_id"]]]
    b = [e for e in recs if not inside[e["episode_id"]]]
    ok_a, ok_b = sum(e["first_goal_success"] for e in a), sum(e["first_goal_success"] for e in b)
    ends = [e["termination"] for e in a if e["goals_reached"] == 0]
    print(f"| {method} | {Path(f).parents[2].name} | {ok_a}/{len(a)} = {ok_a / len(a):.2f} | "
          f"{ok_b}/{len(b)} = {ok_b / len(b):.2f} | {ends.count('collision')} / {ends.count('timeout')} |")
sys.stdout.flush()

#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: PPO on main's code beside the IL rows of
# 2026-12-05_escape and 2026-12-05_turn_commit (training seed 0) and the reference rows, old and new, paired on the
# same 200 val episodes (episode set a7556e2bca0b):
#   bash docs/results/2026-12-06_rl_main/assemble.sh runs/rl_main
set -euo pipefail
RUN=$(cd "${1:-runs/rl_main}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# run folder -> this folder (the new Oracle and goal follower get names of their own: the report labels rows that share
# a method by their folder's name)
declare -A AS=([goal_follower]=goal_follower_stoprule [ppo]=ppo [oracle]=oracle_replan [trajectory_oracle]=trajectory_oracle)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,goal_follower,oracle,nomad_pointgoal,nomad_neg,nomad_neg_veto} \
         ../2026-12-05_turn_commit/eval/nomad_neg_veto_commit ../2026-12-06_trajectory_oracle/eval/trajectory_oracle_fallback; do
  [ -f "$HERE/$d/metrics.json" ] && DIRS+=("$d")
done
for n in goal_follower ppo oracle trajectory_oracle; do
  d=$RUN/eval/$n; [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/${AS[$n]}"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/${AS[$n]}/"
  DIRS+=("eval/${AS[$n]}")
done
if [ -f "$RUN/train/ppo/metrics.jsonl" ]; then
  mkdir -p "$HERE/train/ppo"; cp "$RUN"/train/ppo/{config.yaml,metrics.jsonl,learning_curve.png} "$HERE/train/ppo/"
fi
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("PPO=Goal follower [goal_follower_stoprule]" "PPO=NoMaD-PointGoal" "PPO=NoMaD-Neg" "PPO=NoMaD-Neg-veto-commit"
     "Oracle [oracle_replan]=Oracle [oracle]" "Trajectory oracle=Trajectory oracle fallback 0.02"
     "Goal follower [goal_follower_stoprule]=Goal follower [goal_follower]")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "PPO on main's code beside the IL rows; the Oracle's A* replan and the STOP rule (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

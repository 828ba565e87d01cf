#!/usr/bin/env bash
# Copies run.sh's and run_ddppo.sh's records into this folder and writes report.md: PPO-Lagrangian and DD-PPO on main's
# code beside 2026-12-06_rl_main's PPO and goal follower, the IL rows of 2026-12-05_escape and 2026-12-05_turn_commit
# (training seed 0) and the reference rows, paired on the same 200 val episodes (episode set a7556e2bca0b):
#   bash docs/results/2026-12-06_rl_lag_ddppo/assemble.sh runs/rl_main runs/rl_ddppo
set -euo pipefail
LAG=$(cd "${1:-runs/rl_main}" && pwd)
DDPPO=$(cd "${2:-runs/rl_ddppo}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,nomad_pointgoal,nomad_neg,nomad_neg_veto} \
         ../2026-12-05_turn_commit/eval/nomad_neg_veto_commit \
         ../2026-12-06_rl_main/eval/{goal_follower_stoprule,ppo,oracle_replan,trajectory_oracle}; do
  [ -f "$HERE/$d/metrics.json" ] && DIRS+=("$d")
done
for run in "$LAG:ppo_lag" "$DDPPO:ddppo"; do
  root=${run%:*} n=${run#*:}; d=$root/eval/$n
  [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n" "$HERE/train/$n"
  cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
  cp "$root"/train/$n/{config.yaml,metrics.jsonl,learning_curve.png} "$HERE/train/$n/"
  DIRS+=("eval/$n")
done
for run in "$LAG:ppo_lag" "$DDPPO:ddppo"; do grep -P "^(train|eval)_${run#*:}\t" "${run%:*}/timings.tsv" || true; done \
  > "$HERE/timings.tsv"
cd "$HERE"
CMP=("PPO-Lagrangian=PPO" "DD-PPO=PPO" "PPO-Lagrangian=Goal follower" "DD-PPO=Goal follower"
     "PPO-Lagrangian=NoMaD-PointGoal" "DD-PPO=NoMaD-PointGoal" "PPO-Lagrangian=DD-PPO")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "PPO-Lagrangian and DD-PPO on main's code beside PPO, the IL rows and the references (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

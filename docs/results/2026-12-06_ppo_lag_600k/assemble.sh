#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: PPO-Lagrangian at 600k env steps with training seeds
# 0 and 1 beside the same runs at 400k (2026-12-06_rl_lag_ddppo's PPO-Lagrangian, 2026-12-06_rl_seed1's seed1), PPO at
# 400k and 600k (2026-12-06_rl_main, _rl_seed1, _ppo_600k), NoMaD-PointGoal of both seeds and the reference rows,
# paired on the same 200 val episodes (episode set a7556e2bca0b); a pair whose rows both have a "seed1" row is also
# tested pooled over the seeds (400 paired episodes):
#   bash docs/results/2026-12-06_ppo_lag_600k/assemble.sh runs/rl_main
set -euo pipefail
RUN=$(cd "${1:-runs/rl_main}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,nomad_pointgoal} ../2026-12-05_neg_seed1/eval/nomad_pointgoal \
         ../2026-12-06_rl_main/eval/{goal_follower_stoprule,trajectory_oracle,ppo} ../2026-12-06_rl_lag_ddppo/eval/ppo_lag \
         ../2026-12-06_rl_seed1/eval/{ppo_seed1,ppo_lag_seed1} ../2026-12-06_ppo_600k/eval/{ppo_600k,ppo_600k_seed1}; do
  [ -f "$HERE/$d/metrics.json" ] && DIRS+=("$d")
done
for n in ppo_lag_600k ppo_lag_600k_seed1; do
  d=$RUN/eval/$n
  [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n" "$HERE/train/$n"
  cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
  cp "$RUN"/train/$n/{config.yaml,metrics.jsonl,learning_curve.png} "$HERE/train/$n/"
  DIRS+=("eval/$n")
done
grep -P "^(train|eval)_ppo_lag_600k(_seed1)?\t" "$RUN/timings.tsv" > "$HERE/timings.tsv" || true
cd "$HERE"
CMP=()
for s in "" " seed1"; do
  CMP+=("PPO-Lagrangian 600k$s=PPO-Lagrangian$s" "PPO-Lagrangian 600k$s=PPO 600k$s" "NoMaD-PointGoal$s=PPO-Lagrangian 600k$s"
        "PPO-Lagrangian 600k$s=Goal follower")
done
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "PPO-Lagrangian at 600k env steps (both training seeds' 400k runs continued) beside the same runs at 400k, PPO at 400k and 600k, NoMaD-PointGoal and the references (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: DD-PPO with training seeds 0 and 1 beside PPO and
# PPO-Lagrangian of both seeds, NoMaD-PointGoal of both seeds and the reference rows, paired on the same 200 val
# episodes (episode set a7556e2bca0b); a pair whose rows both have a "seed1" row is also tested pooled over the seeds
# (400 paired episodes):
#   bash docs/results/2026-12-06_ddppo_seed1/assemble.sh runs/rl_ddppo
set -euo pipefail
RUN=$(cd "${1:-runs/rl_ddppo}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,nomad_pointgoal} ../2026-12-05_neg_seed1/eval/nomad_pointgoal \
         ../2026-12-06_rl_main/eval/{goal_follower_stoprule,trajectory_oracle,ppo} ../2026-12-06_rl_lag_ddppo/eval/{ppo_lag,ddppo} \
         ../2026-12-06_rl_seed1/eval/{ppo_seed1,ppo_lag_seed1}; do
  [ -f "$HERE/$d/metrics.json" ] && DIRS+=("$d")
done
n=ddppo_seed1 d=$RUN/eval/ddppo_seed1
if [ -f "$d/metrics.json" ]; then
  mkdir -p "$HERE/eval/$n" "$HERE/train/$n"
  cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
  cp "$RUN"/train/$n/{config.yaml,metrics.jsonl,learning_curve.png} "$HERE/train/$n/"
  DIRS+=("eval/$n")
else
  echo "skip $n (no metrics.json: not run or unfinished)"
fi
grep -P "^(train|eval)_ddppo_seed1\t" "$RUN/timings.tsv" > "$HERE/timings.tsv" || true
cd "$HERE"
CMP=("DD-PPO seed1=DD-PPO" "DD-PPO=PPO" "DD-PPO seed1=PPO seed1" "DD-PPO=PPO-Lagrangian"
     "DD-PPO seed1=PPO-Lagrangian seed1" "DD-PPO seed1=Goal follower" "NoMaD-PointGoal=DD-PPO"
     "NoMaD-PointGoal seed1=DD-PPO seed1")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "DD-PPO, training seeds 0 and 1, beside PPO, PPO-Lagrangian, NoMaD-PointGoal and the references (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: PPO at 600k (800k, 1000k, where run) env steps with
# training seeds 0 and 1 beside the same runs at 400k (2026-12-06_rl_main's PPO, 2026-12-06_rl_seed1's PPO seed1),
# NoMaD-PointGoal of both seeds and the reference rows, paired on the same 200 val episodes (episode set
# a7556e2bca0b); a pair whose rows both have a "seed1" row is also tested pooled over the seeds (400 paired episodes):
#   bash docs/results/2026-12-06_ppo_600k/assemble.sh runs/rl_main
set -euo pipefail
RUN=$(cd "${1:-runs/rl_main}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,nomad_pointgoal} ../2026-12-05_neg_seed1/eval/nomad_pointgoal \
         ../2026-12-06_rl_main/eval/{goal_follower_stoprule,trajectory_oracle,ppo} ../2026-12-06_rl_seed1/eval/ppo_seed1; do
  [ -f "$HERE/$d/metrics.json" ] && DIRS+=("$d")
done
for n in ppo_{600,800,1000}k{,_seed1}; do  # 800k: run.sh with FROM_K=600 TO_K=800; 1000k: FROM_K=800 TO_K=1000
  d=$RUN/eval/$n
  [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n" "$HERE/train/$n"
  cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
  cp "$RUN"/train/$n/{config.yaml,metrics.jsonl,learning_curve.png} "$HERE/train/$n/"
  DIRS+=("eval/$n")
done
for n in ppo_{800,1000}k{,_seed1}_prev; do  # neighbours.sh: the other kept checkpoint of each 800k and 1000k run
  d=$RUN/eval/$n
  [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"
  cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
  DIRS+=("eval/$n")
done
grep -P "^(train|eval)_ppo_(600|800|1000)k(_seed1)?(_prev)?\t" "$RUN/timings.tsv" > "$HERE/timings.tsv" || true
cd "$HERE"
CMP=("PPO 600k=PPO" "PPO 600k seed1=PPO seed1" "NoMaD-PointGoal=PPO 600k" "NoMaD-PointGoal seed1=PPO 600k seed1"
     "PPO 600k=Goal follower" "PPO 600k seed1=Goal follower" "PPO 800k=PPO 600k" "PPO 800k seed1=PPO 600k seed1"
     "PPO 800k=PPO" "PPO 800k seed1=PPO seed1" "NoMaD-PointGoal=PPO 800k" "NoMaD-PointGoal seed1=PPO 800k seed1"
     "PPO 800k=Goal follower" "PPO 800k seed1=Goal follower" "PPO 1000k=PPO 800k" "PPO 1000k seed1=PPO 800k seed1"
     "PPO 1000k=PPO" "PPO 1000k seed1=PPO seed1" "NoMaD-PointGoal=PPO 1000k" "NoMaD-PointGoal seed1=PPO 1000k seed1"
     "PPO 1000k=Goal follower" "PPO 1000k seed1=Goal follower" "PPO 800k=PPO 799k" "PPO 800k seed1=PPO 799k seed1"
     "PPO 1000k=PPO 993k" "PPO 1000k seed1=PPO 993k seed1" "PPO 993k=PPO 799k" "PPO 993k seed1=PPO 799k seed1")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "PPO at 600k, 800k and 1000k env steps (both training seeds' 400k runs continued) beside the same runs at 400k, NoMaD-PointGoal and the references (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: PPO at 1050k env steps (both training seeds) at each
# of its five last checkpoints, read over them, beside PPO at 1000k read over its two (2026-12-06_ppo_600k's rows and
# 2026-12-06_rl_checkpoints' earlier checkpoints), NoMaD-PointGoal of both seeds and the reference rows, on the same
# 200 val episodes (episode set a7556e2bca0b); pairs pooled over both seeds:
#   bash docs/results/2026-12-06_ppo_five_checkpoints/assemble.sh runs/rl_main
set -euo pipefail
RUN=$(cd "${1:-runs/rl_main}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,nomad_pointgoal} ../2026-12-05_neg_seed1/eval/nomad_pointgoal \
         ../2026-12-06_rl_main/eval/{goal_follower_stoprule,trajectory_oracle} \
         ../2026-12-06_ppo_600k/eval/ppo_1000k{,_seed1} ../2026-12-06_rl_checkpoints/eval/ppo_1000k{,_seed1}_ckpt993280; do
  [ -f "$HERE/$d/metrics.json" ] || { echo "assemble: $d missing" >&2; exit 1; }
  DIRS+=("$d")
done
for d in "$RUN"/eval/ppo_1050k{,_seed1}{,_ckpt*}; do
  [ -f "$d/metrics.json" ] || { echo "assemble: $d has no metrics.json (not run or unfinished)" >&2; exit 1; }
  n=${d##*/}
  mkdir -p "$HERE/eval/$n"
  cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
  DIRS+=("eval/$n")
done
for n in ppo_1050k ppo_1050k_seed1; do
  mkdir -p "$HERE/train/$n"
  cp "$RUN"/train/$n/{config.yaml,metrics.jsonl,learning_curve.png} "$HERE/train/$n/"
done
grep -P "^(train|eval)_ppo_1050k" "$RUN/timings.tsv" > "$HERE/timings.tsv" || true
cd "$HERE"
CMP=()
for s in "" " seed1"; do
  CMP+=("PPO 1050k$s=PPO 1000k$s" "NoMaD-PointGoal$s=PPO 1050k$s" "PPO 1050k$s=Goal follower")
  for d in eval/ppo_1050k${s:+_seed1}_ckpt*; do  # the latest against each earlier checkpoint
    CMP+=("PPO 1050k$s=$(python -c "import json, sys; print(json.load(open(sys.argv[1]))['method'])" "$d/metrics.json")")
  done
done
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "PPO at 1050k env steps at each of its last five checkpoints, read over them, beside PPO at 1000k, NoMaD-PointGoal and the references (same 200 val episodes)" \
  "${CMP[@]/#/--compare=}"

#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: NoMaD-Neg with k = 16 CoR samples beside NoMaD-Neg
# (k = 8) and NoMaD-PointGoal of the same seed and the reference rows (docs/results/2026-12-05_escape and
# docs/results/2026-12-05_neg_seed1, assembled first), paired on the same 200 episodes, and pooled over both seeds:
#   bash docs/results/2026-12-06_cor_samples/assemble.sh runs/cor_samples
set -euo pipefail
RUN=$(cd "${1:-runs/cor_samples}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,goal_follower,trajectory_oracle,nomad_pointgoal,nomad_neg} \
         ../2026-12-05_neg_seed1/eval/{nomad_pointgoal,nomad_neg}; do
  [ -f "$HERE/$d/metrics.json" ] && DIRS+=("$d")
done
for n in nomad_neg_k16 nomad_neg_k16_seed1; do
  d=$RUN/eval/$n; [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"; DIRS+=("eval/$n")
done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-Neg-k16=NoMaD-Neg" "NoMaD-Neg-k16 seed1=NoMaD-Neg seed1" "NoMaD-Neg-k16=NoMaD-PointGoal"
     "NoMaD-Neg-k16 seed1=NoMaD-PointGoal seed1")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "CoR's k: NoMaD-Neg with 16 samples from each model against 8, seeds 0 and 1 (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

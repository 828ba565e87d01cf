#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md (tables, how goals ended, paired tests on the same
# 200 episodes, every episode's record, plots):
#   bash docs/results/2026-12-05_escape/assemble.sh runs/escape
set -euo pipefail
RUN=$(cd "${1:-runs/escape}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROWS=(random goal_follower trajectory_oracle oracle nomad_pointgoal nomad_neg nomad_neg_veto nomad_neg_veto_escape)
DIRS=()
for n in "${ROWS[@]}"; do
  d=$RUN/eval/$n; [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"; DIRS+=("eval/$n")
done
for n in nomad_pointgoal nomad_neg; do
  d=$RUN/train/$n; [ -f "$d/config.yaml" ] || continue
  mkdir -p "$HERE/train/$n"; cp "$d/config.yaml" "$HERE/train/$n/"; cp "$d/rvn-train.log" "$HERE/train/$n/" 2>/dev/null || true
done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-Neg-veto-escape=NoMaD-Neg-veto" "NoMaD-Neg-veto=Goal follower" "NoMaD-Neg-veto=Trajectory oracle"
     "NoMaD-Neg=NoMaD-PointGoal" "NoMaD-Neg-veto=NoMaD-Neg")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "The recipe's NoMaD-Neg-veto with and without the escape, on main after the review (seed 0, 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

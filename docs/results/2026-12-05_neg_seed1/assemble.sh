#!/usr/bin/env bash
# Copies run.sh's seed-1 records into this folder and writes report.md: the seed-1 rows beside the seed-0 rows and the
# reference rows of docs/results/2026-12-05_escape (assemble that first), paired on the same 200 episodes:
#   bash docs/results/2026-12-05_neg_seed1/assemble.sh runs/neg_seed1
set -euo pipefail
RUN=$(cd "${1:-runs/neg_seed1}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
SEED0=../2026-12-05_escape/eval
DIRS=()
for n in random goal_follower trajectory_oracle oracle nomad_pointgoal nomad_neg nomad_neg_veto; do
  [ -f "$HERE/$SEED0/$n/metrics.json" ] && DIRS+=("$SEED0/$n")
done
for n in nomad_pointgoal nomad_neg nomad_neg_veto; do
  d=$RUN/eval/$n; [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"; DIRS+=("eval/$n")
done
for n in nomad_pointgoal nomad_neg; do
  d=$RUN/train/$n; [ -f "$d/config.yaml" ] || continue
  mkdir -p "$HERE/train/$n"; cp "$d/config.yaml" "$HERE/train/$n/"; cp "$d/rvn-train.log" "$HERE/train/$n/" 2>/dev/null || true
done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-Neg=NoMaD-PointGoal" "NoMaD-Neg seed1=NoMaD-PointGoal seed1" "NoMaD-Neg-veto seed1=NoMaD-Neg seed1"
     "NoMaD-PointGoal seed1=NoMaD-PointGoal" "NoMaD-Neg seed1=NoMaD-Neg" "NoMaD-Neg-veto seed1=NoMaD-Neg-veto")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "NoMaD-Neg against NoMaD-PointGoal, training seeds 0 and 1 (same data, same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

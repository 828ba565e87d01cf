#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: NoMaD-PointGoal at each of its five kept checkpoints,
# read over them (significance.over_checkpoints), beside the reference rows (same 200 val episodes):
#   bash docs/results/2026-12-07_nomad_checkpoints/assemble.sh runs/nomad_checkpoints
set -euo pipefail
RUN=$(cd "${1:-runs/nomad_checkpoints}" && pwd -P)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in "$RUN"/eval/{random,goal_follower,trajectory_oracle,oracle,nomad_pointgoal,nomad_pointgoal_ckpt*}; do
  n=${d##*/}
  [ -f "$d/metrics.json" ] || { echo "assemble: skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"
  cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
  DIRS+=("eval/$n")
done
for n in nomad_pointgoal nomad_neg; do
  d=$RUN/train/$n; [ -f "$d/config.yaml" ] || continue
  mkdir -p "$HERE/train/$n"; cp "$d/config.yaml" "$HERE/train/$n/"; cp "$d/rvn-train.log" "$HERE/train/$n/" 2>/dev/null || true
  for m in "$d"/*/val.json; do [ -f "$m" ] && cp "$m" "$HERE/train/$n/$(basename "$(dirname "$m")")_val.json"; done
done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-PointGoal=Goal follower" "NoMaD-PointGoal=Trajectory oracle")
for d in eval/nomad_pointgoal_ckpt*; do  # the latest against each earlier checkpoint
  [ -f "$d/metrics.json" ] || continue
  CMP+=("NoMaD-PointGoal=$(python -c "import json, sys; print(json.load(open(sys.argv[1]))['method'])" "$d/metrics.json")")
done
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "NoMaD-PointGoal (seed 0) at each of its last five checkpoints, read over them, beside the references (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

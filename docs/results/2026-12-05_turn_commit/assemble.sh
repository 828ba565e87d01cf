#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: the turn_commit rows beside the escape run's rows
# (docs/results/2026-12-05_escape, assembled first), paired on the same 200 episodes:
#   bash docs/results/2026-12-05_turn_commit/assemble.sh runs/turn_commit
set -euo pipefail
RUN=$(cd "${1:-runs/turn_commit}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
SEED0=../2026-12-05_escape/eval
DIRS=()
for n in random goal_follower trajectory_oracle oracle nomad_pointgoal nomad_neg nomad_neg_veto nomad_neg_veto_escape; do
  [ -f "$HERE/$SEED0/$n/metrics.json" ] && DIRS+=("$SEED0/$n")
done
for n in nomad_neg_veto_commit nomad_neg_commit; do
  d=$RUN/eval/$n; [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"; DIRS+=("eval/$n")
done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-Neg-veto-commit=NoMaD-Neg-veto" "NoMaD-Neg-commit=NoMaD-Neg" "NoMaD-Neg-veto-commit=NoMaD-Neg-veto-escape"
     "NoMaD-Neg-veto-commit=Trajectory oracle")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "policy.turn_commit on NoMaD-Neg (seed 0), with and without the veto (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: NoMaD-Neg-argmin and NoMaD-PointGoal-veto of both
# seeds beside NoMaD-Neg (argmax), NoMaD-Neg-veto and NoMaD-PointGoal of the same seed and the reference rows
# (docs/results/2026-12-05_escape and docs/results/2026-12-05_neg_seed1, assembled first), paired on the same 200
# episodes:
#   bash docs/results/2026-12-06_cor_controls/assemble.sh runs/argmin
set -euo pipefail
RUN=$(cd "${1:-runs/argmin}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,goal_follower,trajectory_oracle,nomad_pointgoal,nomad_neg,nomad_neg_veto} \
         ../2026-12-05_neg_seed1/eval/{nomad_pointgoal,nomad_neg,nomad_neg_veto}; do
  [ -f "$HERE/$d/metrics.json" ] && DIRS+=("$d")
done
for n in nomad_neg_argmin nomad_neg_argmin_seed1 nomad_pointgoal_veto nomad_pointgoal_veto_seed1; do
  d=$RUN/eval/$n; [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"; DIRS+=("eval/$n")
done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-Neg-argmin=NoMaD-Neg" "NoMaD-Neg-argmin=NoMaD-PointGoal" "NoMaD-Neg-argmin seed1=NoMaD-Neg seed1"
     "NoMaD-Neg-argmin seed1=NoMaD-PointGoal seed1" "NoMaD-Neg-veto=NoMaD-PointGoal-veto"
     "NoMaD-Neg-veto seed1=NoMaD-PointGoal-veto seed1" "NoMaD-PointGoal-veto=NoMaD-PointGoal"
     "NoMaD-PointGoal-veto seed1=NoMaD-PointGoal seed1")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "What CoR contributes: NoMaD-Neg with argmin CoR, NoMaD-PointGoal with the depth veto, seeds 0 and 1 (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

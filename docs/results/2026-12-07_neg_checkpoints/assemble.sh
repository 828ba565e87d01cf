#!/usr/bin/env bash
# Copies run.sh's NoMaD-Neg records into this folder and writes report.md: NoMaD-Neg with each of NoMaD-PointGoal's five
# kept checkpoints as NoMaD_e, each against NoMaD-PointGoal at that checkpoint (whose records, and the reference rows',
# stay in ../2026-12-07_nomad_checkpoints), both read over the five (significance.over_checkpoints):
#   bash docs/results/2026-12-07_neg_checkpoints/assemble.sh runs/nomad_checkpoints
set -euo pipefail
RUN=$(cd "${1:-runs/nomad_checkpoints}" && pwd -P)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$HERE/../lib.sh"  # copy_evals, copy_trainings
DIRS=()
for n in random goal_follower trajectory_oracle oracle nomad_pointgoal nomad_pointgoal_ckpt{8000,9000,10000,11000}; do
  DIRS+=("../2026-12-07_nomad_checkpoints/eval/$n")
done
copy_evals "$RUN" "$HERE" nomad_neg 'nomad_neg_ckpt*'
copy_trainings "$RUN" "$HERE" 'nomad_neg_ckpt*'
grep -E '^(eval|train)_nomad_neg' "$RUN/timings.tsv" >"$HERE/timings.tsv" || true
cd "$HERE"
CMP=("NoMaD-Neg=NoMaD-PointGoal" "NoMaD-Neg=Goal follower" "NoMaD-Neg=Trajectory oracle")
for at in 8000 9000 10000 11000; do  # step by step, and NoMaD-Neg's latest against each earlier
  CMP+=("NoMaD-Neg ckpt$at=NoMaD-PointGoal ckpt$at" "NoMaD-Neg=NoMaD-Neg ckpt$at")
done
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "NoMaD-Neg with each of NoMaD-PointGoal's last five checkpoints (seed 0) as NoMaD_e, against NoMaD-PointGoal at that checkpoint, read over them (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: NoMaD-PointGoal at each of its five kept checkpoints,
# read over them (significance.over_checkpoints), beside the reference rows (same 200 val episodes):
#   bash docs/results/2026-12-07_nomad_checkpoints/assemble.sh runs/nomad_checkpoints
set -euo pipefail
RUN=$(cd "${1:-runs/nomad_checkpoints}" && pwd -P)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$HERE/../lib.sh"  # copy_evals, copy_trainings
DIRS=()
copy_evals "$RUN" "$HERE" random goal_follower trajectory_oracle oracle nomad_pointgoal 'nomad_pointgoal_ckpt*'
copy_trainings "$RUN" "$HERE" nomad_pointgoal nomad_neg
# the NoMaD-Neg evaluations and per-checkpoint trainings later run in the same folder are ../2026-12-07_neg_checkpoints's
# records (its timings.tsv); this folder keeps its own rows, so a rerun here writes the same file
grep -Ev '^(eval_nomad_neg|train_nomad_neg_ckpt)' "$RUN/timings.tsv" >"$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-PointGoal=Goal follower" "NoMaD-PointGoal=Trajectory oracle")
for d in eval/nomad_pointgoal_ckpt*; do  # the latest against each earlier checkpoint
  [ -f "$d/metrics.json" ] || continue
  CMP+=("NoMaD-PointGoal=$(python -c "import json, sys; print(json.load(open(sys.argv[1]))['method'])" "$d/metrics.json")")
done
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "NoMaD-PointGoal (seed 0) at each of its last five checkpoints, read over them, beside the references (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

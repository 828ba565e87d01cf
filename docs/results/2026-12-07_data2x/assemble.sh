#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: NoMaD-PointGoal trained on 256 scenes (seeds 0 and 1)
# beside the 128-scene rows of the same recipe and steps (seed 0: ../2026-12-07_nomad_checkpoints, seed 1:
# ../2026-12-07_seed1_checkpoints, whose reference rows serve both: same episodes), and with the depth veto beside
# ../2026-12-06_cor_controls's veto rows; each seed's pair tested and the pair pooled over the two seeds:
#   bash docs/results/2026-12-07_data2x/assemble.sh runs/data2x
set -euo pipefail
RUN=$(cd "${1:-runs/data2x}" && pwd -P)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$HERE/../lib.sh"  # copy_evals, copy_trainings
DIRS=()
for n in random goal_follower trajectory_oracle oracle nomad_pointgoal; do DIRS+=("../2026-12-07_nomad_checkpoints/eval/$n"); done
DIRS+=("../2026-12-07_seed1_checkpoints/eval/nomad_pointgoal")
for n in nomad_pointgoal_veto nomad_pointgoal_veto_seed1; do DIRS+=("../2026-12-06_cor_controls/eval/$n"); done
copy_evals "$RUN" "$HERE" '*'
copy_trainings "$RUN" "$HERE" '*'
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-PointGoal 256 scenes=NoMaD-PointGoal" "NoMaD-PointGoal 256 scenes seed1=NoMaD-PointGoal seed1"
     "NoMaD-PointGoal-veto 256 scenes=NoMaD-PointGoal-veto" "NoMaD-PointGoal-veto 256 scenes seed1=NoMaD-PointGoal-veto seed1"
     "NoMaD-PointGoal 256 scenes=Goal follower" "NoMaD-PointGoal 256 scenes=Trajectory oracle")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "NoMaD-PointGoal on 256 train scenes against 128 at equal steps, training seeds 0 and 1 (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

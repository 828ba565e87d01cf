#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: NoMaD-PointGoal at 22,532 steps on 128 and on 256
# train scenes (seed 0) beside the same recipe at 11,266 steps (128 scenes: ../2026-12-07_nomad_checkpoints, 256:
# ../2026-12-07_data2x), NoMaD-Neg on the 22,532-step model beside ../2026-12-07_neg_checkpoints's, and the depth veto
# rows beside ../2026-12-06_cor_controls's and ../2026-12-07_data2x's; the reference rows are
# ../2026-12-07_nomad_checkpoints's (same episodes). Where run.sh's SEED=1 rows exist, seed 1's 11,266-step rows join
# (../2026-12-07_seed1_checkpoints, ../2026-12-07_data2x, ../2026-12-06_cor_controls), each pair is tested for seed 1
# too and pooled over the two seeds:
#   bash docs/results/2026-12-07_steps2x/assemble.sh runs/steps2x
set -euo pipefail
RUN=$(cd "${1:-runs/steps2x}" && pwd -P)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$HERE/../lib.sh"  # copy_evals, copy_trainings, merge_timings
DIRS=()
for n in random goal_follower trajectory_oracle oracle nomad_pointgoal; do DIRS+=("../2026-12-07_nomad_checkpoints/eval/$n"); done
DIRS+=("../2026-12-07_neg_checkpoints/eval/nomad_neg" "../2026-12-06_cor_controls/eval/nomad_pointgoal_veto")
for n in nomad_pointgoal_seed0 nomad_pointgoal_veto_seed0; do DIRS+=("../2026-12-07_data2x/eval/$n"); done
TAGS=("")  # the seeds' row suffixes
if compgen -G "$RUN/eval/*_seed1" >/dev/null || compgen -G "$HERE/eval/*_seed1" >/dev/null; then  # seed 1's 11,266-step rows, where seed 1 ran
  TAGS+=(" seed1")
  DIRS+=(../2026-12-07_seed1_checkpoints/eval/nomad_{pointgoal,neg} ../2026-12-06_cor_controls/eval/nomad_pointgoal_veto_seed1)
  for n in nomad_pointgoal_seed1 nomad_pointgoal_veto_seed1; do DIRS+=("../2026-12-07_data2x/eval/$n"); done
fi
n_ref=${#DIRS[@]}
copy_evals "$RUN" "$HERE" '*'
copy_trainings "$RUN" "$HERE" '*'
# this folder's rows: every finished one here, RUN's just copied and those an earlier RUN left (a session's run folder
# need not outlive it: seed 1 ran in a fresh one), in name order, in place of the ones copy_evals listed
DIRS=("${DIRS[@]:0:n_ref}")
for d in "$HERE"/eval/*/; do [ -f "$d/metrics.json" ] && DIRS+=("eval/$(basename "$d")"); done
merge_timings "$RUN" "$HERE"
cd "$HERE"
S=" 22532 steps"
CMP=("NoMaD-PointGoal$S 128 scenes=Goal follower" "NoMaD-PointGoal$S 128 scenes=Trajectory oracle")
for t in "${TAGS[@]}"; do  # each seed's pairs; the report pools a pair over the seeds that have it
  CMP+=("NoMaD-PointGoal$S 128 scenes$t=NoMaD-PointGoal$t" "NoMaD-PointGoal$S 256 scenes$t=NoMaD-PointGoal 256 scenes$t"
        "NoMaD-PointGoal$S 256 scenes$t=NoMaD-PointGoal$S 128 scenes$t"
        "NoMaD-Neg$S 128 scenes$t=NoMaD-PointGoal$S 128 scenes$t" "NoMaD-Neg$S 128 scenes$t=NoMaD-Neg$t"
        "NoMaD-PointGoal-veto$S 128 scenes$t=NoMaD-PointGoal-veto$t"
        "NoMaD-PointGoal-veto$S 256 scenes$t=NoMaD-PointGoal-veto 256 scenes$t"
        "NoMaD-PointGoal-veto$S 256 scenes$t=NoMaD-PointGoal-veto$S 128 scenes$t")
done
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "NoMaD-PointGoal at twice the steps (22,532) on 128 and 256 train scenes (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

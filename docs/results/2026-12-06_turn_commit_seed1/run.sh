#!/usr/bin/env bash
# policy.turn_commit's replication: the seed-1 NoMaD-Neg (docs/results/2026-12-05_neg_seed1, its run folder SEED1)
# with the veto and +policy.turn_commit=true, on the escape run's 200 val episodes (docs/results/2026-12-05_escape,
# its run folder BASE) with the same settings, so it pairs episode by episode with seed 1's NoMaD-Neg-veto row:
#   bash docs/results/2026-12-06_turn_commit_seed1/run.sh runs/turn_commit_seed1 runs/neg_seed1 runs/escape   # rerun to resume
set -euo pipefail
OUT=${1:-runs/turn_commit_seed1}
SEED1=$(cd "${2:-runs/neg_seed1}" && pwd)
BASE=$(cd "${3:-runs/escape}" && pwd)
[ -e "$SEED1/train/nomad_neg" ] || { echo "run.sh: $SEED1/train/nomad_neg not found: run docs/results/2026-12-05_neg_seed1/run.sh $SEED1 $BASE first" >&2; exit 2; }
[ -e "$BASE/episodes" ] || { echo "run.sh: $BASE/episodes not found: run docs/results/2026-12-05_escape/run.sh $BASE first" >&2; exit 2; }
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$BASE/cache} OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$BASE/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64"
      "camera.height=64")
step eval_nomad_neg_veto_commit rvn-eval policy=checkpoint policy.checkpoint_path="$SEED1/train/nomad_neg" \
  +policy.waypoint_index=null +policy.turn_commit=true "method=NoMaD-Neg-veto-commit seed1" +policy.depth_veto=0.5 \
  +policy.depth_veto_rule=swept out_dir="$OUT/eval/nomad_neg_veto_commit" "${EVAL[@]}"
echo "turn_commit seed-1 run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

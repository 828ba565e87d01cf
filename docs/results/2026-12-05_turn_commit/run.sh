#!/usr/bin/env bash
# policy.turn_commit on the escape run's NoMaD-Neg (seed 0; docs/results/2026-12-05_escape, its run folder BASE): the
# NoMaD-Neg-veto and NoMaD-Neg rows again with +policy.turn_commit=true, on the same 200 val episodes and settings,
# so each pairs with its row without the commitment episode by episode:
#   bash docs/results/2026-12-05_turn_commit/run.sh runs/turn_commit runs/escape      # rerun to resume
set -euo pipefail
OUT=${1:-runs/turn_commit}
BASE=$(cd "${2:-runs/escape}" && pwd)
for need in "$BASE/train/nomad_neg" "$BASE/episodes"; do
  [ -e "$need" ] || { echo "run.sh: $need not found: run docs/results/2026-12-05_escape/run.sh $BASE first" >&2; exit 2; }
done
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$BASE/cache} OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$BASE/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64"
      "camera.height=64")
NEG=(policy=checkpoint policy.checkpoint_path="$BASE/train/nomad_neg" +policy.waypoint_index=null +policy.turn_commit=true)
step eval_nomad_neg_veto_commit rvn-eval "${NEG[@]}" "method=NoMaD-Neg-veto-commit" +policy.depth_veto=0.5 \
  +policy.depth_veto_rule=swept out_dir="$OUT/eval/nomad_neg_veto_commit" "${EVAL[@]}"
step eval_nomad_neg_commit rvn-eval "${NEG[@]}" "method=NoMaD-Neg-commit" out_dir="$OUT/eval/nomad_neg_commit" "${EVAL[@]}"
echo "turn_commit run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

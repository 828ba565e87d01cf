#!/usr/bin/env bash
# CoR's k (the paper: k = 8 samples from NoMaD_e and 8 from NoMaD_n a decision): NoMaD-Neg with
# +policy.num_samples=16 for both training seeds (docs/results/2026-12-05_escape, its run folder BASE;
# docs/results/2026-12-05_neg_seed1, its run folder SEED1), on the escape run's 200 val episodes with the same
# settings, so each row pairs episode by episode with NoMaD-Neg (k = 8) of its seed. Argmin CoR collides 3x as often
# as argmax (docs/results/2026-12-06_cor_controls): does a larger k, a wider choice, lower CPK further?
#   bash docs/results/2026-12-06_cor_samples/run.sh runs/cor_samples runs/escape runs/neg_seed1      # rerun to resume
set -euo pipefail
OUT=${1:-runs/cor_samples}
BASE=$(cd "${2:-runs/escape}" && pwd)
SEED1=$(cd "${3:-runs/neg_seed1}" && pwd)
for need in "$BASE/train/nomad_neg" "$BASE/episodes" "$SEED1/train/nomad_neg"; do
  [ -e "$need" ] || { echo "run.sh: $need not found: run docs/results/2026-12-05_escape/run.sh and docs/results/2026-12-05_neg_seed1/run.sh first" >&2; exit 2; }
done
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$BASE/cache} OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$BASE/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64"
      "camera.height=64")
step eval_nomad_neg_k16 rvn-eval policy=checkpoint policy.checkpoint_path="$BASE/train/nomad_neg" \
  +policy.waypoint_index=null +policy.num_samples=16 "method=NoMaD-Neg-k16" out_dir="$OUT/eval/nomad_neg_k16" "${EVAL[@]}"
step eval_nomad_neg_k16_seed1 rvn-eval policy=checkpoint policy.checkpoint_path="$SEED1/train/nomad_neg" \
  +policy.waypoint_index=null +policy.num_samples=16 "method=NoMaD-Neg-k16 seed1" \
  out_dir="$OUT/eval/nomad_neg_k16_seed1" "${EVAL[@]}"
echo "CoR samples run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

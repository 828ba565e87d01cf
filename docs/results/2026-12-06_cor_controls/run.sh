#!/usr/bin/env bash
# What CoR contributes, two controls on main's code for both training seeds (docs/results/2026-12-05_escape, its run
# folder BASE; docs/results/2026-12-05_neg_seed1, its run folder SEED1), on the escape run's 200 val episodes with
# the same settings, so each row pairs episode by episode with the rows there:
#  - NoMaD-Neg with the CoR selection rule as the paper writes it (+policy.selection=argmin; rvn-eval's default is
#    argmax, by the equation): against NoMaD-Neg (argmax) and NoMaD-PointGoal of its seed;
#  - NoMaD-PointGoal with the depth veto (NoMaD-Neg's NoMaD_e without CoR): against NoMaD-Neg-veto of its seed, does
#    CoR still lower CPK on top of the veto?
#   bash docs/results/2026-12-06_cor_controls/run.sh runs/argmin runs/escape runs/neg_seed1      # rerun to resume
set -euo pipefail
OUT=${1:-runs/argmin}
BASE=$(cd "${2:-runs/escape}" && pwd)
SEED1=$(cd "${3:-runs/neg_seed1}" && pwd)
for need in "$BASE/train/nomad_neg" "$BASE/train/nomad_pointgoal" "$BASE/episodes" "$SEED1/train/nomad_neg" \
            "$SEED1/train/nomad_pointgoal"; do
  [ -e "$need" ] || { echo "run.sh: $need not found: run docs/results/2026-12-05_escape/run.sh and docs/results/2026-12-05_neg_seed1/run.sh first" >&2; exit 2; }
done
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$BASE/cache} OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$BASE/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64"
      "camera.height=64")
step eval_nomad_neg_argmin rvn-eval policy=checkpoint policy.checkpoint_path="$BASE/train/nomad_neg" \
  +policy.waypoint_index=null +policy.selection=argmin "method=NoMaD-Neg-argmin" out_dir="$OUT/eval/nomad_neg_argmin" "${EVAL[@]}"
step eval_nomad_neg_argmin_seed1 rvn-eval policy=checkpoint policy.checkpoint_path="$SEED1/train/nomad_neg" \
  +policy.waypoint_index=null +policy.selection=argmin "method=NoMaD-Neg-argmin seed1" \
  out_dir="$OUT/eval/nomad_neg_argmin_seed1" "${EVAL[@]}"
VETO=(+policy.depth_veto=0.5 +policy.depth_veto_rule=swept)
step eval_nomad_veto rvn-eval policy=checkpoint policy.checkpoint_path="$BASE/train/nomad_pointgoal" \
  +policy.waypoint_index=null +policy.num_samples=8 "${VETO[@]}" "method=NoMaD-PointGoal-veto" \
  out_dir="$OUT/eval/nomad_pointgoal_veto" "${EVAL[@]}"
step eval_nomad_veto_seed1 rvn-eval policy=checkpoint policy.checkpoint_path="$SEED1/train/nomad_pointgoal" \
  +policy.waypoint_index=null +policy.num_samples=8 "${VETO[@]}" "method=NoMaD-PointGoal-veto seed1" \
  out_dir="$OUT/eval/nomad_pointgoal_veto_seed1" "${EVAL[@]}"
echo "CoR controls run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

#!/usr/bin/env bash
# Issue 31 item 5: NoMaD-Neg-veto (seed 0) with policy.escape_after=12 (after 12 turns in place in a row, a full
# circle, turn to the most open heading nearest the goal and drive escape_steps forward), on the recipe's checkpoint
# and episodes. Runs on the commit that added policy.escape_after (run.json says which):
#   bash docs/results/2026-11-26_main/escape.sh runs/small_main
set -euo pipefail
OUT=$(cd "${1:-runs/small_main}" && pwd)
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64" "camera.height=64")
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache} OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
step eval_nomad_neg_veto_escape rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_neg" \
  "method=NoMaD-Neg-veto-escape" +policy.waypoint_index=null +policy.depth_veto=0.5 +policy.depth_veto_rule=swept \
  +policy.escape_after=12 out_dir="$OUT/eval/nomad_neg_veto_escape" "${EVAL[@]}"

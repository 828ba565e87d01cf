#!/usr/bin/env bash
# The trajectory oracle on the recipe's 200 val episodes (episode set a7556e2bca0b, as 2026-12-05_escape's rows) after
# ExpertPlanner.plan learned to reach goals inside the expert's margin (main 1079895); EVAL is
# 2026-12-05_escape/run.sh's, with paths=true (the maps; no result depends on it):
#   bash docs/results/2026-12-06_trajectory_oracle/run.sh runs/trajectory_oracle      # rerun to resume
set -euo pipefail
OUT=${1:-runs/trajectory_oracle}
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache} OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64"
      "camera.height=64" "paths=true")
# the first two rows ran before the fallback existed (1079895, 947fb8d): policy.fallback_margin_offset=null is what
# they did, pinned here so that a run from scratch on later code makes the same rows
step eval_trajectory_oracle rvn-eval policy=trajectory_oracle "method=Trajectory oracle" policy.waypoint_index=null \
  policy.fallback_margin_offset=null out_dir="$OUT/eval/trajectory_oracle" "${EVAL[@]}"
# the IL policies' STOP radius a centimetre inside the success distance (main 947fb8d): no STOP repeated at the boundary
step eval_trajectory_oracle_stop035 rvn-eval policy=trajectory_oracle "method=Trajectory oracle stop 0.35" \
  policy.waypoint_index=null policy.stop_radius=0.35 policy.fallback_margin_offset=null \
  out_dir="$OUT/eval/trajectory_oracle_stop035" "${EVAL[@]}"
# the default since 8ffc2da: a tighter margin (r_robot + 0.02 m) where the expert's leaves no path
step eval_trajectory_oracle_fallback rvn-eval policy=trajectory_oracle "method=Trajectory oracle fallback 0.02" \
  policy.waypoint_index=null out_dir="$OUT/eval/trajectory_oracle_fallback" "${EVAL[@]}"
echo "trajectory oracle run: done in $SECONDS s"

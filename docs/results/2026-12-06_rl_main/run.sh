#!/usr/bin/env bash
# PPO on main's code (generator version 4), the Oracle with its A* replan (main 65788c3) and the trajectory oracle with
# the STOP rule (main d115b5e), on the recipe's 200 val episodes (episode set a7556e2bca0b, as 2026-12-05_escape's IL
# rows): jobs/rl_small.sh's PPO (400k env steps, one torch thread) and its blind goal follower, then the two oracles
# with 2026-12-05_escape/run.sh's EVAL:
#   bash docs/results/2026-12-06_rl_main/run.sh runs/rl_main      # rerun to resume
set -euo pipefail
OUT=${1:-runs/rl_main}
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ALGOS=ppo bash "$HERE/../../../jobs/rl_small.sh" "$OUT"
source "$HERE/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache} OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64"
      "camera.height=64")
step eval_oracle rvn-eval policy=oracle method=Oracle out_dir="$OUT/eval/oracle" "${EVAL[@]}"
step eval_trajectory_oracle rvn-eval policy=trajectory_oracle "method=Trajectory oracle" policy.waypoint_index=null \
  out_dir="$OUT/eval/trajectory_oracle" "${EVAL[@]}"
echo "rl_main run: done in $SECONDS s"

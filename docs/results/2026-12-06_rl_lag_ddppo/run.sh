#!/usr/bin/env bash
# PPO-Lagrangian on main's code (generator version 4) beside 2026-12-06_rl_main's PPO, on the recipe's 200 val episodes
# (episode set a7556e2bca0b): jobs/rl_small.sh's PPO-Lagrangian (400k env steps, one torch thread, cost limit 1e-4,
# lambda at most 1.0), in the same run folder as rl_main's PPO so that the two share their train scenes' caches and
# the val episodes (rl_small.sh then evaluates the blind goal follower again, the step before being new):
#   bash docs/results/2026-12-06_rl_lag_ddppo/run.sh runs/rl_main      # rerun to resume
set -euo pipefail
OUT=${1:-runs/rl_main}
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ALGOS=ppo_lag bash "$HERE/../../../jobs/rl_small.sh" "$OUT"
echo "rl_lag run: done in $SECONDS s"

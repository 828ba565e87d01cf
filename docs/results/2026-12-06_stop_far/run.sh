#!/usr/bin/env bash
# PPO and PPO-Lagrangian trained with env.stop_far_is_failure=true (a STOP far from the goal ends the training episode,
# a failure, as Habitat's PointNav ends an episode at any STOP) beside 2026-12-06_rl_main's PPO and
# 2026-12-06_rl_lag_ddppo's PPO-Lagrangian, trained without it: the same recipe (jobs/rl_small.sh, 400k env steps each,
# side by side, one torch thread each), the same run folder (its train scenes' caches and the 200 val episodes,
# episode set a7556e2bca0b), run folders of their own (train/ppo_stop_far, train/ppo_lag_stop_far). Evaluated by the
# benchmark's rule as every row (a far STOP is a no-op there).
#   bash docs/results/2026-12-06_stop_far/run.sh runs/rl_main      # rerun to resume
set -euo pipefail
OUT=${1:-runs/rl_main}
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ALGOS="ppo ppo_lag" TAG=stop_far RL_EXTRA="env.stop_far_is_failure=true" bash "$HERE/../../../jobs/rl_small.sh" "$OUT"
echo "stop_far run: done in $SECONDS s"

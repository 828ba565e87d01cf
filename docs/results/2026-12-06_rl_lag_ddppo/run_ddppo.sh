#!/usr/bin/env bash
# DD-PPO on main's code beside PPO and PPO-Lagrangian, on the same 200 val episodes (episode set a7556e2bca0b):
# jobs/rl_small.sh's DD-PPO (torchrun, 2 ranks x 4 envs, the same 400k env steps), in a run folder of its own whose
# cache root is rl_main's (the train scenes' navmeshes and goal pools, each built once; a lock per file) and whose
# val episodes are made again from the same settings (the same set). It ran beside PPO-Lagrangian at nice 10:
#   nice -n 10 bash docs/results/2026-12-06_rl_lag_ddppo/run_ddppo.sh runs/rl_ddppo runs/rl_main      # rerun to resume
set -euo pipefail
OUT=${1:-runs/rl_ddppo}
SHARED=$(cd "${2:-runs/rl_main}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
RVN_CACHE_DIR=$SHARED/cache ALGOS=ddppo bash "$HERE/../../../jobs/rl_small.sh" "$OUT"
echo "rl_ddppo run: done in $SECONDS s"

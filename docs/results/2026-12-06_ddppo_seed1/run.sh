#!/usr/bin/env bash
# DD-PPO with training seed 1 (TRAIN_SEED=1), the one RL row that had a single seed, evaluated on the 200 val episodes
# of every other row (episode set a7556e2bca0b): jobs/rl_small.sh's DD-PPO (torchrun, 2 ranks x 4 envs, 400k env
# steps) in seed 0's run folder (2026-12-06_rl_lag_ddppo/run_ddppo.sh: runs/rl_ddppo, whose cache root is rl_main's),
# in run folders of its own (train/ddppo_seed1, eval/ddppo_seed1), alone on the 2 cores:
#   bash docs/results/2026-12-06_ddppo_seed1/run.sh runs/rl_ddppo runs/rl_main      # rerun to resume
# Then: bash docs/results/2026-12-06_ddppo_seed1/assemble.sh runs/rl_ddppo
set -euo pipefail
OUT=${1:-runs/rl_ddppo}
SHARED=$(cd "${2:-runs/rl_main}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
RVN_CACHE_DIR=$SHARED/cache ALGOS=ddppo TRAIN_SEED=1 TAG=seed1 bash "$HERE/../../../jobs/rl_small.sh" "$OUT"
echo "ddppo_seed1 run: done in $SECONDS s"

#!/usr/bin/env bash
# A second training seed of PPO and PPO-Lagrangian on main's code (TRAIN_SEED=1), evaluated on the 200 val episodes of
# seed 0's rows (2026-12-06_rl_main's PPO, 2026-12-06_rl_lag_ddppo's PPO-Lagrangian; episode set a7556e2bca0b): the same
# recipe (jobs/rl_small.sh, 400k env steps each, side by side, one torch thread each) in the same run folder (its train
# scenes' caches and val episodes), run folders of their own (train/ppo_seed1, train/ppo_lag_seed1):
#   bash docs/results/2026-12-06_rl_seed1/run.sh runs/rl_main      # rerun to resume
# As run: started on e19c19d, whose rows were labelled "PPO (seed1)"; 6 minutes in, the recipe's bash processes were
# stopped (SIGKILL: its trainings, left running, finished at e19c19d) and the label became "PPO seed1", which the
# report pools with seed 0's "PPO"; the rerun on main then found both trainings finished (rvn-rl returns at once) and
# evaluated them. Then: bash docs/results/2026-12-06_rl_seed1/assemble.sh runs/rl_main
set -euo pipefail
OUT=${1:-runs/rl_main}
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
TRAIN_SEED=1 TAG=seed1 bash "$HERE/../../../jobs/rl_small.sh" "$OUT"
echo "rl_seed1 run: done in $SECONDS s"

#!/usr/bin/env bash
# Every RL row of docs/results/README.md's table again at its run's checkpoint before the latest (each run keeps two,
# 1-20 updates apart), through jobs/rl_small.sh's EVAL_CHECKPOINTS=2: rows "<row> ckpt<env steps>" on the same 200 val
# episodes (episode set a7556e2bca0b), which the report reads each row over. Nothing is trained: every training step
# finds its run finished (rvn-rl says so and writes nothing) and every evaluation already made is resumed with nothing
# to add (rvn-eval leaves its records as they were). OUT: the PPO and PPO-Lagrangian runs (2026-12-06_rl_main,
# _rl_seed1, _ppo_600k, _ppo_lag_600k); DDPPO_OUT: the DD-PPO runs (2026-12-06_rl_lag_ddppo, _ddppo_seed1):
#   bash docs/results/2026-12-06_rl_checkpoints/run.sh runs/rl_main runs/rl_ddppo      # rerun to resume
# Then: bash docs/results/2026-12-06_rl_checkpoints/assemble.sh runs/rl_main runs/rl_ddppo
set -euo pipefail
OUT=$(cd "${1:-runs/rl_main}" && pwd -P)  # the folder the runs' recorded commands name (not a link to it)
DDPPO_OUT=$(cd "${2:-runs/rl_ddppo}" && pwd -P)
RECIPE=$(dirname "${BASH_SOURCE[0]}")/../../../jobs/rl_small.sh
export EVAL_CHECKPOINTS=2
ALGOS="ppo ppo_lag" bash "$RECIPE" "$OUT"
ALGOS="ppo ppo_lag" TRAIN_SEED=1 TAG=seed1 bash "$RECIPE" "$OUT"
for k in 600 800 1000; do  # PPO's 600k, 800k and 1000k runs (each the one before continued, in a copy of its folder)
  ALGOS=ppo TOTAL_STEPS=${k}000 TAG=${k}k bash "$RECIPE" "$OUT"
  ALGOS=ppo TOTAL_STEPS=${k}000 TRAIN_SEED=1 TAG=${k}k_seed1 bash "$RECIPE" "$OUT"
done
ALGOS=ppo_lag TOTAL_STEPS=600000 FROM=untagged TAG=600k bash "$RECIPE" "$OUT"
ALGOS=ppo_lag TOTAL_STEPS=600000 TRAIN_SEED=1 FROM=seed1 TAG=600k_seed1 bash "$RECIPE" "$OUT"
ALGOS=ddppo bash "$RECIPE" "$DDPPO_OUT"
ALGOS=ddppo TRAIN_SEED=1 TAG=seed1 bash "$RECIPE" "$DDPPO_OUT"
echo "rl_checkpoints run: done in $SECONDS s"

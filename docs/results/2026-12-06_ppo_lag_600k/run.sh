#!/usr/bin/env bash
# PPO-Lagrangian with half again its env steps, through jobs/rl_small.sh's FROM knob: both training seeds' 400k runs in
# OUT (train/ppo_lag: 2026-12-06_rl_lag_ddppo's row; train/ppo_lag_seed1: 2026-12-06_rl_seed1's) continued from their
# last checkpoints (400,384 env steps) to 600k in runs of their own (train/ppo_lag_600k, train/ppo_lag_600k_seed1:
# rvn-rl train.continue_from; the 400k runs stay as they were evaluated), the two recipes side by side, one torch
# thread each, with the recipe's SCALE=small settings; then rvn-eval on the same 200 val episodes (episode set
# a7556e2bca0b) as rows "PPO-Lagrangian 600k" and "PPO-Lagrangian 600k seed1", and the recipe's report: each row
# against the run it continued and the pairs pooled over both seeds, beside PPO at 600k (2026-12-06_ppo_600k's runs in
# the same OUT):
#   bash docs/results/2026-12-06_ppo_lag_600k/run.sh runs/rl_main      # rerun to resume
# Then: bash docs/results/2026-12-06_ppo_lag_600k/assemble.sh runs/rl_main
set -euo pipefail
OUT=${1:-runs/rl_main}
RECIPE=$(dirname "${BASH_SOURCE[0]}")/../../../jobs/rl_small.sh
export ALGOS=ppo_lag TOTAL_STEPS=600000
seed0() { FROM=untagged TAG=600k bash "$RECIPE" "$OUT"; }
seed1() {  # its report: both seeds' rows, PPO at 600k beside them
  TRAIN_SEED=1 FROM=seed1 TAG=600k_seed1 IL_RUNS="$OUT/eval/ppo_600k $OUT/eval/ppo_600k_seed1" \
    COMPARE="PPO-Lagrangian 600k=PPO 600k;PPO-Lagrangian 600k seed1=PPO 600k seed1" bash "$RECIPE" "$OUT"
}
trap 'kill $(jobs -p) 2>/dev/null || true' EXIT  # one recipe failing stops the other
seed0 & s0=$!
sleep "${STAGGER:-180}"  # the two recipes' goal-follower evaluations (one out_dir, its episodes all there) 3 min apart
seed1 & s1=$!
wait "$s0"
wait "$s1" || echo "ppo_lag_600k run: the seed-1 recipe stopped (its report names seed 0's row, which may not be there yet); it runs again below"
seed1  # every step done: the report again, with seed 0's row certainly in it
echo "ppo_lag_600k run: done in $SECONDS s; report: $OUT/report.md"

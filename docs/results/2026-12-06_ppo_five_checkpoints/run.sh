#!/usr/bin/env bash
# PPO's two 1000k runs trained on by 50k env steps keeping their last five checkpoints (10,240 env steps apart), each
# evaluated on the same 200 val episodes (episode set a7556e2bca0b), through jobs/rl_small.sh: FROM=1000k TAG=1050k
# (rvn-rl train.continue_from: new run folders, the 1000k runs untouched) with EVAL_CHECKPOINTS=5 (rvn-rl
# train.keep_checkpoints=5; rows "PPO 1050k" and "PPO 1050k ckpt<env steps>"), the two recipes side by side, one torch
# thread each; the report reads each row over its five checkpoints, against the 1000k runs read over their two:
#   bash docs/results/2026-12-06_ppo_five_checkpoints/run.sh runs/rl_main      # rerun to resume
# Then: bash docs/results/2026-12-06_ppo_five_checkpoints/assemble.sh runs/rl_main
set -euo pipefail
OUT=$(cd "${1:-runs/rl_main}" && pwd -P)
RECIPE=$(dirname "${BASH_SOURCE[0]}")/../../../jobs/rl_small.sh
export ALGOS=ppo TOTAL_STEPS=1050000 EVAL_CHECKPOINTS=5
seed0() { FROM=1000k TAG=1050k bash "$RECIPE" "$OUT"; }
seed1() { TRAIN_SEED=1 FROM=1000k_seed1 TAG=1050k_seed1 bash "$RECIPE" "$OUT"; }
trap 'kill $(jobs -p) 2>/dev/null || true' EXIT  # one recipe failing stops the other
seed0 & s0=$!
sleep "${STAGGER:-60}"  # the two recipes' goal-follower evaluations (one out_dir) apart
seed1 & s1=$!
wait "$s0"
wait "$s1" || echo "five_checkpoints run: the seed-1 recipe stopped (its report may name seed 0's rows, not there yet); it runs again below"
seed1  # every step done: the report again, with seed 0's rows certainly in it
echo "five_checkpoints run: done in $SECONDS s; report: $OUT/report.md"

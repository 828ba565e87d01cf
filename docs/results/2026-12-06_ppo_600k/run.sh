#!/usr/bin/env bash
# PPO with half again its env steps: both training seeds' 400k runs (2026-12-06_rl_main's PPO, 2026-12-06_rl_seed1's
# PPO seed1) continued from their last checkpoint (400,384 env steps) to 600k, side by side, one torch thread each,
# with jobs/rl_small.sh's SCALE=small settings; PPO has no schedule over train.total_steps (constant lr, clip and
# entropy weight), so a continued run trains as a 600k budget would have (its envs start fresh episodes at the
# resume). Copies of the run folders are continued (train/ppo_600k, train/ppo_600k_seed1): the 400k checkpoints stay
# as they were evaluated. Then rvn-eval on the same 200 val episodes (episode set a7556e2bca0b) as rows "PPO 600k" and
# "PPO 600k seed1", which the report pools with the 400k rows' "PPO" and "PPO seed1":
#   bash docs/results/2026-12-06_ppo_600k/run.sh runs/rl_main      # rerun to resume
#   FROM_K=600 TO_K=800 bash docs/results/2026-12-06_ppo_600k/run.sh runs/rl_main   # then 600k -> 800k
# Then: bash docs/results/2026-12-06_ppo_600k/assemble.sh runs/rl_main
set -euo pipefail
OUT=$(cd "${1:-runs/rl_main}" && pwd)
export RVN_CACHE_DIR=$OUT/cache OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
# FROM_K=600 TO_K=800: the 600k runs continued to 800k in turn (train/ppo_800k, ...; rows "PPO 800k", ...)
: "${FROM_K:=400}" "${TO_K:=600}"
# jobs/rl_small.sh's RL and EVAL arguments at SCALE=small (TOTAL_STEPS=${TO_K}000)
RL=("scale=small" "env.size=64" "env.num_scenes=50" "env.workers=0" "model.backbone=resnet18" "model.base_planes=16"
    "model.ngroups=8" "env.goal_pool=64" "ppo.num_steps=64" "ppo.num_mini_batch=4" "train.total_steps=${TO_K}000"
    "train.checkpoint_every=20" "env.t_max=500" "device=cpu" "renderer=auto" "progress=false"
    "env.num_envs=8" "train.threads=1")
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64" "camera.height=64")
if [[ "$FROM_K" == 400 ]]; then declare -A FROM=([0]=ppo [1]=ppo_seed1)
else declare -A FROM=([0]=ppo_${FROM_K}k [1]=ppo_${FROM_K}k_seed1); fi
declare -A NAME=([0]=ppo_${TO_K}k [1]=ppo_${TO_K}k_seed1) METHOD=([0]="PPO ${TO_K}k" [1]="PPO ${TO_K}k seed1")
mkdir -p "$OUT/logs" "$OUT/.done"
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"   # step NAME CMD...: skip if done, log, time
pids=()
for s in 0 1; do
  dst=$OUT/train/${NAME[$s]}
  if [[ ! -d "$dst" ]]; then  # the FROM_K run, copied whole (checkpoints, metrics.jsonl, tb/), under a temporary name
    rm -rf "$dst.part" && cp -a "$OUT/train/${FROM[$s]}" "$dst.part" && mv "$dst.part" "$dst"
  fi
  step "train_${NAME[$s]}" rvn-rl algo=ppo out_dir="$dst" seed="$s" "${RL[@]}" & pids+=($!)
done
for p in "${pids[@]}"; do wait "$p"; done
step_seen "train_${NAME[0]}" "train_${NAME[1]}"   # they ran in subshells
for s in 0 1; do
  step "eval_${NAME[$s]}" rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/${NAME[$s]}" \
    "method=${METHOD[$s]}" out_dir="$OUT/eval/${NAME[$s]}" "${EVAL[@]}"
done
echo "ppo_${TO_K}k run: done in $SECONDS s"

#!/usr/bin/env bash
# rvn-rl PPO with train.overlap=true and a lag correction, training seeds 0 and 1 side by side (one torch thread each),
# otherwise run_pair.sh's settings; then rvn-eval on the same 200 val episodes (seeds.py tests them against the pairs).
#   bash run_variant.sh OUT VARIANT [TOTAL_STEPS]
# VARIANT: decoupled (ppo.decoupled: clipped around the weights at the update's start) or recompute
# (ppo.recompute_advantages: the values behind GAE from those weights).
set -euo pipefail
OUT=$1; VARIANT=$2; STEPS=${3:-300000}
case $VARIANT in
  decoupled) FIX=ppo.decoupled=true; METHOD="PPO overlap decoupled" ;;
  recompute) FIX=ppo.recompute_advantages=true; METHOD="PPO overlap recompute" ;;
  *) echo "VARIANT must be decoupled or recompute, not '$VARIANT'" >&2; exit 2 ;;
esac
mkdir -p "$OUT/logs"
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
RL=(algo=ppo scale=small env.size=64 env.num_scenes=50 env.workers=0 model.backbone=resnet18 model.base_planes=16
    model.ngroups=8 env.goal_pool=64 ppo.num_steps=64 ppo.num_mini_batch=4 train.total_steps=$STEPS
    train.checkpoint_every=20 env.t_max=500 device=cpu renderer=auto progress=false env.num_envs=8 train.threads=1
    train.overlap=true $FIX)
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500
      "episodes.dir=$OUT/episodes" workers=2 progress=false seed=0 renderer=auto camera.width=64 camera.height=64)
for seed in 0 1; do
  ( s=$SECONDS; rvn-rl "${RL[@]}" seed=$seed out_dir="$OUT/seed$seed/train/ppo_overlap_$VARIANT" \
      > "$OUT/logs/train_$seed.log" 2>&1
    echo "train_seed$seed $((SECONDS - s)) s" >> "$OUT/timings.txt" ) &
done
wait
s=$SECONDS
for seed in 0 1; do
  rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/seed$seed/train/ppo_overlap_$VARIANT" "method=$METHOD" \
    out_dir="$OUT/seed$seed/eval/ppo_overlap_$VARIANT" "${EVAL[@]}" > "$OUT/logs/eval_$seed.log" 2>&1
done
echo "evals $((SECONDS - s)) s" >> "$OUT/timings.txt"

#!/usr/bin/env bash
# rvn-rl PPO with train.overlap=true and a lag correction, training seeds 0 and 1 side by side (one torch thread each),
# otherwise run_pair.sh's settings; then rvn-eval on the same 200 val episodes (seeds.py tests them against the pairs).
#   [SEEDS="0 1"] bash run_variant.sh OUT "VARIANT [VARIANT ...]" [TOTAL_STEPS]
# VARIANT: decoupled (ppo.decoupled: clipped around the weights at the update's start), recompute
# (ppo.recompute_advantages: the values behind GAE from those weights), or false / true: run_pair.sh's arms
# (train.overlap off, on without a correction). Every (seed, variant) trains side by side: the third seed's pair ran as
# SEEDS=2 bash run_variant.sh OUT "false recompute" 122880.
set -euo pipefail
OUT=$1; VARIANTS=$2; STEPS=${3:-300000}
fix() {  # the variant's settings
  case $1 in
    decoupled) echo "train.overlap=true ppo.decoupled=true" ;;
    recompute) echo "train.overlap=true ppo.recompute_advantages=true" ;;
    true) echo "train.overlap=true" ;;
    false) echo "train.overlap=false" ;;
    *) echo "VARIANT must be decoupled, recompute, true or false, not '$1'" >&2; return 2 ;;
  esac
}
declare -A METHOD=([decoupled]="PPO overlap decoupled" [recompute]="PPO overlap recompute" [true]="PPO overlap"
                   [false]="PPO")
for v in $VARIANTS; do fix "$v" > /dev/null; done  # every variant checked before any run
mkdir -p "$OUT/logs"
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
RL=(algo=ppo scale=small env.size=64 env.num_scenes=50 env.workers=0 model.backbone=resnet18 model.base_planes=16
    model.ngroups=8 env.goal_pool=64 ppo.num_steps=64 ppo.num_mini_batch=4 train.total_steps=$STEPS
    train.checkpoint_every=20 env.t_max=500 device=cpu renderer=auto progress=false env.num_envs=8 train.threads=1)
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500
      "episodes.dir=$OUT/episodes" workers=2 progress=false seed=0 renderer=auto camera.width=64 camera.height=64)
for seed in ${SEEDS:-0 1}; do
  for v in $VARIANTS; do
    # shellcheck disable=SC2046  # fix's settings are words
    ( s=$SECONDS; rvn-rl "${RL[@]}" $(fix "$v") seed=$seed out_dir="$OUT/seed$seed/train/ppo_overlap_$v" \
        > "$OUT/logs/train_${v}_$seed.log" 2>&1
      echo "train_${v}_seed$seed $((SECONDS - s)) s" >> "$OUT/timings.txt" ) &
  done
done
wait
s=$SECONDS
for seed in ${SEEDS:-0 1}; do
  for v in $VARIANTS; do
    rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/seed$seed/train/ppo_overlap_$v" "method=${METHOD[$v]}" \
      out_dir="$OUT/seed$seed/eval/ppo_overlap_$v" "${EVAL[@]}" > "$OUT/logs/eval_${v}_$seed.log" 2>&1
  done
done
echo "evals $((SECONDS - s)) s" >> "$OUT/timings.txt"

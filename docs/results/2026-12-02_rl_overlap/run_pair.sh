#!/usr/bin/env bash
# rvn-rl PPO with train.overlap=false and true side by side (one torch thread each), otherwise jobs/rl_small.sh's PPO settings,
# then rvn-eval on its 200 val episodes and the report beside the blind goal follower, random and trajectory oracle rows.
#   bash run_pair.sh OUT [TOTAL_STEPS] [SEED] [BASELINES]
# SEED is the trainings' seed (the evaluations keep seed 0: the same 200 episodes for every pair). Given a BASELINES
# folder (an earlier pair's OUT/eval), the three baseline rows are taken from it instead of being run again.
set -euo pipefail
OUT=$1; STEPS=${2:-300000}; SEED=${3:-0}; BASE=${4:-}
mkdir -p "$OUT/logs"
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
RL=(algo=ppo scale=small env.size=64 env.num_scenes=50 env.workers=0 model.backbone=resnet18 model.base_planes=16
    model.ngroups=8 env.goal_pool=64 ppo.num_steps=64 ppo.num_mini_batch=4 train.total_steps=$STEPS
    train.checkpoint_every=20 env.t_max=500 seed=$SEED device=cpu renderer=auto progress=false env.num_envs=8 train.threads=1)
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500
      "episodes.dir=$OUT/episodes" workers=2 progress=false seed=0 renderer=auto camera.width=64 camera.height=64)
for p in false true; do
  ( s=$SECONDS; rvn-rl "${RL[@]}" train.overlap=$p out_dir="$OUT/train/ppo_overlap_$p" > "$OUT/logs/train_$p.log" 2>&1
    echo "train_$p $((SECONDS - s)) s" >> "$OUT/timings.txt" ) &
done
wait
s=$SECONDS
if [ -z "$BASE" ]; then
BASE="$OUT/eval"
rvn-eval policy=goal_follower "method=Goal follower" out_dir="$OUT/eval/goal_follower" "${EVAL[@]}" > "$OUT/logs/eval_goal_follower.log" 2>&1
rvn-eval policy=random "method=Random" out_dir="$OUT/eval/random" "${EVAL[@]}" > "$OUT/logs/eval_random.log" 2>&1
rvn-eval policy=trajectory_oracle "method=Trajectory oracle" out_dir="$OUT/eval/trajectory_oracle" "${EVAL[@]}" \
  > "$OUT/logs/eval_trajectory_oracle.log" 2>&1
fi
for p in false true; do
  m="PPO"; [ $p = true ] && m="PPO overlap"
  rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/ppo_overlap_$p" "method=$m" out_dir="$OUT/eval/ppo_overlap_$p" \
    "${EVAL[@]}" > "$OUT/logs/eval_$p.log" 2>&1
done
echo "evals $((SECONDS - s)) s" >> "$OUT/timings.txt"
python -m rvn_data.benchmark.report "$BASE/goal_follower" "$BASE/random" "$BASE/trajectory_oracle" \
  "$OUT/eval/ppo_overlap_false" "$OUT/eval/ppo_overlap_true" -o "$OUT/report.md" "--compare=PPO overlap=PPO" \
  "--compare=PPO=Goal follower" "--compare=PPO overlap=Goal follower" \
  --title "rvn-rl PPO, train.overlap false against true (jobs/rl_small.sh's settings, seed $SEED)"

#!/usr/bin/env bash
# NoMaD-PointGoal read over its training checkpoints: the recipe's seed-0 NoMaD-PointGoal (jobs/small_experiment.sh at
# SCALE=small, the commands of ../2026-12-05_escape/run.sh) trained again keeping its last five checkpoints
# (train.keep_checkpoints=5; one every 1,000 steps, the last at the end of epoch 2), then evaluated at each of them
# (rvn-eval policy.step) on the same 200 val episodes, beside the reference rows:
#   bash docs/results/2026-12-07_nomad_checkpoints/run.sh runs/nomad_checkpoints      # rerun to resume
set -euo pipefail
OUT=${1:-runs/nomad_checkpoints}
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd -P)
DATA=$OUT/data
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache} OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
CAMERA=("camera.width=64" "camera.height=64")
GEN=("split=train" "scenes.num_scenes=128" "dataset.train_fraction=1.0" "workers=2" "progress=false" "seed=0"
     "renderer=auto" "${CAMERA[@]}" "dataset.save_depth=true")
VAL_GEN=("split=val" "scenes.num_scenes=10" "dataset.train_fraction=1.0" "workers=2" "progress=false" "seed=0"
         "renderer=auto" "${CAMERA[@]}")
TRAIN=("model.size=small" "train.batch_size=32" "data.num_workers=0" "data.goal_offset=[1,40]" "train.tqdm_interval=30"
       "device=cpu" "data.val_root=$DATA/val_expert" "model.depth_aux_weight=0.5" "train.lr=1e-3" "data.pad_context=true")
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "${CAMERA[@]}")
train() { OMP_NUM_THREADS=2 MKL_NUM_THREADS=2 step "$@"; }
evaluate() { OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "$@"; }

step gen_expert rvn-gen dataset=expert out_dir="$DATA/rvn_expert" trajectories_per_scene=32 "${GEN[@]}"
step gen_negative rvn-gen dataset=negative out_dir="$DATA/rvn_negative" trajectories_per_scene=2 "${GEN[@]}"
step gen_depth_negative rvn-gen dataset=negative out_dir="$DATA/depth_negative" trajectories_per_scene=32 "${GEN[@]}"
step gen_val rvn-gen dataset=expert out_dir="$DATA/val_expert" trajectories_per_scene=4 "${VAL_GEN[@]}"
# NoMaD-Neg's splits (the recipe's neg_splits): NoMaD_e's 30 expert trajectories a scene, NoMaD_n's 2 negatives
mkdir -p "$OUT/splits_neg/rvn_expert/train" "$OUT/splits_neg/rvn_negative/train"
awk -F_ '($NF + 0) < 30' "$DATA/rvn_expert/data_splits/rvn_expert/train/traj_names.txt" >"$OUT/splits_neg/rvn_expert/train/.t.tmp"
mv "$OUT/splits_neg/rvn_expert/train/.t.tmp" "$OUT/splits_neg/rvn_expert/train/traj_names.txt"
cp "$DATA/rvn_negative/data_splits/rvn_negative/train/traj_names.txt" "$OUT/splits_neg/rvn_negative/train/.t.tmp"
mv "$OUT/splits_neg/rvn_negative/train/.t.tmp" "$OUT/splits_neg/rvn_negative/train/traj_names.txt"

train train_nomad rvn-train model=nomad_pointgoal model.prediction_type=sample data.root="$DATA/rvn_expert" \
  out_dir="$OUT/train/nomad_pointgoal" train.epochs=2 "${TRAIN[@]}" data.depth_root="$DATA/depth_negative" seed=0 \
  train.keep_checkpoints=5
train train_nomad_neg rvn-train model=nomad_neg model.prediction_type=sample data.root="$DATA/rvn_expert" \
  data.negative_root="$DATA/rvn_negative" data.splits_dir="$OUT/splits_neg" data.skip_short=true \
  out_dir="$OUT/train/nomad_neg" train.epochs=2 "${TRAIN[@]}" train.expert_from="$OUT/train/nomad_pointgoal" seed=0

evaluate eval_random rvn-eval policy=random method=Random out_dir="$OUT/eval/random" "${EVAL[@]}"
evaluate eval_goal_follower rvn-eval policy=goal_follower "method=Goal follower" out_dir="$OUT/eval/goal_follower" "${EVAL[@]}"
evaluate eval_trajectory_oracle rvn-eval policy=trajectory_oracle "method=Trajectory oracle" policy.waypoint_index=null \
  out_dir="$OUT/eval/trajectory_oracle" "${EVAL[@]}"
evaluate eval_oracle rvn-eval policy=oracle method=Oracle out_dir="$OUT/eval/oracle" "${EVAL[@]}"
NOMAD=(policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal" +policy.waypoint_index=null +policy.num_samples=8)
evaluate eval_nomad rvn-eval "${NOMAD[@]}" "method=NoMaD-PointGoal" out_dir="$OUT/eval/nomad_pointgoal" "${EVAL[@]}"
# the four kept checkpoints before the latest, newest first (policy.step: a kept checkpoint other than the latest)
latest=$(sed 's/^ckpt_0*//' "$OUT/train/nomad_pointgoal/model/latest")
for ckpt in $(ls -d "$OUT"/train/nomad_pointgoal/model/ckpt_* | sed 's/.*ckpt_0*//' | sort -rn); do
  [ "$ckpt" = "$latest" ] && continue
  evaluate "eval_nomad_ckpt$ckpt" rvn-eval "${NOMAD[@]}" +policy.step="$ckpt" "method=NoMaD-PointGoal ckpt$ckpt" \
    out_dir="$OUT/eval/nomad_pointgoal_ckpt$ckpt" "${EVAL[@]}"
done
# NoMaD-Neg (trained above, 56 s) is not evaluated: its NoMaD_e is the latest checkpoint alone, and the session's time
# went to the checkpoints
echo "nomad_checkpoints run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

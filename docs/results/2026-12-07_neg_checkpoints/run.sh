#!/usr/bin/env bash
# NoMaD-Neg read over NoMaD_e's checkpoints: the run of ../2026-12-07_nomad_checkpoints (NoMaD-PointGoal seed 0 keeping
# its last five checkpoints, each evaluated) continued in the same folder: NoMaD-Neg with its latest as NoMaD_e (the
# recipe's row), and with each of the four checkpoints before it (rvn-train train.expert_step; NoMaD_n trained again,
# the same weights each time), each evaluated on the same 200 val episodes:
#   bash docs/results/2026-12-07_nomad_checkpoints/run.sh runs/nomad_checkpoints      # its steps, done before: skipped
#   bash docs/results/2026-12-07_neg_checkpoints/run.sh runs/nomad_checkpoints        # rerun to resume
set -euo pipefail
OUT=${1:-runs/nomad_checkpoints}
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd -P)
DATA=$OUT/data
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}
for done in train_nomad train_nomad_neg eval_random eval_goal_follower eval_trajectory_oracle eval_oracle eval_nomad; do
  [[ -f "$OUT/.done/$done" ]] || { echo "$OUT has no $done: run ../2026-12-07_nomad_checkpoints/run.sh first" >&2; exit 2; }
done
CAMERA=("camera.width=64" "camera.height=64")
TRAIN=("model.size=small" "train.batch_size=32" "data.num_workers=0" "data.goal_offset=[1,40]" "train.tqdm_interval=30"
       "device=cpu" "data.val_root=$DATA/val_expert" "model.depth_aux_weight=0.5" "train.lr=1e-3" "data.pad_context=true")
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "${CAMERA[@]}")
train() { OMP_NUM_THREADS=2 MKL_NUM_THREADS=2 step "$@"; }
evaluate() { OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "$@"; }
NEG_TRAIN=(model=nomad_neg model.prediction_type=sample data.root="$DATA/rvn_expert" data.negative_root="$DATA/rvn_negative"
           data.splits_dir="$OUT/splits_neg" data.skip_short=true train.epochs=2 "${TRAIN[@]}"
           train.expert_from="$OUT/train/nomad_pointgoal" seed=0)
NEG=(policy=checkpoint +policy.waypoint_index=null)  # the recipe's NoMaD-Neg row (LOOKAHEAD=null at SCALE=small)

evaluate eval_nomad_neg rvn-eval "${NEG[@]}" policy.checkpoint_path="$OUT/train/nomad_neg" method=NoMaD-Neg \
  out_dir="$OUT/eval/nomad_neg" "${EVAL[@]}"
earlier_checkpoints "$OUT/train/nomad_pointgoal" model 5 neg_checkpoints "train.keep_checkpoints=5 when it trained"
for at in "${EARLIER[@]}"; do
  train "train_nomad_neg_ckpt$at" rvn-train "${NEG_TRAIN[@]}" train.expert_step="$at" out_dir="$OUT/train/nomad_neg_ckpt$at"
  evaluate "eval_nomad_neg_ckpt$at" rvn-eval "${NEG[@]}" policy.checkpoint_path="$OUT/train/nomad_neg_ckpt$at" \
    "method=NoMaD-Neg ckpt$at" out_dir="$OUT/eval/nomad_neg_ckpt$at" "${EVAL[@]}"
done
echo "neg_checkpoints run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

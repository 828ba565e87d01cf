#!/usr/bin/env bash
# NoMaD-PointGoal and NoMaD-Neg over the training checkpoints with the second training seed: the seed-1 NoMaD-PointGoal of
# ../2026-12-05_neg_seed1 trained again keeping its last five checkpoints (train.keep_checkpoints=5), on the data,
# NoMaD-Neg splits and episodes of BASE (the run folder of ../2026-12-07_nomad_checkpoints/run.sh, seed 0's), then, newest
# checkpoint first, NoMaD-PointGoal evaluated at each and NoMaD-Neg with it as NoMaD_e (train.expert_step) evaluated
# beside it, as ../2026-12-07_nomad_checkpoints and ../2026-12-07_neg_checkpoints did with seed 0; the latest's rows
# last (../2026-12-05_neg_seed1 holds them, the reproduction check):
#   bash docs/results/2026-12-07_seed1_checkpoints/run.sh runs/seed1_checkpoints runs/nomad_checkpoints   # rerun to resume
set -euo pipefail
OUT=${1:-runs/seed1_checkpoints}
BASE=$(cd "${2:-runs/nomad_checkpoints}" && pwd -P)
for need in "$BASE/data/rvn_expert" "$BASE/data/rvn_negative" "$BASE/data/depth_negative" "$BASE/data/val_expert" \
            "$BASE/splits_neg" "$BASE/episodes"; do
  [ -e "$need" ] || { echo "run.sh: $need not found: run docs/results/2026-12-07_nomad_checkpoints/run.sh $BASE first" >&2; exit 2; }
done
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd -P)
DATA=$BASE/data
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$BASE/cache}
CAMERA=("camera.width=64" "camera.height=64")
TRAIN=("model.size=small" "train.batch_size=32" "data.num_workers=0" "data.goal_offset=[1,40]" "train.tqdm_interval=30"
       "device=cpu" "data.val_root=$DATA/val_expert" "model.depth_aux_weight=0.5" "train.lr=1e-3" "data.pad_context=true")
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$BASE/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "${CAMERA[@]}")
train() { OMP_NUM_THREADS=2 MKL_NUM_THREADS=2 step "$@"; }
evaluate() { OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "$@"; }
NEG_TRAIN=(model=nomad_neg model.prediction_type=sample data.root="$DATA/rvn_expert" data.negative_root="$DATA/rvn_negative"
           data.splits_dir="$BASE/splits_neg" data.skip_short=true train.epochs=2 "${TRAIN[@]}"
           train.expert_from="$OUT/train/nomad_pointgoal" seed=1)
NOMAD=(policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal" +policy.waypoint_index=null +policy.num_samples=8)
NEG=(policy=checkpoint +policy.waypoint_index=null)  # the recipe's NoMaD-Neg row (LOOKAHEAD=null at SCALE=small)

train train_nomad rvn-train model=nomad_pointgoal model.prediction_type=sample data.root="$DATA/rvn_expert" \
  out_dir="$OUT/train/nomad_pointgoal" train.epochs=2 "${TRAIN[@]}" data.depth_root="$DATA/depth_negative" seed=1 \
  train.keep_checkpoints=5
earlier_checkpoints "$OUT/train/nomad_pointgoal" model 5 seed1_checkpoints "train.keep_checkpoints=5 when it trained"
for at in "${EARLIER[@]}"; do
  evaluate "eval_nomad_ckpt$at" rvn-eval "${NOMAD[@]}" +policy.step="$at" "method=NoMaD-PointGoal seed1 ckpt$at" \
    out_dir="$OUT/eval/nomad_pointgoal_ckpt$at" "${EVAL[@]}"
  train "train_nomad_neg_ckpt$at" rvn-train "${NEG_TRAIN[@]}" train.expert_step="$at" out_dir="$OUT/train/nomad_neg_ckpt$at"
  evaluate "eval_nomad_neg_ckpt$at" rvn-eval "${NEG[@]}" policy.checkpoint_path="$OUT/train/nomad_neg_ckpt$at" \
    "method=NoMaD-Neg seed1 ckpt$at" out_dir="$OUT/eval/nomad_neg_ckpt$at" "${EVAL[@]}"
done
evaluate eval_nomad rvn-eval "${NOMAD[@]}" "method=NoMaD-PointGoal seed1" out_dir="$OUT/eval/nomad_pointgoal" "${EVAL[@]}"
train train_nomad_neg rvn-train "${NEG_TRAIN[@]}" out_dir="$OUT/train/nomad_neg"
evaluate eval_nomad_neg rvn-eval "${NEG[@]}" policy.checkpoint_path="$OUT/train/nomad_neg" "method=NoMaD-Neg seed1" \
  out_dir="$OUT/eval/nomad_neg" "${EVAL[@]}"
echo "seed1_checkpoints run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

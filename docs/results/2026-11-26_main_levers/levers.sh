#!/usr/bin/env bash
# Issue 31, the measurements the recipe run (../2026-11-26_main) left open, on the same run folder, checkpoints,
# data and 200 val episodes (episode set 6d6e329f75e1), on main's code (run.json / config.yaml record the commit):
#   bash docs/results/2026-11-26_main_levers/levers.sh runs/small_main      # rerun to resume
# 1. NoMaD-PointGoal-medoid (seeds 0, 1): the sample nearest the other 7 (CoR's expert term alone, no negatives):
#    the control that says what NoMaD-Neg's negatives add beyond choosing a consensus sample.
# 2. NoMaD-Neg-depthneg (seeds 0, 1): NoMaD_n trained on the 4,096 depth negatives (32 per train scene) instead of
#    the recipe's 256 (NEG_PER_SCENE=2); NoMaD_e is the same seed's NoMaD-PointGoal (train.expert_from), as in the recipe.
# 3. Data scale (item 6): NoMaD-PointGoal (seed 0) on the first 4, 8, 16 expert trajectories of each of the 128 train
#    scenes (512, 1,024, 2,048 trajectories; 4,096 is the recipe's run), 2 epochs each (equal steps per sample), same
#    depth-head data and settings; evaluated as the recipe's one-sample row.
# 4. NoMaD-Neg-veto-escape (seed 0): the rest of escape.sh's row (../2026-11-26_main/escape.sh), if time allows.
set -euo pipefail
OUT=$(cd "${1:-runs/small_main}" && pwd)
DATA=$OUT/data
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64" "camera.height=64")
# the recipe's training settings (jobs/small_experiment.sh at SCALE=small, DEPTH_AUX=0.5, DEPTH_NEG_PER_SCENE=32)
TRAIN=("model.size=small" "train.batch_size=32" "data.num_workers=0" "data.goal_offset=[1,40]" "train.tqdm_interval=30"
       "device=cpu" "data.val_root=$DATA/val_expert" "model.depth_aux_weight=0.5" "train.lr=1e-3" "data.pad_context=true")
train() { OMP_NUM_THREADS=2 MKL_NUM_THREADS=2 step "$@"; }
evaluate() { OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "$@"; }

# splits: NoMaD_n on every depth negative; NoMaD_e's list as the recipe's (splits_neg); data scale: first k per scene
mkdir -p "$OUT/splits_neg_depth/rvn_expert/train" "$OUT/splits_neg_depth/rvn_negative/train" "$OUT/splits_scale/rvn_expert"
cp "$OUT/splits_neg/rvn_expert/train/traj_names.txt" "$OUT/splits_neg_depth/rvn_expert/train/traj_names.txt"
cp "$DATA/depth_negative/data_splits/rvn_negative/train/traj_names.txt" "$OUT/splits_neg_depth/rvn_negative/train/traj_names.txt"
for K in 4 8 16; do
  N=$((128 * K)); mkdir -p "$OUT/splits_scale/rvn_expert/n$N"
  awk -F_ -v k="$K" '($NF + 0) < k' "$DATA/rvn_expert/data_splits/rvn_expert/train/traj_names.txt" \
    >"$OUT/splits_scale/rvn_expert/n$N/.traj_names.txt.tmp"
  mv "$OUT/splits_scale/rvn_expert/n$N/.traj_names.txt.tmp" "$OUT/splits_scale/rvn_expert/n$N/traj_names.txt"
done

medoid() {  # seed suffix, label
  evaluate "eval_nomad_medoid$1" rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal$1" \
    "method=NoMaD-PointGoal-medoid$2" +policy.aggregate=medoid out_dir="$OUT/eval/nomad_pointgoal_medoid$1" "${EVAL[@]}"
}
neg_depth() {  # seed, suffix, label
  train "train_nomad_neg_depthneg$2" rvn-train model=nomad_neg model.prediction_type=sample data.root="$DATA/rvn_expert" \
    data.negative_root="$DATA/depth_negative" data.splits_dir="$OUT/splits_neg_depth" data.skip_short=true \
    out_dir="$OUT/train/nomad_neg_depthneg$2" train.epochs=2 "${TRAIN[@]}" \
    train.expert_from="$OUT/train/nomad_pointgoal$2" seed="$1"
  evaluate "eval_nomad_neg_depthneg$2" rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_neg_depthneg$2" \
    "method=NoMaD-Neg-depthneg$3" +policy.waypoint_index=null out_dir="$OUT/eval/nomad_neg_depthneg$2" "${EVAL[@]}"
}
scale() {  # number of trajectories
  train "train_nomad_n$1" rvn-train model=nomad_pointgoal model.prediction_type=sample data.root="$DATA/rvn_expert" \
    data.splits_dir="$OUT/splits_scale" data.split="n$1" out_dir="$OUT/train/nomad_pointgoal_n$1" train.epochs=2 \
    "${TRAIN[@]}" data.depth_root="$DATA/depth_negative" seed=0
  evaluate "eval_nomad_n$1" rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal_n$1" \
    "method=NoMaD-PointGoal n$1" +policy.waypoint_index=null +policy.num_samples=8 \
    out_dir="$OUT/eval/nomad_pointgoal_n$1" "${EVAL[@]}"
}

medoid "" ""
neg_depth 0 "" ""
scale 512
scale 1024
scale 2048
medoid _seed1 " seed1"
neg_depth 1 _seed1 " seed1"
evaluate eval_nomad_neg_veto_escape rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_neg" \
  "method=NoMaD-Neg-veto-escape" +policy.waypoint_index=null +policy.depth_veto=0.5 +policy.depth_veto_rule=swept \
  +policy.escape_after=12 out_dir="$OUT/eval/nomad_neg_veto_escape" "${EVAL[@]}"
echo "levers: done in $SECONDS s"

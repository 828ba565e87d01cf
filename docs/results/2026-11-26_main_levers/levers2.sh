#!/usr/bin/env bash
# The second half of levers.sh's queue, reordered to fit the session's time (levers.sh stopped after its
# 1,024-trajectory row, before 2,048, which would have taken ~40 min): the seed-1 medoid control and a fourth
# data-scale size (256 trajectories, 2 per scene: 256 / 512 / 1,024 / 4,096). Not run (next): NoMaD-Neg-depthneg
# with the swept depth veto, NoMaD-Neg-depthneg seed 1, the 2,048 size, the escape row's rest.
# Same run folder, episodes and settings as levers.sh:
#   bash docs/results/2026-11-26_main_levers/levers2.sh runs/small_main      # rerun to resume
set -euo pipefail
OUT=$(cd "${1:-runs/small_main}" && pwd)
DATA=$OUT/data
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64" "camera.height=64")
TRAIN=("model.size=small" "train.batch_size=32" "data.num_workers=0" "data.goal_offset=[1,40]" "train.tqdm_interval=30"
       "device=cpu" "data.val_root=$DATA/val_expert" "model.depth_aux_weight=0.5" "train.lr=1e-3" "data.pad_context=true")
train() { OMP_NUM_THREADS=2 MKL_NUM_THREADS=2 step "$@"; }
evaluate() { OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "$@"; }

evaluate eval_nomad_medoid_seed1 rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal_seed1" \
  "method=NoMaD-PointGoal-medoid seed1" +policy.aggregate=medoid out_dir="$OUT/eval/nomad_pointgoal_medoid_seed1" "${EVAL[@]}"

mkdir -p "$OUT/splits_scale/rvn_expert/n256"
awk -F_ '($NF + 0) < 2' "$DATA/rvn_expert/data_splits/rvn_expert/train/traj_names.txt" >"$OUT/splits_scale/rvn_expert/n256/.traj_names.txt.tmp"
mv "$OUT/splits_scale/rvn_expert/n256/.traj_names.txt.tmp" "$OUT/splits_scale/rvn_expert/n256/traj_names.txt"
train train_nomad_n256 rvn-train model=nomad_pointgoal model.prediction_type=sample data.root="$DATA/rvn_expert" \
  data.splits_dir="$OUT/splits_scale" data.split=n256 out_dir="$OUT/train/nomad_pointgoal_n256" train.epochs=2 \
  "${TRAIN[@]}" data.depth_root="$DATA/depth_negative" seed=0
evaluate eval_nomad_n256 rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal_n256" \
  "method=NoMaD-PointGoal n256" +policy.waypoint_index=null +policy.num_samples=8 \
  out_dir="$OUT/eval/nomad_pointgoal_n256" "${EVAL[@]}"

echo "levers2: done in $SECONDS s"

#!/usr/bin/env bash
# The paper's signature comparison (NoMaD-Neg against NoMaD-PointGoal: does training on negative trajectories lower
# CPK?) with a second training seed: NoMaD-PointGoal and NoMaD-Neg trained again with seed=1 on the data of
# docs/results/2026-12-05_escape (its run folder BASE: data, NoMaD-Neg's splits, episodes, packed cache), evaluated on
# the same 200 val episodes with the same settings, so each row pairs with its seed-0 row episode by episode.
# The commands are run.sh's of 2026-12-05_escape with seed=1 for training (the evaluation seed stays 0: same episodes):
#   bash docs/results/2026-12-05_neg_seed1/run.sh runs/neg_seed1 runs/escape      # rerun to resume
set -euo pipefail
OUT=${1:-runs/neg_seed1}
BASE=$(cd "${2:-runs/escape}" && pwd)
for need in "$BASE/data/rvn_expert" "$BASE/data/rvn_negative" "$BASE/data/depth_negative" "$BASE/data/val_expert" \
            "$BASE/splits_neg" "$BASE/episodes"; do
  [ -e "$need" ] || { echo "run.sh: $need not found: run docs/results/2026-12-05_escape/run.sh $BASE first" >&2; exit 2; }
done
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
DATA=$BASE/data
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$BASE/cache} OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
CAMERA=("camera.width=64" "camera.height=64")
TRAIN=("model.size=small" "train.batch_size=32" "data.num_workers=0" "data.goal_offset=[1,40]" "train.tqdm_interval=30"
       "device=cpu" "data.val_root=$DATA/val_expert" "model.depth_aux_weight=0.5" "train.lr=1e-3" "data.pad_context=true")
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$BASE/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "${CAMERA[@]}")
VETO=(+policy.depth_veto=0.5 +policy.depth_veto_rule=swept)
train() { OMP_NUM_THREADS=2 MKL_NUM_THREADS=2 step "$@"; }
evaluate() { OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "$@"; }

train train_nomad rvn-train model=nomad_pointgoal model.prediction_type=sample data.root="$DATA/rvn_expert" \
  out_dir="$OUT/train/nomad_pointgoal" train.epochs=2 "${TRAIN[@]}" data.depth_root="$DATA/depth_negative" seed=1
train train_nomad_neg rvn-train model=nomad_neg model.prediction_type=sample data.root="$DATA/rvn_expert" \
  data.negative_root="$DATA/rvn_negative" data.splits_dir="$BASE/splits_neg" data.skip_short=true \
  out_dir="$OUT/train/nomad_neg" train.epochs=2 "${TRAIN[@]}" train.expert_from="$OUT/train/nomad_pointgoal" seed=1

evaluate eval_nomad rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal" \
  "method=NoMaD-PointGoal seed1" +policy.waypoint_index=null +policy.num_samples=8 \
  out_dir="$OUT/eval/nomad_pointgoal" "${EVAL[@]}"
NEG=(policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_neg" +policy.waypoint_index=null)
evaluate eval_nomad_neg rvn-eval "${NEG[@]}" "method=NoMaD-Neg seed1" out_dir="$OUT/eval/nomad_neg" "${EVAL[@]}"
evaluate eval_nomad_neg_veto rvn-eval "${NEG[@]}" "method=NoMaD-Neg-veto seed1" "${VETO[@]}" \
  out_dir="$OUT/eval/nomad_neg_veto" "${EVAL[@]}"
echo "seed-1 run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

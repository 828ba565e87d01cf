#!/usr/bin/env bash
# Twice the scenes at equal steps: the recipe's NoMaD-PointGoal (../2026-12-07_nomad_checkpoints/run.sh's command, seeds
# 0 and 1) trained on 256 procedural train scenes x 32 expert trajectories (and 256 x 32 depth negatives) for the
# 11,266 steps its 128 scenes take in 2 epochs (train.max_steps), keeping its last five checkpoints, then evaluated on
# the same 200 val episodes (BASE's, episode set a7556e2bca0b) beside the 128-scene rows, plain and with the depth veto.
# The two seeds train side by side on one torch thread each:
#   bash docs/results/2026-12-07_data2x/run.sh runs/data2x runs/nomad_checkpoints      # rerun to resume
set -euo pipefail
OUT=${1:-runs/data2x}
BASE=$(cd "${2:-runs/nomad_checkpoints}" && pwd -P)
for need in "$BASE/data/val_expert" "$BASE/episodes"; do
  [ -e "$need" ] || { echo "run.sh: $need not found: run docs/results/2026-12-07_nomad_checkpoints/run.sh $BASE first" >&2; exit 2; }
done
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd -P)
DATA=$OUT/data
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$BASE/cache} OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
CAMERA=("camera.width=64" "camera.height=64")
GEN=("split=train" "scenes.num_scenes=256" "dataset.train_fraction=1.0" "workers=2" "progress=false" "seed=0"
     "renderer=auto" "${CAMERA[@]}" "dataset.save_depth=true")
TRAIN=("model.size=small" "train.batch_size=32" "data.num_workers=0" "data.goal_offset=[1,40]" "train.tqdm_interval=30"
       "device=cpu" "data.val_root=$BASE/data/val_expert" "model.depth_aux_weight=0.5" "train.lr=1e-3" "data.pad_context=true")
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$BASE/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "${CAMERA[@]}")
evaluate() { OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "$@"; }

step gen_expert rvn-gen dataset=expert out_dir="$DATA/rvn_expert" trajectories_per_scene=32 "${GEN[@]}"
step gen_depth_negative rvn-gen dataset=negative out_dir="$DATA/depth_negative" trajectories_per_scene=32 "${GEN[@]}"

pids=()
for seed in 0 1; do  # side by side, one torch thread each
  ( OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "train_nomad_seed$seed" rvn-train model=nomad_pointgoal \
      model.prediction_type=sample data.root="$DATA/rvn_expert" out_dir="$OUT/train/nomad_pointgoal_seed$seed" \
      train.epochs=2 train.max_steps=11266 "${TRAIN[@]}" data.depth_root="$DATA/depth_negative" seed=$seed \
      train.keep_checkpoints=5 ) &
  pids+=($!)
done
for pid in "${pids[@]}"; do wait "$pid"; done  # set -e: a failed training stops the run here
step_seen train_nomad_seed0 train_nomad_seed1

VETO=(+policy.depth_veto=0.5 +policy.depth_veto_rule=swept)  # the depth veto rows (../2026-12-06_cor_controls's)
# eval_nomad NAME LABEL [OVERRIDES...]: each seed's model on the episodes, seed 1's row labelled "<LABEL> seed1"
eval_nomad() {
  local name=$1 label=$2 seed tag; shift 2
  for seed in 0 1; do
    tag=""; [ "$seed" = 0 ] || tag=" seed$seed"
    evaluate "eval_${name}_seed$seed" rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal_seed$seed" \
      +policy.waypoint_index=null +policy.num_samples=8 "$@" "method=$label$tag" out_dir="$OUT/eval/${name/nomad/nomad_pointgoal}_seed$seed" \
      "${EVAL[@]}"
  done
}
eval_nomad nomad "NoMaD-PointGoal 256 scenes"
eval_nomad nomad_veto "NoMaD-PointGoal-veto 256 scenes" "${VETO[@]}"
echo "data2x run: done in $SECONDS s ($STEPS_SECONDS s in steps run now)"

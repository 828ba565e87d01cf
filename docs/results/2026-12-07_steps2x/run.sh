#!/usr/bin/env bash
# Twice the steps, on 128 and on 256 train scenes: the recipe's NoMaD-PointGoal (../2026-12-07_nomad_checkpoints/run.sh's
# command, seed 0) trained for 22,532 steps (train.max_steps: twice the 11,266 of the 128-scene recipe's 2 epochs; its
# warm-up and cosine schedule stretch with it) on the 128 scenes x 32 expert trajectories of BASE (4 epochs) and on the
# 256 scenes x 32 of DATA256 (../2026-12-07_data2x's, 2 epochs), keeping the last five checkpoints; NoMaD-Neg on the
# 128-scene model (the recipe's command, NoMaD_e = that model); all evaluated on BASE's 200 val episodes (episode set
# a7556e2bca0b), plain and with the depth veto, beside the 11,266-step rows. The two trainings run side by side on one
# torch thread each. SEED=1 runs the same for training seed 1 (its steps, folders and rows named ..._seed1 / "... seed1"
# beside seed 0's in the same OUT; seed 0's commands are the ones run first, unchanged):
#   bash docs/results/2026-12-07_steps2x/run.sh runs/steps2x runs/nomad_checkpoints runs/data2x/data   # rerun to resume
#   SEED=1 bash docs/results/2026-12-07_steps2x/run.sh runs/steps2x runs/nomad_checkpoints runs/data2x/data
# ARMS=128 runs the 128-scene arm alone (no DATA256 needed; its training then gets both torch threads):
#   SEED=1 ARMS=128 bash docs/results/2026-12-07_steps2x/run.sh runs/steps2x runs/nomad_checkpoints
set -euo pipefail
SEED=${SEED:-0}
[[ "$SEED" =~ ^[0-9]+$ ]] || { echo "run.sh: SEED=$SEED; give a whole number (the training seed)" >&2; exit 2; }
ARMS=${ARMS:-128 256}
[[ "$ARMS" =~ ^(128|256|128\ 256)$ ]] || { echo "run.sh: ARMS=$ARMS; give 128, 256 or \"128 256\"" >&2; exit 2; }
THREADS=1; [ "$ARMS" = "128 256" ] || THREADS=2  # the two arms side by side on one torch thread each
S=""; M=""; [ "$SEED" = 0 ] || { S="_seed$SEED"; M=" seed$SEED"; }  # seed 0 keeps the names it ran under
OUT=${1:-runs/steps2x}
BASE=$(cd "${2:-runs/nomad_checkpoints}" && pwd -P)
for need in "$BASE/data/rvn_expert" "$BASE/data/depth_negative" "$BASE/data/rvn_negative" "$BASE/splits_neg" \
            "$BASE/data/val_expert" "$BASE/episodes"; do
  [ -e "$need" ] || { echo "run.sh: $need not found: run docs/results/2026-12-07_nomad_checkpoints/run.sh $BASE first" >&2; exit 2; }
done
if [[ "$ARMS" == *256* ]]; then
  DATA256=$(cd "${3:-runs/data2x/data}" && pwd -P)
  for need in "$DATA256/rvn_expert" "$DATA256/depth_negative"; do
    [ -e "$need" ] || { echo "run.sh: $need not found: run docs/results/2026-12-07_data2x/run.sh first" >&2; exit 2; }
  done
fi
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd -P)
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$BASE/cache} OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
CAMERA=("camera.width=64" "camera.height=64")
TRAIN=("model.size=small" "train.batch_size=32" "data.num_workers=0" "data.goal_offset=[1,40]" "train.tqdm_interval=30"
       "device=cpu" "data.val_root=$BASE/data/val_expert" "model.depth_aux_weight=0.5" "train.lr=1e-3" "data.pad_context=true")
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$BASE/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "${CAMERA[@]}")
evaluate() { OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 step "$@"; }

# train_arm SCENES DATA EPOCHS: NoMaD-PointGoal for 22,532 steps on DATA (SCENES train scenes), THREADS torch threads
train_arm() {
  OMP_NUM_THREADS=$THREADS MKL_NUM_THREADS=$THREADS step "train_nomad_$1$S" rvn-train model=nomad_pointgoal model.prediction_type=sample \
    data.root="$2/rvn_expert" out_dir="$OUT/train/nomad_pointgoal_$1$S" train.epochs="$3" train.max_steps=22532 \
    "${TRAIN[@]}" data.depth_root="$2/depth_negative" seed="$SEED" train.keep_checkpoints=5
}
pids=()
[[ "$ARMS" == *128* ]] && { train_arm 128 "$BASE/data" 4 & pids+=($!); }
[[ "$ARMS" == *256* ]] && { train_arm 256 "$DATA256" 2 & pids+=($!); }
for pid in "${pids[@]}"; do wait "$pid"; done  # set -e: a failed training stops the run here
for scenes in $ARMS; do step_seen "train_nomad_$scenes$S"; done

if [[ "$ARMS" == *128* ]]; then  # NoMaD-Neg on the 128-scene model
  step "train_nomad_neg_128$S" rvn-train model=nomad_neg model.prediction_type=sample data.root="$BASE/data/rvn_expert" \
    data.negative_root="$BASE/data/rvn_negative" data.splits_dir="$BASE/splits_neg" data.skip_short=true \
    out_dir="$OUT/train/nomad_neg_128$S" train.epochs=2 "${TRAIN[@]}" train.expert_from="$OUT/train/nomad_pointgoal_128$S" \
    seed="$SEED"
fi

VETO=(+policy.depth_veto=0.5 +policy.depth_veto_rule=swept)  # the depth veto rows (../2026-12-06_cor_controls's)
POLICY=(policy=checkpoint +policy.waypoint_index=null +policy.num_samples=8)
for scenes in $ARMS; do
  evaluate "eval_nomad_$scenes$S" rvn-eval "${POLICY[@]}" policy.checkpoint_path="$OUT/train/nomad_pointgoal_$scenes$S" \
    "method=NoMaD-PointGoal 22532 steps $scenes scenes$M" out_dir="$OUT/eval/nomad_pointgoal_$scenes$S" "${EVAL[@]}"
done
if [[ "$ARMS" == *128* ]]; then
  NEG=(policy=checkpoint +policy.waypoint_index=null)  # the recipe's NoMaD-Neg row (../2026-12-07_neg_checkpoints's)
  evaluate "eval_nomad_neg_128$S" rvn-eval "${NEG[@]}" policy.checkpoint_path="$OUT/train/nomad_neg_128$S" \
    "method=NoMaD-Neg 22532 steps 128 scenes$M" out_dir="$OUT/eval/nomad_neg_128$S" "${EVAL[@]}"
fi
for scenes in $ARMS; do
  evaluate "eval_nomad_veto_$scenes$S" rvn-eval "${POLICY[@]}" policy.checkpoint_path="$OUT/train/nomad_pointgoal_$scenes$S" \
    "${VETO[@]}" "method=NoMaD-PointGoal-veto 22532 steps $scenes scenes$M" \
    out_dir="$OUT/eval/nomad_pointgoal_veto_$scenes$S" "${EVAL[@]}"
done
echo "steps2x run (seed $SEED): done in $SECONDS s ($STEPS_SECONDS s in steps run now; the trainings ran in the background)"

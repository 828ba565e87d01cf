#!/usr/bin/env bash
# issue 15 lever: no goal masking (model.goal_mask_prob=0): every sample trains the goal-conditioned
# policy; otherwise run 4's recipe (x0 + depth loss 0.5, 4 epochs, same data, same episodes)
set -euo pipefail
cd /work/wt15
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
SRC=/work/runs/exp15
OUT=/work/runs/exp15b
DATA=$SRC/data
export RVN_CACHE_DIR=$SRC/cache
CAM=(camera.width=64 camera.height=64)
t0=$SECONDS
export OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
[ -f $OUT/.train ] || { rvn-train model=nomad_pointgoal model.prediction_type=sample data.root=$DATA/rvn_expert out_dir=$OUT/train/nomad_nomask \
  train.epochs=4 model.size=small train.batch_size=32 data.num_workers=0 'data.goal_offset=[1,40]' train.tqdm_interval=30 seed=0 device=cpu \
  data.val_root=$DATA/val_expert model.depth_aux_weight=0.5 train.lr=1e-3 model.goal_mask_prob=0 > $OUT/train.log 2>&1; touch $OUT/.train; }
echo "train $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$SRC/episodes workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_nomask method=NoMaD-PointGoal-x0-depth-nomask-vote +policy.aggregate=vote out_dir=$OUT/eval/nomad_nomask_vote "${EVAL[@]}" > $OUT/eval_vote.log 2>&1
echo "eval_vote $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_nomask method=NoMaD-PointGoal-x0-depth-nomask +policy.waypoint_index=null +policy.num_samples=8 out_dir=$OUT/eval/nomad_nomask "${EVAL[@]}" > $OUT/eval_s0.log 2>&1
echo "eval_s0 $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

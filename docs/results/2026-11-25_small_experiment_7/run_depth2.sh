#!/usr/bin/env bash
# issue 15 run 7: the data x2 recipe (seed 0) with a 4x heavier auxiliary depth loss (model.depth_aux_weight=2.0,
# runs 3-6: 0.5) and data.pad_context=$PAD; its vote eval with and without policy.depth_veto=0.5 on the 200 val
# episodes of runs 2-6; ran after run_veto.sh
set -euo pipefail
while kill -0 "${WAIT_PID:-0}" 2>/dev/null; do sleep 20; done
: "${PAD:=true}"
cd /work/wt15
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
OUT=/work/runs/exp15i
DATA=$OUT/data
export RVN_CACHE_DIR=$OUT/cache
CAM=(camera.width=64 camera.height=64)
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$OUT/episodes workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
t0=$SECONDS
export OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
[ -f $OUT/.train_depth2 ] || { rvn-train model=nomad_pointgoal model.prediction_type=sample data.root=$DATA/rvn_expert out_dir=$OUT/train/nomad_depth2 \
  train.epochs=2 model.size=small train.batch_size=32 data.num_workers=0 'data.goal_offset=[1,40]' train.tqdm_interval=30 seed=0 device=cpu \
  data.val_root=$DATA/val_expert model.depth_aux_weight=2.0 train.lr=1e-3 data.pad_context=$PAD > $OUT/train_depth2.log 2>&1; touch $OUT/.train_depth2; }
echo "train_depth2 $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_depth2 method=NoMaD-PointGoal-x0-depth2-data2x-vote +policy.aggregate=vote out_dir=$OUT/eval/nomad_depth2_vote "${EVAL[@]}" > $OUT/eval_depth2_vote.log 2>&1
echo "eval_depth2_vote $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_depth2 method=NoMaD-PointGoal-x0-depth2-data2x-veto-vote +policy.aggregate=vote +policy.depth_veto=0.5 out_dir=$OUT/eval/nomad_depth2_veto_vote "${EVAL[@]}" > $OUT/eval_depth2_veto.log 2>&1
echo "eval_depth2_veto $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

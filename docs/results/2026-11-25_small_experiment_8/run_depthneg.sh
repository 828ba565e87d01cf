#!/usr/bin/env bash
# issue 15 run 8: run 7's pad recipe (seed 0) + data.depth_root = negatives with depth on the 128 train scenes (the
# depth head also learns near-obstacle views, 32 frames a step); its vote eval and vote + depth_veto 0.5 eval on the
# 200 val episodes of runs 2-7. Data: /work/runs/exp15i (gen.sh of run 6; gen_neg.sh for the negatives)
set -euo pipefail
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
[ -f $OUT/.train_depthneg ] || { rvn-train model=nomad_pointgoal model.prediction_type=sample data.root=$DATA/rvn_expert out_dir=$OUT/train/nomad_depthneg \
  train.epochs=2 model.size=small train.batch_size=32 data.num_workers=0 'data.goal_offset=[1,40]' train.tqdm_interval=30 seed=0 device=cpu \
  data.val_root=$DATA/val_expert model.depth_aux_weight=0.5 train.lr=1e-3 data.pad_context=true \
  data.depth_root=$DATA/rvn_negative_depth data.depth_batch=32 > $OUT/train_depthneg.log 2>&1; touch $OUT/.train_depthneg; }
echo "train_depthneg $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_depthneg method=NoMaD-PointGoal-x0-depth-data2x-pad-depthneg-vote +policy.aggregate=vote out_dir=$OUT/eval/nomad_depthneg_vote "${EVAL[@]}" > $OUT/eval_depthneg_vote.log 2>&1
echo "eval_depthneg_vote $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_depthneg method=NoMaD-PointGoal-x0-depth-data2x-pad-depthneg-veto +policy.aggregate=vote policy.depth_veto=0.5 out_dir=$OUT/eval/nomad_depthneg_veto "${EVAL[@]}" > $OUT/eval_depthneg_veto.log 2>&1
echo "eval_depthneg_veto $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

#!/usr/bin/env bash
# issue 15 run 7: the data x2 recipe (seed 0) with data.pad_context=true (train the first context_size decisions of
# each trajectory, their context padded with frame 0 as the policy's after reset()); its vote eval on the 200 val
# episodes of runs 2-6. Data: /work/runs/exp15i (gen.sh of run 6, the same bytes as run 5's data x2)
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
[ -f $OUT/.train_pad ] || { rvn-train model=nomad_pointgoal model.prediction_type=sample data.root=$DATA/rvn_expert out_dir=$OUT/train/nomad_pad \
  train.epochs=2 model.size=small train.batch_size=32 data.num_workers=0 'data.goal_offset=[1,40]' train.tqdm_interval=30 seed=0 device=cpu \
  data.val_root=$DATA/val_expert model.depth_aux_weight=0.5 train.lr=1e-3 data.pad_context=true > $OUT/train_pad.log 2>&1; touch $OUT/.train_pad; }
echo "train_pad $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_pad method=NoMaD-PointGoal-x0-depth-data2x-pad-vote +policy.aggregate=vote out_dir=$OUT/eval/nomad_pad_vote "${EVAL[@]}" > $OUT/eval_pad_vote.log 2>&1
echo "eval_pad_vote $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

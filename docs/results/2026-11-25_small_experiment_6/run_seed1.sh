#!/usr/bin/env bash
# issue 15 (run 5 open question): the data x2 recipe with training seed 1 (data of run_moving.sh), its vote eval,
# and the DDIM vote of the same model; ran after run_moving.sh
set -euo pipefail
# (waited here for run_moving.sh to finish)
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
[ -f $OUT/.train_seed1 ] || { rvn-train model=nomad_pointgoal model.prediction_type=sample data.root=$DATA/rvn_expert out_dir=$OUT/train/nomad_data2x_seed1 \
  train.epochs=2 model.size=small train.batch_size=32 data.num_workers=0 'data.goal_offset=[1,40]' train.tqdm_interval=30 seed=1 device=cpu \
  data.val_root=$DATA/val_expert model.depth_aux_weight=0.5 train.lr=1e-3 > $OUT/train_seed1.log 2>&1; touch $OUT/.train_seed1; }
echo "train_seed1 $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_data2x_seed1 method=NoMaD-PointGoal-x0-depth-data2x-seed1-vote +policy.aggregate=vote out_dir=$OUT/eval/nomad_data2x_seed1_vote "${EVAL[@]}" > $OUT/eval_seed1_vote.log 2>&1
echo "eval_seed1_vote $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_data2x_seed1 method=NoMaD-PointGoal-x0-depth-data2x-seed1-ddim-vote +policy.aggregate=vote +policy.sampler=ddim out_dir=$OUT/eval/nomad_data2x_seed1_ddim_vote "${EVAL[@]}" > $OUT/eval_seed1_ddim.log 2>&1
echo "eval_seed1_ddim $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

#!/usr/bin/env bash
# issue 15 lever: heading perturbations (DART-style recovery data). The data x2 recipe (128 train scenes x 32
# trajectories, x0 + depth loss 0.5, lr 1e-3, batch 32) with dataset.perturb_prob=0.1, at the same number of steps
# as data x2 (train.max_steps=10404); same val dataset and 200 val episodes
set -euo pipefail
cd /work/wt15   # worktree of 7b9376b (the episodes of runs 3-5 and rl_small) + main's encoders.py
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
SRC=/work/runs/exp15
OUT=/work/runs/exp15g
DATA=$OUT/data
export RVN_CACHE_DIR=$OUT/cache
CAM=(camera.width=64 camera.height=64)
GEN=(split=train scenes.num_scenes=128 dataset.train_fraction=1.0 workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
t0=$SECONDS
[ -f $OUT/.gen_expert ] || { rvn-gen dataset=expert out_dir=$DATA/rvn_expert trajectories_per_scene=32 "${GEN[@]}" dataset.save_depth=true dataset.perturb_prob=0.1 > $OUT/gen_expert.log 2>&1; touch $OUT/.gen_expert; }
echo "gen_expert $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
[ -f $OUT/.train ] || { rvn-train model=nomad_pointgoal model.prediction_type=sample data.root=$DATA/rvn_expert out_dir=$OUT/train/nomad_perturb \
  train.epochs=100 train.max_steps=10404 model.size=small train.batch_size=32 data.num_workers=0 'data.goal_offset=[1,40]' train.tqdm_interval=30 seed=0 device=cpu \
  data.val_root=$SRC/data/val_expert model.depth_aux_weight=0.5 train.lr=1e-3 > $OUT/train.log 2>&1; touch $OUT/.train; }
echo "train $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$SRC/episodes workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_perturb method=NoMaD-PointGoal-x0-depth-data2x-perturb-vote +policy.aggregate=vote out_dir=$OUT/eval/nomad_perturb_vote "${EVAL[@]}" > $OUT/eval_vote.log 2>&1
echo "eval_vote $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
echo done >> $OUT/timings.tsv

#!/usr/bin/env bash
# issue 15 lever: x0 + auxiliary depth loss 0.5, 4 epochs instead of 3 (same data and recipe as run 3)
set -euo pipefail
cd /work/wt15   # a worktree of 7b9376b (before issue 17 changed procedural navmeshes): the episodes of runs 3 and rl_small
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
OUT=/work/runs/exp15
DATA=$OUT/data
export RVN_CACHE_DIR=$OUT/cache
CAM=(camera.width=64 camera.height=64)
GEN=(split=train scenes.num_scenes=64 dataset.train_fraction=1.0 workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
t0=$SECONDS
[ -f $OUT/.gen_expert ] || { rvn-gen dataset=expert out_dir=$DATA/rvn_expert trajectories_per_scene=32 "${GEN[@]}" dataset.save_depth=true > $OUT/gen_expert.log 2>&1; touch $OUT/.gen_expert; }
echo "gen_expert $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
[ -f $OUT/.gen_val ] || { rvn-gen dataset=expert out_dir=$DATA/val_expert trajectories_per_scene=4 split=val scenes.num_scenes=10 dataset.train_fraction=1.0 workers=2 progress=false seed=0 renderer=auto "${CAM[@]}" > $OUT/gen_val.log 2>&1; touch $OUT/.gen_val; }
echo "gen_val $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
[ -f $OUT/.train ] || { rvn-train model=nomad_pointgoal model.prediction_type=sample data.root=$DATA/rvn_expert out_dir=$OUT/train/nomad_depth_e4 \
  train.epochs=4 model.size=small train.batch_size=32 data.num_workers=0 'data.goal_offset=[1,40]' train.tqdm_interval=30 seed=0 device=cpu \
  data.val_root=$DATA/val_expert model.depth_aux_weight=0.5 train.lr=1e-3 > $OUT/train.log 2>&1; touch $OUT/.train; }
echo "train $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$OUT/episodes workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
rvn-eval policy=goal_follower "method=Goal follower" out_dir=$OUT/eval/goal_follower "${EVAL[@]}" > $OUT/eval_gf.log 2>&1
echo "eval_gf $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_depth_e4 method=NoMaD-PointGoal-x0-depth-e4-vote +policy.aggregate=vote out_dir=$OUT/eval/nomad_depth_e4_vote "${EVAL[@]}" > $OUT/eval_vote.log 2>&1
echo "eval_vote $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_depth_e4 method=NoMaD-PointGoal-x0-depth-e4 +policy.waypoint_index=null +policy.num_samples=8 out_dir=$OUT/eval/nomad_depth_e4 "${EVAL[@]}" > $OUT/eval_s0.log 2>&1
echo "eval_s0 $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

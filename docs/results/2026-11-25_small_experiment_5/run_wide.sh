#!/usr/bin/env bash
# issue 15 lever: capacity. Run 4's recipe (x0 + depth loss 0.5, 4 epochs, same data, same episodes) with a wider
# image encoder and token: EfficientNet width 0.5 (small: 0.25), encoding_size 128 (small: 64); 2.4M parameters vs 1.2M
set -euo pipefail
until grep -q '^done' /work/runs/exp15b/timings.tsv 2>/dev/null; do sleep 20; done
cd /work/wt15
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
SRC=/work/runs/exp15
OUT=/work/runs/exp15c
DATA=$SRC/data
export RVN_CACHE_DIR=$SRC/cache
CAM=(camera.width=64 camera.height=64)
t0=$SECONDS
export OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
[ -f $OUT/.train ] || { rvn-train model=nomad_pointgoal model.prediction_type=sample data.root=$DATA/rvn_expert out_dir=$OUT/train/nomad_wide \
  train.epochs=4 model.size=small train.batch_size=32 data.num_workers=0 'data.goal_offset=[1,40]' train.tqdm_interval=30 seed=0 device=cpu \
  data.val_root=$DATA/val_expert model.depth_aux_weight=0.5 train.lr=1e-3 \
  model.sizes.small.width_coefficient=0.5 model.sizes.small.encoding_size=128 > $OUT/train.log 2>&1; touch $OUT/.train; }
echo "train $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$SRC/episodes workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_wide method=NoMaD-PointGoal-x0-depth-wide-vote +policy.aggregate=vote out_dir=$OUT/eval/nomad_wide_vote "${EVAL[@]}" > $OUT/eval_vote.log 2>&1
echo "eval_vote $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
echo done >> $OUT/timings.tsv

#!/usr/bin/env bash
# train negatives with depth (128 train scenes x 32, seed 0, 64x64): depth-head frames near obstacles (issue 15 run 8)
set -euo pipefail
cd /work/wt15
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
OUT=/work/runs/exp15i
export RVN_CACHE_DIR=$OUT/cache
t0=$SECONDS
rvn-gen dataset=negative out_dir=$OUT/data/rvn_negative_depth trajectories_per_scene=32 split=train scenes.num_scenes=128 dataset.train_fraction=1.0 workers=2 progress=false seed=0 renderer=auto camera.width=64 camera.height=64 dataset.save_depth=true > $OUT/gen_neg.log 2>&1
echo "gen_negative $((SECONDS-t0))" >> $OUT/timings.tsv

#!/usr/bin/env bash
# issue 15: lever 3's model (twice the data) following sample 0, and voting over 16 samples instead of 8; same 200 val episodes
set -euo pipefail
until grep -q '^rc=' /tmp/pytest_full.log 2>/dev/null; do sleep 10; done
cd /work/wt15
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
SRC=/work/runs/exp15
CK=/work/runs/exp15d/train/nomad_data2x
OUT=/work/runs/exp15f
CAM=(camera.width=64 camera.height=64)
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$SRC/episodes workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$CK method=NoMaD-PointGoal-x0-depth-data2x +policy.waypoint_index=null +policy.num_samples=8 out_dir=$OUT/eval/nomad_data2x "${EVAL[@]}" > $OUT/eval_s0.log 2>&1
echo "eval_s0 $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$CK method=NoMaD-PointGoal-x0-depth-data2x-vote16 +policy.aggregate=vote +policy.num_samples=16 out_dir=$OUT/eval/nomad_data2x_vote16 "${EVAL[@]}" > $OUT/eval_vote16.log 2>&1
echo "eval_vote16 $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

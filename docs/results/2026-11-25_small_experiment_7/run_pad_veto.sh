#!/usr/bin/env bash
# issue 15 run 7: policy.depth_veto=0.5 on the pad model (run_pad.sh), on the 200 val episodes of runs 2-6; ran after
# run_depth2.sh
set -euo pipefail
while kill -0 "${WAIT_PID:-0}" 2>/dev/null; do sleep 20; done
cd /work/wt15
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
OUT=/work/runs/exp15i
export RVN_CACHE_DIR=$OUT/cache
CAM=(camera.width=64 camera.height=64)
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$OUT/episodes workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_pad method=NoMaD-PointGoal-x0-depth-data2x-pad-veto-vote +policy.aggregate=vote +policy.depth_veto=0.5 out_dir=$OUT/eval/nomad_pad_veto_vote "${EVAL[@]}" > $OUT/eval_pad_veto.log 2>&1
echo "eval_pad_veto $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

#!/usr/bin/env bash
# issue 15 run 8: the band veto on the depth-negatives model, then policy.depth_veto_rule=swept at 0.5 m (fixed before any swept eval: the band rule's threshold) on the
# depth-negatives model, then on run 7's pad model; same 200 val episodes, vote of 8. hfov 90 given explicitly: both
# checkpoints were trained before rvn-train recorded it.
set -euo pipefail
while kill -0 "$WAIT_PID" 2>/dev/null; do sleep 20; done
cd /work/wt15
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
OUT=/work/runs/exp15i
export RVN_CACHE_DIR=$OUT/cache OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$OUT/episodes workers=2 progress=false seed=0 renderer=auto camera.width=64 camera.height=64)
SWEPT=(+policy.aggregate=vote +policy.depth_veto=0.5 +policy.depth_veto_rule=swept +policy.depth_veto_hfov=90)
t0=$SECONDS
# the band-veto row of run_depthneg.sh, whose last line lacked Hydra's + (policy.depth_veto is not in conf/policy/checkpoint.yaml)
[ -f $OUT/eval/nomad_depthneg_veto/metrics.json ] || rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_depthneg method=NoMaD-PointGoal-x0-depth-data2x-pad-depthneg-veto +policy.aggregate=vote +policy.depth_veto=0.5 out_dir=$OUT/eval/nomad_depthneg_veto "${EVAL[@]}" > $OUT/eval_depthneg_veto.log 2>&1
echo "eval_depthneg_veto $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_depthneg method=NoMaD-PointGoal-x0-depth-data2x-pad-depthneg-swept "${SWEPT[@]}" out_dir=$OUT/eval/nomad_depthneg_swept "${EVAL[@]}" > $OUT/eval_depthneg_swept.log 2>&1
echo "eval_depthneg_swept $((SECONDS-t0))" >> $OUT/timings.tsv; t0=$SECONDS
rvn-eval policy=checkpoint policy.checkpoint_path=$OUT/train/nomad_pad method=NoMaD-PointGoal-x0-depth-data2x-pad-swept "${SWEPT[@]}" out_dir=$OUT/eval/nomad_pad_swept "${EVAL[@]}" > $OUT/eval_pad_swept.log 2>&1
echo "eval_pad_swept $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

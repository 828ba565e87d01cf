#!/usr/bin/env bash
# issue 15 lever: an ensemble of two trained models (no training). Run 4's model and run 5's no-mask model,
# 8 samples each, one vote over the 16 (policy.ensemble); same 200 val episodes
set -euo pipefail
until grep -q '^done' /work/runs/exp15d/timings.tsv 2>/dev/null; do sleep 20; done
cd /work/wt15   # worktree of 7b9376b + main's encoders.py and policies (policy.ensemble)
export PYTHONPATH=/work/wt15
. /work/main/.venv/bin/activate
SRC=/work/runs/exp15
OUT=/work/runs/exp15e
CAM=(camera.width=64 camera.height=64)
t0=$SECONDS
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=(split=val episodes.num_scenes=50 episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=$SRC/episodes workers=2 progress=false seed=0 renderer=auto "${CAM[@]}")
rvn-eval policy=checkpoint policy.checkpoint_path=$SRC/train/nomad_depth_e4 method=NoMaD-PointGoal-x0-depth-ensemble2-vote +policy.aggregate=vote \
  "+policy.ensemble=[/work/runs/exp15b/train/nomad_nomask]" out_dir=$OUT/eval/nomad_ensemble2_vote "${EVAL[@]}" > $OUT/eval_vote.log 2>&1
echo "eval_vote $((SECONDS-t0))" >> $OUT/timings.tsv
echo done >> $OUT/timings.tsv

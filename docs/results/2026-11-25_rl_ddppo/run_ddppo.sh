#!/usr/bin/env bash
# issue 16: the DD-PPO small row (2 ranks x 4 envs, 1 thread each, 400k env steps), on the code of 7b9376b (the train
# scenes and 200 val episodes of ../2026-11-24_rl_small/) with main's rvn_il and jobs/rl_small.sh; it resumed from the
# 10,240-step checkpoint of the run stopped last session (../2026-11-25_small_experiment_6/run_ddppo.sh).
# The report in this folder is rebuilt by report.sh with the newer IL rows.
set -euo pipefail
cd /work/wt15
export PYTHONPATH=/work/wt15 RVN_CACHE_DIR=/work/runs/rl_ddppo/cache
. /work/main/.venv/bin/activate
R=/work/main/docs/results
export ALGOS=ddppo IL_RUNS="$R/2026-11-24_rl_small/eval/ppo $R/2026-11-24_rl_small/eval/ppo_lag $R/2026-11-25_small_experiment_5/eval/nomad_data2x_vote"
export COMPARE="DD-PPO=PPO;DD-PPO=PPO-Lagrangian;DD-PPO=NoMaD-PointGoal-x0-depth-data2x-vote"
bash /work/main/jobs/rl_small.sh /work/runs/rl_ddppo/out

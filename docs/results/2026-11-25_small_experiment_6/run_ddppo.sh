#!/usr/bin/env bash
# issue 16: DD-PPO at small scale (2 ranks x 4 envs, 1 thread each, 400k env steps) on the code of 7b9376b (the train
# scenes and 200 val episodes of ../2026-11-24_rl_small/); needs ~100 min here (~75 env steps/s over both ranks):
# started this session, stopped at 14,848 steps for the IL lever (see README)
set -euo pipefail
cd /work/wt15
export PYTHONPATH=/work/wt15 RVN_CACHE_DIR=/work/runs/rl_ddppo/cache
. /work/main/.venv/bin/activate
R=/work/main/docs/results
export ALGOS=ddppo IL_RUNS="$R/2026-11-24_rl_small/eval/ppo $R/2026-11-24_rl_small/eval/ppo_lag $R/2026-11-25_small_experiment_5/eval/nomad_data2x_vote"
export COMPARE="DD-PPO=PPO;DD-PPO=PPO-Lagrangian;DD-PPO=NoMaD-PointGoal-x0-depth-data2x-vote"
date > /work/runs/rl_ddppo/started
bash /work/main/jobs/rl_small.sh /work/runs/rl_ddppo/out
date > /work/runs/rl_ddppo/finished

#!/usr/bin/env bash
# issue 16: the DD-PPO + predicted depth small row, as run_ddppo.sh (same code, train scenes, val episodes, 2 ranks x 4
# envs, 400k env steps) with main's rvn_rl copied into the worktree: rl_small.sh first trains the frozen depth
# network (40 rendered pairs on each of the 50 train scenes, 2000 steps; val AbsRel / delta1 on 10 val scenes in
# depth_model/metrics.json), then DD-PPO on RGB + its depth. Rerunning resumes.
set -euo pipefail
cd /work/wt15
export PYTHONPATH=/work/wt15 RVN_CACHE_DIR=/work/runs/rl_ddppo/cache
. /work/main/.venv/bin/activate
export ALGOS=ddppo_depth
bash /work/main/jobs/rl_small.sh /work/runs/rl_ddppo_depth/out

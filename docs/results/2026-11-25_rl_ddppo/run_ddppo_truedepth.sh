#!/usr/bin/env bash
# issue 16: the ablation row "DD-PPO + rendered depth", as run_ddppo_depth.sh (same code, train scenes, val episodes,
# 2 ranks x 4 envs, 400k env steps) with the rendered depth as the 4th channel instead of the depth network's
# (DEPTH_SOURCE=true; evaluated with env.depth=true). Rerunning resumes.
set -euo pipefail
cd /work/wt15
export PYTHONPATH=/work/wt15 RVN_CACHE_DIR=/work/runs/rl_ddppo/cache
. /work/main/.venv/bin/activate
export ALGOS=ddppo_depth DEPTH_SOURCE=true
bash /work/main/jobs/rl_small.sh /work/runs/rl_ddppo_truedepth/out

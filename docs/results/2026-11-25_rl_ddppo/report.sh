#!/usr/bin/env bash
# The report of this folder: every row on the same 200 val episodes (50 val scenes x 4, N_goal 32, 64x64 camera).
set -euo pipefail
cd "$(dirname "$0")"
R=..
python -m rvn_data.benchmark.report $R/2026-11-23_small_experiment_3/eval/random $R/2026-11-23_small_experiment_3/eval/goal_follower \
  $R/2026-11-23_small_experiment_3/eval/trajectory_oracle $R/2026-11-24_rl_small/eval/ppo $R/2026-11-24_rl_small/eval/ppo_lag \
  eval/ddppo eval/ddppo_depth eval/ddppo_truedepth $R/2026-11-25_small_experiment_8/eval/nomad_depthneg_vote $R/2026-11-25_small_experiment_8/eval/nomad_depthneg_swept \
  -o report.md --title "RL baselines beside the IL rows, small scale (200 val episodes)" \
  "--compare=DD-PPO=Goal follower" "--compare=DD-PPO=PPO" "--compare=DD-PPO=PPO-Lagrangian" \
  "--compare=DD-PPO + predicted depth=DD-PPO" "--compare=DD-PPO + predicted depth=PPO" \
  "--compare=DD-PPO + predicted depth=Goal follower" \
  "--compare=DD-PPO + rendered depth=DD-PPO + predicted depth" "--compare=DD-PPO + rendered depth=DD-PPO" \
  "--compare=DD-PPO + rendered depth=PPO" \
  "--compare=NoMaD-PointGoal-x0-depth-data2x-pad-depthneg-swept=DD-PPO + rendered depth" \
  "--compare=NoMaD-PointGoal-x0-depth-data2x-pad-depthneg-swept=DD-PPO + predicted depth" \
  "--compare=NoMaD-PointGoal-x0-depth-data2x-pad-depthneg-vote=DD-PPO" \
  "--compare=NoMaD-PointGoal-x0-depth-data2x-pad-depthneg-swept=DD-PPO"

#!/usr/bin/env bash
# Small-scale RL baselines on a CPU machine (issue 16): rvn-rl PPO and PPO-Lagrangian at reduced size
# (ResNet-18 at base width 16, 64x64 RGB, 50 train scenes), rvn-eval on 200 val episodes (50 val scenes x 4) for each,
# the blind goal follower as the reference row, then the report with significance tests.
#
#   bash jobs/rl_small.sh [OUT]                  # SCALE=small: < 2 h on 2 CPU cores
#   SCALE=tiny bash jobs/rl_small.sh /tmp/x      # smoke test: a few hundred steps, 1 episode
#   IL_RUNS="runs/small_experiment_small/eval/nomad_pointgoal ..." bash jobs/rl_small.sh   # IL rows beside
#
# Every knob below can be set in the environment. Rerunning resumes: a step whose exact command
# already succeeded is skipped (OUT/.done/); rvn-rl continues from its latest checkpoint and rvn-eval
# skips finished episodes. Logs: OUT/logs/<step>.log; wall time per step: OUT/timings.tsv.
set -euo pipefail
SCALE=${SCALE:-small}
OUT=${1:-${OUT:-runs/rl_small_${SCALE}}}
case "$SCALE" in
  small)  # two trainings side by side, ~95-105 min at 65-75 env steps/s each (collection + learning); evaluations ~2.5 min each
    : "${TOTAL_STEPS:=400000}" "${IMAGE:=64}" "${NUM_ENVS:=8}" "${TRAIN_SCENES:=50}" "${ROLLOUT:=64}" "${MINI_BATCHES:=4}"
    : "${EVAL_SCENES:=50}" "${EVAL_EPISODES:=4}" "${N_GOALS:=32}" "${T_MAX:=500}" ;;
  tiny)   # smoke test of the whole chain
    : "${TOTAL_STEPS:=64}" "${IMAGE:=32}" "${NUM_ENVS:=2}" "${TRAIN_SCENES:=2}" "${ROLLOUT:=16}" "${MINI_BATCHES:=2}"
    : "${EVAL_SCENES:=1}" "${EVAL_EPISODES:=1}" "${N_GOALS:=2}" "${T_MAX:=50}" ;;
  *) echo "rl_small.sh: error: SCALE=$SCALE; choose small or tiny" >&2; exit 2 ;;
esac
: "${BACKBONE:=resnet18}"     # resnet18 | resnet50 (the paper's, half width)
: "${BASE_PLANES:=16}"        # ResNet base width (the paper's: 32); 16 halves the cost of an update
: "${GOAL_POOL:=64}"          # train goals per scene whose distance fields are computed once
: "${COST_LIMIT:=1e-4}"       # PPO-Lagrangian expected episode cost limit (the paper's)
: "${LAMBDA_MAX:=1.0}"        # upper bound on the Lagrange multiplier (null: none). At this scale nearly every
                              # training episode ends in a collision (J_c ~ 1 >> 1e-4), so an unbounded lambda grows
                              # ~0.035 per update and the policy learns to turn in place; 1.0 weighs cost like reward
: "${WORKERS:=2}"             # rvn-eval worker processes
: "${ENV_WORKERS:=0}"         # rvn-rl env worker processes (0: in the learner's process)
: "${PARALLEL:=1}"            # 1: train PPO and PPO-Lagrangian at the same time (one process per core)
: "${THREADS:=$([[ $PARALLEL == 1 ]] && echo 1 || echo 2)}"   # torch threads per training
: "${SEED:=0}"
: "${DEVICE:=cpu}"
: "${RENDERER:=auto}"
: "${IL_RUNS:=}"              # rvn-eval out_dirs of other rows (same val episodes) to put in the report
PY=${PYTHON:-python}
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"   # step NAME CMD...: skip if done, log, time
export OMP_NUM_THREADS=$THREADS MKL_NUM_THREADS=$THREADS
CAMERA=("camera.width=$IMAGE" "camera.height=$IMAGE")
RL=("scale=small" "env.size=$IMAGE" "env.num_envs=$NUM_ENVS" "env.num_scenes=$TRAIN_SCENES" "env.workers=$ENV_WORKERS"
    "model.backbone=$BACKBONE" "model.base_planes=$BASE_PLANES" "model.ngroups=$((BASE_PLANES / 2))"
    "env.goal_pool=$GOAL_POOL" "ppo.num_steps=$ROLLOUT" "ppo.num_mini_batch=$MINI_BATCHES" "train.total_steps=$TOTAL_STEPS" "train.threads=$THREADS"
    "train.checkpoint_every=20" "env.t_max=$T_MAX" "seed=$SEED" "device=$DEVICE" "renderer=$RENDERER" "progress=false")
EVAL=("split=val" "episodes.num_scenes=$EVAL_SCENES" "episodes.per_scene=$EVAL_EPISODES" "episodes.n_goals=$N_GOALS"
      "env.t_max=$T_MAX" "episodes.dir=$OUT/episodes" "workers=$WORKERS" "progress=false" "seed=$SEED" "renderer=$RENDERER"
      "${CAMERA[@]}")
echo "rl_small: SCALE=$SCALE OUT=$OUT: PPO and PPO-Lagrangian, $TOTAL_STEPS env steps each, $BACKBONE, ${IMAGE}x$IMAGE," \
     "$NUM_ENVS envs, $TRAIN_SCENES train scenes; eval $EVAL_SCENES val scenes x $EVAL_EPISODES episodes x $N_GOALS goals"
if [[ "$PARALLEL" == 1 ]]; then  # the two trainings side by side, THREADS torch threads each
  step train_ppo rvn-rl algo=ppo out_dir="$OUT/train/ppo" "${RL[@]}" & ppo_pid=$!
  step train_ppo_lag rvn-rl algo=ppo_lag out_dir="$OUT/train/ppo_lag" algo.cost_limit="$COST_LIMIT" algo.lambda_max="$LAMBDA_MAX" "${RL[@]}" & lag_pid=$!
  wait $ppo_pid && wait $lag_pid || { echo "rl_small: a training failed (logs in $OUT/logs/)" >&2; exit 1; }
else
  step train_ppo rvn-rl algo=ppo out_dir="$OUT/train/ppo" "${RL[@]}"
  step train_ppo_lag rvn-rl algo=ppo_lag out_dir="$OUT/train/ppo_lag" algo.cost_limit="$COST_LIMIT" algo.lambda_max="$LAMBDA_MAX" \
    "${RL[@]}"
fi
step eval_goal_follower rvn-eval policy=goal_follower "method=Goal follower" out_dir="$OUT/eval/goal_follower" "${EVAL[@]}"
step eval_ppo rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/ppo" method=PPO out_dir="$OUT/eval/ppo" "${EVAL[@]}"
step eval_ppo_lag rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/ppo_lag" method=PPO-Lagrangian \
  out_dir="$OUT/eval/ppo_lag" "${EVAL[@]}"
RUNS=("$OUT/eval/goal_follower" "$OUT/eval/ppo" "$OUT/eval/ppo_lag")
for run in $IL_RUNS; do RUNS+=("$run"); done
COMPARE=("PPO=Goal follower" "PPO-Lagrangian=PPO" "PPO-Lagrangian=Goal follower")
$PY -m rvn_data.benchmark.report "${RUNS[@]}" -o "$OUT/report.md" "${COMPARE[@]/#/--compare=}" \
  --title "RL baselines, small scale (SCALE=$SCALE)"
echo "rl_small: this run took $SECONDS s ($STEPS_SECONDS s in steps run now); report: $OUT/report.md;" \
     "learning curves: $OUT/train/*/learning_curve.png"

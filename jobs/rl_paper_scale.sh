#!/usr/bin/env bash
# Paper-scale RL baselines on a Slurm cluster (issue 16): PPO and PPO-Lagrangian on one GPU each,
# DD-PPO and DD-PPO + depth on NODES x GPUS ranks (torchrun started by srun on every node, one rank
# per GPU, NCCL), all with `scale=paper` (half-width ResNet-50 on 256x256 RGB pooled to 128, 2-layer
# LSTM 512, DD-PPO PointNav hyperparameters, 4 envs per GPU, 800 train scenes), then rvn-eval on
# val and test (20 episodes per scene; Slurm array tasks of EVAL_SHARD_SCENES scenes, conf/hydra/launcher/slurm.yaml)
# and the report.
#
#   OUT=/data/rvn_rl PARTITION=gpu ACCOUNT=myproj NODES=2 GPUS=4 bash jobs/rl_paper_scale.sh
#   DRY_RUN=1 bash jobs/rl_paper_scale.sh          # print the sbatch scripts and commands, submit nothing
#   DEPTH_MODEL=/data/rvn/depth/model.safetensors  # the frozen depth network (rvn_rl/depth) for ddppo_depth;
#                                                  # DEPTH_SOURCE=true trains on the rendered depth instead
# Rerunning resumes: rvn-rl continues from out_dir's latest checkpoint, rvn-eval skips finished episodes.
set -euo pipefail
OUT=${OUT:-/data/rvn_rl}
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}   # the 800 scenes' navmeshes and goal pools, built once for all jobs
NODES=${NODES:-2}                 # DD-PPO nodes (the paper: 8 GPUs in all)
GPUS=${GPUS:-4}                   # GPUs (ranks) per node
STEPS=${STEPS:-2500000000}        # env steps (habitat-baselines' DD-PPO PointNav budget; the paper: "until convergence")
TIME=${TIME:-3-00:00:00}
DEPTH_SOURCE=${DEPTH_SOURCE:-model}
DEPTH_MODEL=${DEPTH_MODEL:-}
ALGOS=${ALGOS:-"ppo ppo_lag ddppo ddppo_depth"}
EVAL_SHARD_SCENES=${EVAL_SHARD_SCENES:-5}  # scenes per rvn-eval array task (val and test: 50 scenes each)
SBATCH=(${PARTITION:+"--partition=$PARTITION"} ${ACCOUNT:+"--account=$ACCOUNT"})
LAUNCH=("hydra/launcher=slurm" ${PARTITION:+"hydra.launcher.partition=$PARTITION"} ${ACCOUNT:+"hydra.launcher.account=$ACCOUNT"})
COMMON=("scale=paper" "train.total_steps=$STEPS" "progress=false")

run() {  # print the command (shell-quoted), then run it unless DRY_RUN
  echo "+$(printf ' %q' "$@")"
  [[ -n "${DRY_RUN:-}" ]] || "$@"
}
TRAINING=()  # "pid name" of each background sbatch --wait (its exit status is the job's)
submit() {  # submit NAME NODES GPUS_PER_NODE COMMAND: one sbatch job, waited for in the background
  local name=$1 nodes=$2 gpus=$3 cmd=$4
  local script="#!/bin/bash
#SBATCH --job-name=rvn-rl-$name --nodes=$nodes --ntasks-per-node=1 --gpus-per-node=$gpus
#SBATCH --cpus-per-task=$((gpus * 8)) --time=$TIME --output=$OUT/logs/$name-%j.log
${SETUP:-}
export RVN_CACHE_DIR=$(printf %q "$RVN_CACHE_DIR")
export MASTER_ADDR=\$(scontrol show hostnames \"\$SLURM_JOB_NODELIST\" | head -n 1) MASTER_PORT=\$((20000 + SLURM_JOB_ID % 20000))
$cmd"
  echo "---- $name"; echo "$script"
  if [[ -z "${DRY_RUN:-}" ]]; then sbatch --wait "${SBATCH[@]}" <<<"$script" & TRAINING+=("$! $name"); fi
}
if [[ " $ALGOS " == *" ddppo_depth "* && "$DEPTH_SOURCE" == model && -z "$DEPTH_MODEL" ]]; then
  echo "rl_paper_scale.sh: error: ddppo_depth needs DEPTH_MODEL=<trained depth model> (or DEPTH_SOURCE=true)" >&2; exit 2
fi
mkdir -p "$OUT/logs"
for algo in $ALGOS; do
  extra=()
  if [[ "$algo" == ddppo_depth ]]; then
    extra=("depth.source=$DEPTH_SOURCE")
    [[ "$DEPTH_SOURCE" == model ]] && extra+=("depth.model_path=$DEPTH_MODEL")
  fi
  args="algo=$algo out_dir=$OUT/train/$algo ${COMMON[*]} ${extra[*]}"
  case "$algo" in
    ppo|ppo_lag) submit "$algo" 1 1 "rvn-rl $args" ;;
    # srun gets the CPUs explicitly: Slurm 22.05-23.02's srun does not inherit sbatch's --cpus-per-task (one CPU a task)
    *) submit "$algo" "$NODES" "$GPUS" "srun --cpus-per-task=$((GPUS * 8)) torchrun --nnodes=$NODES --nproc_per_node=$GPUS --rdzv_id=\$SLURM_JOB_ID \
--rdzv_backend=c10d --rdzv_endpoint=\$MASTER_ADDR:\$MASTER_PORT -m rvn_rl.cli $args" ;;
  esac
done
# every job is waited for (a rerun would otherwise submit a second copy of one still running), then a failed one stops
# the recipe before the benchmark evaluates a model it did not finish
FAILED=()
for t in ${TRAINING[@]+"${TRAINING[@]}"}; do wait "${t%% *}" || FAILED+=("rvn-rl-${t#* } ($OUT/logs/${t#* }-<job id>.log)"); done
if (( ${#FAILED[@]} )); then
  echo "rl_paper_scale.sh: error: training job(s) failed: ${FAILED[*]}; fix the cause and rerun (rvn-rl resumes from its latest checkpoint)" >&2
  exit 1
fi
# the benchmark on the cluster as well: one array task per EVAL_SHARD_SCENES scenes, on a GPU (the launcher's
# gpus_per_node); the report merges each row's shards
declare -A METHOD=([ppo]=PPO [ppo_lag]=PPO-Lagrangian [ddppo]=DD-PPO [ddppo_depth]=DDPPO-depth)
RUNS=()
for split in val test; do
  for algo in $ALGOS; do
    env_depth=()
    [[ "$algo" == ddppo_depth && "$DEPTH_SOURCE" == true ]] && env_depth=("env.depth=true")
    run rvn-eval -m "${LAUNCH[@]}" policy=checkpoint policy.checkpoint_path="$OUT/train/$algo" policy.device=cuda \
      method="${METHOD[$algo]}" split=$split episodes.num_scenes="$EVAL_SHARD_SCENES" \
      "episodes.first_scene=range(0,50,$EVAL_SHARD_SCENES)" workers=8 progress=false \
      hydra.sweep.dir="$OUT/eval/.multirun/$split/$algo" "out_dir=$OUT/eval/$split/$algo/scenes_\${episodes.first_scene}" \
      "${env_depth[@]}"
    RUNS+=("$OUT/eval/$split/$algo")
  done
done
run python -m rvn_data.benchmark.report "${RUNS[@]}" -o "$OUT/report.md" --title "RL baselines, paper scale"

#!/usr/bin/env bash
# Small-scale RL baselines on a CPU machine (issue 16): rvn-rl PPO, PPO-Lagrangian and (ALGOS=...) DD-PPO and
# DD-PPO + depth at reduced size (ResNet-18 at base width 16, 64x64 RGB, 50 train scenes), rvn-eval on 200 val episodes (50 val
# scenes x 4) for each, the blind goal follower as the reference row, then the report with significance tests.
#
#   bash jobs/rl_small.sh [OUT]                  # SCALE=small: PPO and PPO-Lagrangian, < 2 h on 2 CPU cores
#   ALGOS=ddppo bash jobs/rl_small.sh [OUT]      # DD-PPO: torchrun, RANKS ranks x NUM_ENVS/RANKS envs
#   ALGOS=ddppo_depth bash jobs/rl_small.sh      # depth network trained on rendered pairs (val AbsRel, delta1 in
#                                                # OUT/depth_model/metrics.json), frozen; DD-PPO on RGB + its depth
#   ALGOS=ddppo_depth DEPTH_SOURCE=true ...      # the ablation: DD-PPO on RGB + the rendered depth (OUT/train and
#                                                # OUT/eval ddppo_depth_true: the predicted-depth run's stay its own)
#   SCALE=tiny bash jobs/rl_small.sh /tmp/x      # smoke test: a few hundred steps, 1 episode
#   IL_RUNS="runs/small_experiment_small/eval/nomad_pointgoal ..." bash jobs/rl_small.sh   # other rows beside
#   ALGOS=ppo_lag TAG=stop_far RL_EXTRA="env.stop_far_is_failure=true" bash jobs/rl_small.sh runs/rl_small_small
#                                                # a variant beside the runs in OUT: OUT/{train,eval}/ppo_lag_stop_far,
#                                                # "PPO-Lagrangian stop_far", the same caches and val episodes
#   TRAIN_SEED=1 TAG=seed1 bash jobs/rl_small.sh runs/rl_small_small    # a second training seed, the same val episodes;
#                                                # its report holds the first seed's rows too, pairs pooled over both
#   ALGOS=ppo TOTAL_STEPS=600000 FROM=untagged TAG=600k bash jobs/rl_small.sh runs/rl_small_small
#                                                # the PPO run trained on to 600k env steps in OUT/train/ppo_600k
#                                                # (rvn-rl train.continue_from), the 400k run left as it was evaluated:
#                                                # row "PPO 600k" against "PPO"; a second seed's: TRAIN_SEED=1
#                                                # FROM=seed1 TAG=600k_seed1, row "PPO 600k seed1", pooled with seed 0's
#   EVAL_CHECKPOINTS=3 bash jobs/rl_small.sh runs/rl_small_small
#                                                # each run's row also at its 2 checkpoints before the latest (SCALE=small's
#                                                # default: 1 before it): rows "PPO ckpt<env steps>" (OUT/eval/ppo_ckpt<env
#                                                # steps>); the report reads each row over them (their mean, tested pair by pair)
#
# Every knob below can be set in the environment. Rerunning resumes: a step whose exact command
# already succeeded is skipped (OUT/.done/) unless a step before it ran again (jobs/lib.sh); rvn-rl continues
# from its latest checkpoint and rvn-eval skips finished episodes. Logs: OUT/logs/<step>.log; wall time per step: OUT/timings.tsv.
set -euo pipefail
SCALE=${SCALE:-small}
OUT=${1:-${OUT:-runs/rl_small_${SCALE}}}
case "$SCALE" in
  small)  # two trainings side by side, ~95-105 min at 65-75 env steps/s each (collection + learning); evaluations ~2.5 min each
    : "${TOTAL_STEPS:=400000}" "${IMAGE:=64}" "${NUM_ENVS:=8}" "${TRAIN_SCENES:=50}" "${ROLLOUT:=64}" "${MINI_BATCHES:=4}"
    : "${EVAL_SCENES:=50}" "${EVAL_EPISODES:=4}" "${N_GOALS:=32}" "${T_MAX:=500}" "${EVAL_CHECKPOINTS:=2}"
    : "${DEPTH_PAIRS:=40}" "${DEPTH_VAL_SCENES:=10}" "${DEPTH_STEPS:=2000}" ;;
  tiny)   # smoke test of the whole chain
    : "${TOTAL_STEPS:=64}" "${IMAGE:=32}" "${NUM_ENVS:=4}" "${TRAIN_SCENES:=2}" "${ROLLOUT:=16}" "${MINI_BATCHES:=2}"
    : "${EVAL_SCENES:=1}" "${EVAL_EPISODES:=1}" "${N_GOALS:=2}" "${T_MAX:=50}"
    : "${DEPTH_PAIRS:=4}" "${DEPTH_VAL_SCENES:=1}" "${DEPTH_STEPS:=10}" ;;
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
: "${ALGOS:=ppo ppo_lag}"     # any of ppo ppo_lag ddppo ddppo_depth; ppo and ppo_lag train side by side (PARALLEL),
                              # ddppo and ddppo_depth after, in that order
: "${RANKS:=2}"               # DD-PPO ranks (torchrun, gloo on CPU, 1 torch thread each); NUM_ENVS is split over them
: "${PARALLEL:=1}"            # 1: train PPO and PPO-Lagrangian at the same time (one process per core)
: "${THREADS:=$([[ $PARALLEL == 1 ]] && echo 1 || echo 2)}"   # torch threads per training
: "${DEPTH_SOURCE:=model}"    # ddppo_depth's 4th channel: model (the depth network trained here from DEPTH_PAIRS
                              # rendered pairs per train scene, DEPTH_STEPS steps; val on DEPTH_VAL_SCENES val scenes)
                              # or true (the rendered depth: the ablation row)
: "${DEPTH_MODEL:=}"          # a trained depth model's out_dir (python -m rvn_rl.depth.cli) to use instead
: "${DEPTH_THREADS:=2}"       # torch threads of the depth network's training (it runs alone)
: "${SEED:=0}"                # the val episodes' seed, and the trainings' unless TRAIN_SEED says otherwise
: "${TRAIN_SEED:=$SEED}"      # the trainings' (and the depth network's) seed: another training seed evaluated on the
                              # same val episodes is TRAIN_SEED=1 TAG=seed1 in the same OUT
: "${DEVICE:=cpu}"
: "${RENDERER:=auto}"
: "${IL_RUNS:=}"              # rvn-eval out_dirs of other rows (same val episodes) to put in the report, each with
                              # its evaluations of other checkpoints beside it (<out_dir>_ckpt<env steps>)
: "${RL_EXTRA:=}"             # more rvn-rl overrides for every training, separated by spaces (e.g.
                              # env.stop_far_is_failure=true); needs TAG where OUT holds the untagged runs already
: "${TAG:=}"                  # a variant's name: its runs are OUT/train/<algo>_TAG and OUT/eval/<algo>_TAG, its rows
                              # "<method> TAG", so that it neither resumes nor overwrites the untagged runs; a TAG
                              # ending in _seed<s> is another training seed of a variant: rows "<method> <variant>
                              # seed<s>", which the report pools with the variant's "<method> <variant>"
: "${FROM:=}"                 # the TAG of runs in OUT to continue (untagged: the untagged runs): each algo's run of this
                              # TAG starts from the latest checkpoint of OUT/train/<algo>_FROM (rvn-rl
                              # train.continue_from) and trains on to TOTAL_STEPS, which counts that run's steps; that
                              # run stays as it was evaluated, and the report tests the new rows against its rows
: "${EVAL_CHECKPOINTS:=1}"    # SCALE=small: 2. Evaluate each run at its last EVAL_CHECKPOINTS kept checkpoints (rvn-eval
                              # +policy.env_steps): the latest as the row, the others as rows "<row> ckpt<env steps>"
                              # that the report reads the row over (rvn_data.benchmark.significance.over_checkpoints),
                              # since at this scale a row moves by an SD of 0.03-0.04 SR_1 between checkpoints, a 200-
                              # episode row's binomial error (docs/results/2026-12-06_ppo_five_checkpoints); above 2,
                              # rvn-rl keeps as many (train.keep_checkpoints; a run trained before keeps 2)
: "${COMPARE:=}"              # extra "A=B" method pairs to test in the report, separated by ';' (e.g. "DD-PPO=PPO" with
                              # a PPO row among IL_RUNS); a pair naming a row the report does not have (not evaluated
                              # yet by a recipe running beside, or a typo) is listed as not tested, not an error
has() { [[ " $ALGOS " == *" $1 "* ]]; }
for algo in $ALGOS; do
  case "$algo" in ppo|ppo_lag|ddppo|ddppo_depth) ;; *) echo "rl_small.sh: error: ALGOS contains '$algo'; choose among ppo ppo_lag ddppo ddppo_depth" >&2; exit 2 ;; esac
done
if has ddppo_depth; then
  case "$DEPTH_SOURCE" in model|true) ;; *) echo "rl_small.sh: error: DEPTH_SOURCE=$DEPTH_SOURCE; choose model or true" >&2; exit 2 ;; esac
  if [[ -n "$DEPTH_MODEL" && ! -f "$DEPTH_MODEL/model.json" ]]; then
    echo "rl_small.sh: error: DEPTH_MODEL=$DEPTH_MODEL holds no model.json; give the out_dir of python -m rvn_rl.depth.cli" >&2
    exit 2
  fi
fi
if { has ddppo || has ddppo_depth; } && (( RANKS < 1 || NUM_ENVS % RANKS || NUM_ENVS / RANKS < MINI_BATCHES )); then
  echo "rl_small.sh: error: NUM_ENVS=$NUM_ENVS must split over RANKS=$RANKS DD-PPO ranks into at least" \
       "MINI_BATCHES=$MINI_BATCHES envs each" >&2; exit 2
fi
for knob in TAG FROM; do
  if [[ -n "${!knob}" && ! "${!knob}" =~ ^[A-Za-z0-9_-]+$ ]]; then
    echo "rl_small.sh: error: $knob='${!knob}'; use letters, digits, '_' and '-' (it names run folders)" >&2; exit 2
  fi
done
if [[ ! "$EVAL_CHECKPOINTS" =~ ^[1-9][0-9]*$ ]]; then
  echo "rl_small.sh: error: EVAL_CHECKPOINTS=$EVAL_CHECKPOINTS; give how many of each run's last checkpoints to evaluate (1: the latest)" >&2
  exit 2
fi
if [[ "$TAG" =~ (^|_)ckpt[0-9]+$ ]]; then
  echo "rl_small.sh: error: TAG=$TAG ends like an evaluation of another checkpoint (<run>_ckpt<env steps>); choose another TAG" >&2
  exit 2
fi
if [[ "$TAG" == untagged ]]; then
  echo "rl_small.sh: error: TAG=untagged names the untagged runs (FROM=untagged); choose another TAG" >&2; exit 2
fi
if [[ -n "$FROM" && ( -z "$TAG" || "$FROM" == "$TAG" ) ]]; then
  echo "rl_small.sh: error: FROM=$FROM continues those runs in runs of another TAG; give one (e.g. TAG=${FROM}_more)," \
       "so that the runs continued stay as they were evaluated" >&2; exit 2
fi
read -ra RL_EXTRA_ARGS <<<"$RL_EXTRA"
# each algo's run folder (run_of ALGO TAG; the untagged run with TAG empty); the rendered-depth ablation its own, so it
# neither resumes nor overwrites the predicted-depth run
declare -A BASE_NAME=([ppo]=ppo [ppo_lag]=ppo_lag [ddppo]=ddppo
                      [ddppo_depth]=$([[ "$DEPTH_SOURCE" == true ]] && echo ddppo_depth_true || echo ddppo_depth))
run_of() { echo "${BASE_NAME[$1]}${2:+_$2}"; }
declare -A RUN_NAME=() CONTINUE=()
FROM_TAG=$([[ "$FROM" == untagged ]] || echo "$FROM")
for algo in "${!BASE_NAME[@]}"; do RUN_NAME[$algo]=$(run_of "$algo" "$TAG"); done
for algo in $ALGOS; do  # the runs to continue: each must have saved a checkpoint
  if [[ -z "$FROM" ]]; then continue; fi
  src=$OUT/train/$(run_of "$algo" "$FROM_TAG")
  if [[ ! -f "$src/checkpoints/latest" ]]; then
    echo "rl_small.sh: error: FROM=$FROM: $src holds no checkpoint to continue; train it first, or give FROM the TAG" \
         "of runs in $OUT/train" >&2; exit 2
  fi
  CONTINUE[$algo]=train.continue_from=$(cd "$src" && pwd)
done
if [[ ${#RL_EXTRA_ARGS[@]} -gt 0 && -z "$TAG" ]]; then
  for algo in $ALGOS; do
    if [[ -d "$OUT/train/${RUN_NAME[$algo]}" ]]; then
      echo "rl_small.sh: error: RL_EXTRA='$RL_EXTRA' would continue $OUT/train/${RUN_NAME[$algo]}, trained without it;" \
           "give the variant a TAG (TAG=name: OUT/train/${RUN_NAME[$algo]}_name) or another OUT" >&2; exit 2
    fi
  done
fi
PY=${PYTHON:-python}
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"   # step NAME CMD...: skip if done, log, time
export OMP_NUM_THREADS=$THREADS MKL_NUM_THREADS=$THREADS
# one cache root for every step (README, Caches): each train scene's navmesh and goal pool is built once, by whichever
# of PPO and PPO-Lagrangian (side by side, drawing the same scene stream) asks first while the other waits for it,
# and read by the DD-PPO rows; each val scene's navmesh once for all the evaluations. Every run kept its own before.
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}
CAMERA=("camera.width=$IMAGE" "camera.height=$IMAGE")
RL=("scale=small" "env.size=$IMAGE" "env.num_scenes=$TRAIN_SCENES" "env.workers=$ENV_WORKERS"
    "model.backbone=$BACKBONE" "model.base_planes=$BASE_PLANES" "model.ngroups=$((BASE_PLANES / 2))"
    "env.goal_pool=$GOAL_POOL" "ppo.num_steps=$ROLLOUT" "ppo.num_mini_batch=$MINI_BATCHES" "train.total_steps=$TOTAL_STEPS"
    "train.checkpoint_every=20" "env.t_max=$T_MAX" "seed=$TRAIN_SEED" "device=$DEVICE" "renderer=$RENDERER" "progress=false"
    "${RL_EXTRA_ARGS[@]}")
if (( EVAL_CHECKPOINTS > 2 )); then RL+=("train.keep_checkpoints=$EVAL_CHECKPOINTS"); fi
EVAL=("split=val" "episodes.num_scenes=$EVAL_SCENES" "episodes.per_scene=$EVAL_EPISODES" "episodes.n_goals=$N_GOALS"
      "env.t_max=$T_MAX" "episodes.dir=$OUT/episodes" "workers=$WORKERS" "progress=false" "seed=$SEED" "renderer=$RENDERER"
      "${CAMERA[@]}")
echo "rl_small: SCALE=$SCALE OUT=$OUT: $ALGOS, $TOTAL_STEPS env steps each, $BACKBONE, ${IMAGE}x$IMAGE," \
     "$NUM_ENVS envs, $TRAIN_SCENES train scenes; eval $EVAL_SCENES val scenes x $EVAL_EPISODES episodes x $N_GOALS goals"
SINGLE=("env.num_envs=$NUM_ENVS" "train.threads=$THREADS" "${RL[@]}")
train_ppo() {
  step "train_${RUN_NAME[ppo]}" rvn-rl algo=ppo out_dir="$OUT/train/${RUN_NAME[ppo]}" "${SINGLE[@]}" \
    ${CONTINUE[ppo]+"${CONTINUE[ppo]}"}
}
train_ppo_lag() {
  step "train_${RUN_NAME[ppo_lag]}" rvn-rl algo=ppo_lag out_dir="$OUT/train/${RUN_NAME[ppo_lag]}" \
    algo.cost_limit="$COST_LIMIT" algo.lambda_max="$LAMBDA_MAX" "${SINGLE[@]}" \
    ${CONTINUE[ppo_lag]+"${CONTINUE[ppo_lag]}"}
}
if [[ "$PARALLEL" == 1 ]] && has ppo && has ppo_lag; then  # the two trainings side by side, THREADS torch threads each
  # each in a process group of its own (set -m), so that when one fails, or the recipe is stopped, the other is stopped
  # with every process it started (killing its subshell alone would leave its rvn-rl running)
  mkdir -p "$OUT/train"  # their common parent: each tool's write check would make it, and remove it, at once
  set -m
  train_ppo & ppo_pid=$!
  train_ppo_lag & lag_pid=$!
  set +m
  trap 'kill -- -$ppo_pid -$lag_pid 2>/dev/null || true' EXIT
  for _ in 1 2; do  # whichever ends first
    wait -n || { echo "rl_small: a training failed (logs in $OUT/logs/); the other one was stopped" >&2; exit 1; }
  done
  trap - EXIT
  # they ran in subshells: a training that ran makes every evaluation run again
  step_seen "train_${RUN_NAME[ppo]}" "train_${RUN_NAME[ppo_lag]}"
else
  if has ppo; then train_ppo; fi
  if has ppo_lag; then train_ppo_lag; fi
fi
# decentralised PPO: the same env steps in all, over RANKS processes of 1 thread; train_ddppo ALGO NAME [OVERRIDES...]
# (NAME: the run's folder in OUT/train and OUT/eval)
train_ddppo() {
  local algo=$1 name=$2; shift 2
  step "train_$name" env OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 $PY -m torch.distributed.run --standalone \
    --nproc_per_node="$RANKS" -m rvn_rl.cli algo="$algo" out_dir="$OUT/train/$name" "$@" \
    "env.num_envs=$((NUM_ENVS / RANKS))" "train.threads=1" "${RL[@]}" ${CONTINUE[$algo]+"${CONTINUE[$algo]}"}
}
if has ddppo; then train_ddppo ddppo "${RUN_NAME[ddppo]}"; fi
if has ddppo_depth; then  # the same DD-PPO with depth as a 4th channel
  DEPTH_ARGS=("depth.source=$DEPTH_SOURCE")
  if [[ "$DEPTH_SOURCE" == model ]]; then
    if [[ -z "$DEPTH_MODEL" ]]; then  # train the frozen depth network on rendered (RGB, depth) pairs of the train scenes
      DEPTH_MODEL="$OUT/depth_model"
      step train_depth_model $PY -m rvn_rl.depth.cli out_dir="$DEPTH_MODEL" image_size="$IMAGE" \
        pairs.train_scenes="$TRAIN_SCENES" pairs.val_scenes="$DEPTH_VAL_SCENES" pairs.per_scene="$DEPTH_PAIRS" \
        train.steps="$DEPTH_STEPS" threads="$DEPTH_THREADS" seed="$TRAIN_SEED" renderer="$RENDERER" progress=false
    fi
    DEPTH_ARGS+=("depth.model_path=$DEPTH_MODEL")
  fi
  train_ddppo ddppo_depth "${RUN_NAME[ddppo_depth]}" "${DEPTH_ARGS[@]}"
fi
step eval_goal_follower rvn-eval policy=goal_follower "method=Goal follower" out_dir="$OUT/eval/goal_follower" "${EVAL[@]}"
RUNS=("$OUT/eval/goal_follower")
DEPTH_NAME=$([[ "$DEPTH_SOURCE" == true ]] && echo rendered || echo predicted)
declare -A METHOD=([ppo]=PPO [ppo_lag]=PPO-Lagrangian [ddppo]=DD-PPO [ddppo_depth]="DD-PPO + $DEPTH_NAME depth")
# a row's label: "<method>", "<method> TAG", a TAG ending in _seed<s> as "<method> <variant> seed<s>" (the report pools
# "<A> seed<s>" rows with "<A>": rvn_data.benchmark.significance.pooled_pairs)
label_of() {
  local tag=$2
  if [[ "$tag" =~ ^(.+)_(seed[0-9]+)$ ]]; then tag="${BASH_REMATCH[1]} ${BASH_REMATCH[2]}"; fi
  echo "${METHOD[$1]}${tag:+ $tag}"
}
# TAG=<v>_seed<s> is seed s of variant <v> (its seed-0 runs: TAG=<v>); TAG=seed<s> seed s of the untagged runs
seed_of() { if [[ "$1" =~ (^|_)seed([0-9]+)$ ]]; then echo "${BASH_REMATCH[2]}"; fi; }
variant_of() {
  local s; s=$(seed_of "$1")
  if [[ -z "$s" ]]; then echo "$1"; else local v=${1%seed"$s"}; echo "${v%_}"; fi
}
PAIRS=()
declare -A SEEN=() ADDED=()
pair() { if [[ -n "$1" && -z "${SEEN[$1]:-}" ]]; then SEEN[$1]=1; PAIRS+=("$1"); fi; }   # each pair once
add_run() {  # add_run DIR: an evaluation joins the report (each once), with its evaluations of other checkpoints
  local dir=$1 other
  if [[ -n "${ADDED[$dir]:-}" ]]; then return; fi
  ADDED[$dir]=1; RUNS+=("$dir")
  for other in "${dir}"_ckpt*; do
    if [[ "$other" =~ _ckpt[0-9]+$ && -f "$other/metrics.json" ]]; then ADDED[$other]=1; RUNS+=("$other"); fi
  done
}
row() {  # row ALGO TAG: that run's evaluation joins the report where OUT holds it; status 1 where not
  local dir; dir=$OUT/eval/$(run_of "$1" "$2")
  [[ -f "$dir/metrics.json" ]] || return 1
  add_run "$dir"
}
evaluate() {  # evaluate ALGO [ENV_STEPS]: its run's latest checkpoint as its row, or that of ENV_STEPS as "<row> ckpt<n>"
  local algo=$1 name=${RUN_NAME[$1]} at=${2:-} extra=()
  if [[ $algo == ddppo_depth && "$DEPTH_SOURCE" == true ]]; then extra=("env.depth=true"); fi
  if [[ -n "$at" ]]; then extra+=("+policy.env_steps=$at"); fi
  step "eval_$name${at:+_ckpt$at}" rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/$name" \
    "method=$(label_of "$algo" "$TAG")${at:+ ckpt$at}" out_dir="$OUT/eval/$name${at:+_ckpt$at}" "${EVAL[@]}" "${extra[@]}"
}
for algo in $ALGOS; do evaluate "$algo"; done
for algo in $ALGOS; do  # EVAL_CHECKPOINTS: the kept checkpoints before the latest, newest first
  name=${RUN_NAME[$algo]}
  if (( EVAL_CHECKPOINTS > 1 )); then
    earlier_checkpoints "$OUT/train/$name" checkpoints "$EVAL_CHECKPOINTS" rl_small "train.keep_checkpoints when it trained"
    for at in "${EARLIER[@]}"; do evaluate "$algo" "$at"; done
  fi
  add_run "$OUT/eval/$name"
done
# a tagged variant's references: the untagged run of its algo (of its seed, for TAG=<v>_seed<s>) and the run it
# continued (FROM), each tested against it where OUT holds that run's evaluation; for TAG=<v>_seed<s> the seed-0 pair
# too (variant <v> against the reference's seed-0 run), which the report pools over the seeds
TAG_SEED=$(seed_of "$TAG") VARIANT=$(variant_of "$TAG")
PEER=$([[ -n "$VARIANT" && -n "$TAG_SEED" ]] && echo "$VARIANT" || true)   # the variant's seed-0 tag, where it has one
against() {  # against ALGO REF_TAG
  if ! row "$1" "$2"; then return; fi
  pair "$(label_of "$1" "$TAG")=$(label_of "$1" "$2")"
  if [[ -n "$PEER" && "$(seed_of "$2")" == "$TAG_SEED" ]] && row "$1" "$PEER" && row "$1" "$(variant_of "$2")"; then
    pair "$(label_of "$1" "$PEER")=$(label_of "$1" "$(variant_of "$2")")"
  fi
}
for algo in $ALGOS; do
  pair "$(label_of "$algo" "$TAG")=Goal follower"
  if [[ -n "$TAG" ]]; then
    against "$algo" "$([[ -n "$PEER" ]] && echo "seed$TAG_SEED" || true)"
    if [[ -n "$FROM" ]]; then against "$algo" "$FROM_TAG"; fi
  fi
done
between() {  # two algos' rows: this run's, and their seed-0 runs' (the untagged ones for TAG=seed<s> or an unseeded TAG)
  if has "$1" && has "$2"; then
    pair "$(label_of "$1" "$TAG")=$(label_of "$2" "$TAG")"
    if [[ -n "$TAG" ]] && row "$1" "$PEER" && row "$2" "$PEER"; then
      pair "$(label_of "$1" "$PEER")=$(label_of "$2" "$PEER")"
    fi
  fi
}
between ppo_lag ppo
between ddppo ppo
between ddppo_depth ddppo
for run in $IL_RUNS; do add_run "$run"; done   # with its evaluations of other checkpoints beside it
IFS=';' read -ra EXTRA <<<"$COMPARE"
for p in "${EXTRA[@]}"; do pair "$p"; done
$PY -m rvn_data.benchmark.report "${RUNS[@]}" -o "$OUT/report.md" "${PAIRS[@]/#/--compare=}" --compare-present \
  --title "RL baselines, small scale (SCALE=$SCALE)"
echo "rl_small: this run took $SECONDS s ($STEPS_SECONDS s in steps run now); report: $OUT/report.md;" \
     "learning curves: $OUT/train/*/learning_curve.png"

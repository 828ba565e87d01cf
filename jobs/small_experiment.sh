#!/usr/bin/env bash
# Small-scale RVN experiment on a CPU machine, end to end:
#   rvn-gen expert + negative on procedural train scenes
#   -> rvn-train ViNT-PointGoal, NoMaD-PointGoal, NoMaD-Neg (model.size=small)
#   -> rvn-eval on procedural val scenes (the three, NoMaD-PointGoal voting over its samples, NoMaD-PointGoal-vote
#      and NoMaD-Neg with the depth veto when DEPTH_VETO is set, the latter with committed turns too when TURN_COMMIT=1,
#      NoMaD-Neg with argmin CoR when NEG_ARGMIN=1;
#      oracle, trajectory oracle, blind goal follower, random)
#   SEEDS="0 1": NoMaD-PointGoal and NoMaD-Neg (and their eval rows) once per training seed; data, episodes,
#   ViNT and the reference rows once (seed SEED). Rows of another seed than SEED are labelled "<method> seed<s>".
#   EVAL_CHECKPOINTS=k: NoMaD-PointGoal also at its k-1 kept checkpoints before the latest ("<method> ckpt<step>"),
#   and NoMaD-Neg with each of them as NoMaD_e, which the report reads the rows over; with SEEDS, each step's pair
#   is also tested pooled over the seeds ("<method> seed<s> ckpt<step>" beside "<method> ckpt<step>").
#   -> python -m rvn_data.benchmark.report -> OUT/report.md (+ plots, per-episode logs in OUT/eval/*/)
#
#   bash jobs/small_experiment.sh [OUT]              # SCALE=small on 2 CPU cores: wall time per step in OUT/timings.tsv
#   SCALE=tiny bash jobs/small_experiment.sh /tmp/x  # smoke test: 1 scene, 2 steps, 1 episode
#
# OUT defaults to runs/small_experiment_$SCALE. Every knob below can be set in the
# environment (e.g. TRAIN_SCENES=40 NOMAD_EPOCHS=4 bash jobs/small_experiment.sh).
# Rerunning resumes: a step whose exact command already succeeded is skipped (OUT/.done/) unless a
# step before it ran again (jobs/lib.sh), and each tool resumes its own work (rvn-gen trajectories, rvn-train
# checkpoints, rvn-eval episodes) or refuses a changed input (rvn-eval: an out_dir holding another model's episodes).
# Logs: OUT/logs/<step>.log; wall time per step: OUT/timings.tsv.
set -euo pipefail

SCALE=${SCALE:-small}
OUT=${1:-${OUT:-runs/small_experiment_${SCALE}}}
case "$SCALE" in
  small)  # sized for a 2-core machine (jobs/paper_scale.md, "Time budget"; per step: docs/results/*_main/timings.tsv). The measured recipe
          # (docs/results/2026-11-25_small_experiment_5/ to _7/): twice the scenes for 2 epochs instead of 3 (10-11k
          # steps), the auxiliary depth loss, the first decisions trained (PAD_CONTEXT), the depth head also trained on
          # negatives (DEPTH_NEG_PER_SCENE; docs/results/2026-11-25_small_experiment_8/)
    : "${TRAIN_SCENES:=128}" "${TRAJ_PER_SCENE:=32}" "${IMAGE:=64}" "${VINT_EPOCHS:=1}" "${NOMAD_EPOCHS:=2}" "${MAX_STEPS:=}"
    : "${DEPTH_AUX:=0.5}" "${DEPTH_NEG_PER_SCENE:=32}" "${DEPTH_VETO:=0.5}"  # veto at 0.5 m: run 7's threshold
    : "${VINT_MAX_STEPS:=900}"  # ViNT: 900 of its 2,200 steps per epoch (~15 min); NoMaD gets the time budget
    : "${EVAL_SCENES:=50}" "${EVAL_EPISODES:=4}" "${N_GOALS:=32}" "${T_MAX:=500}" "${LR:=1e-3}"  # 200 val episodes a row
    : "${VAL_SCENES:=10}" "${VAL_TRAJ:=4}" ;;
  tiny)   # smoke test of the whole chain (tests/test_experiment_smoke.py)
    : "${TRAIN_SCENES:=1}" "${TRAJ_PER_SCENE:=2}" "${IMAGE:=64}" "${VINT_EPOCHS:=1}" "${NOMAD_EPOCHS:=1}" "${MAX_STEPS:=2}"
    : "${EVAL_SCENES:=1}" "${EVAL_EPISODES:=1}" "${N_GOALS:=2}" "${T_MAX:=60}" "${BATCH:=4}" "${WORKERS:=1}"
    : "${VAL_SCENES:=1}" "${VAL_TRAJ:=2}" ;;
  *) echo "small_experiment.sh: error: SCALE=$SCALE; choose small or tiny" >&2; exit 2 ;;
esac
[[ "${NEG_EXPERT:-reuse}" =~ ^(reuse|train)$ ]] || { echo "small_experiment.sh: error: NEG_EXPERT=$NEG_EXPERT; choose reuse or train" >&2; exit 2; }
[[ "${PREDICTION:-sample}" =~ ^(epsilon|sample|v_prediction)$ ]] || { echo "small_experiment.sh: error: PREDICTION=$PREDICTION; choose epsilon, sample or v_prediction" >&2; exit 2; }
: "${NEG_FRACTION:=0.0625}"   # NoMaD-Neg: share of expert trajectories replaced by negative ones (paper: 6.25 %)
: "${WORKERS:=2}"             # processes for rvn-gen and rvn-eval
: "${THREADS:=2}"             # torch threads for rvn-train
: "${BATCH:=32}"              # model.size=small batch
: "${LR:=}"                   # empty: the model's lr (official 1e-4 at batch 256, 100 epochs); small: 1e-3, which
                              # learns about 6x faster in steps (jobs/paper_scale.md, "Small-scale learning rate")
: "${LOOKAHEAD:=null}"       # IL policies steer to this predicted waypoint (null: the first beyond d_step/2; -1: last)
: "${NOMAD_SAMPLES:=8}"       # NoMaD-PointGoal samples per decision at eval (follows sample 0)
: "${GOAL_OFFSET_MAX:=40}"     # point goals up to this many frames ahead (the whole 4-8 m path; official 20)
: "${NEG_EXPERT:=reuse}"     # reuse: NoMaD_e = the NoMaD-PointGoal checkpoint; train: train NoMaD_e on 93.75 % of the experts
: "${PREDICTION:=sample}"    # NoMaD denoiser target: sample (x0; measured best at this scale, docs/results) | epsilon (the paper's) | v_prediction
: "${DEPTH_AUX:=0}"           # > 0: rvn-gen writes depth sidecars and the models train with this auxiliary depth-loss
                              # weight (model.depth_aux_weight; off by default, a departure from the paper's RGB-only models)
: "${PAD_CONTEXT:=true}"      # true: also train each trajectory's first context_size decisions, their context padded with
                              # frame 0 as the policy's after reset() (data.pad_context; GNM's sampling: false)
: "${DEPTH_NEG_PER_SCENE:=0}"  # > 0, with DEPTH_AUX > 0: rvn-gen this many negatives per train scene with depth
                              # (data/depth_negative) and NoMaD-PointGoal's depth head also learns from their frames,
                              # which run into obstacles (data.depth_root; off by default, a departure)
: "${DEPTH_VETO:=}"           # metres, with DEPTH_AUX > 0: one more row, NoMaD-PointGoal-vote with policy.depth_veto (its
                              # depth head turns it away from a blocked forward step; rvn_il/policies/depth_veto.py)
: "${NEG_ARGMIN:=0}"          # 1: one more row, NoMaD-Neg with argmin CoR (the paper's wording; its equation means
                              # argmax, the default; measured in docs/results/2026-11-23_small_experiment_2/ and _3/; ~12 min)
: "${TURN_COMMIT:=0}"         # 1, with DEPTH_VETO: one more row, NoMaD-Neg-veto-commit (policy.turn_commit: a turn against
                              # the step before's turn repeats it; CPK -21 % and -32 % with two seeds, SR_1 -0.03 n.s.,
                              # docs/results/2026-12-06_turn_commit_seed1/; ~25 min)
: "${DEPTH_VETO_RULE:=swept}"  # where DEPTH_VETO looks: swept (the rectangle the step sweeps; measured best,
                              # docs/results/2026-11-25_small_experiment_8/) | band (the central half of the columns)
: "${SEED:=0}"                # data, episodes, ViNT and the reference rows
: "${SEEDS:=$SEED}"           # training seeds of NoMaD-PointGoal and NoMaD-Neg (space-separated, e.g. "0 1")
: "${EVAL_CHECKPOINTS:=1}"    # NoMaD-PointGoal's row also at its k-1 kept checkpoints before the latest (rvn-eval
                              # policy.step; rows "NoMaD-PointGoal ckpt<step>", ~1.5-6 min each at SCALE=small), read
                              # over the k by the report (per episode the share that reached the first goal). Default 1:
                              # NoMaD-PointGoal's last five checkpoints moved by an SD of 0.014 SR_1, under a row's binomial
                              # error (docs/results/2026-12-07_nomad_checkpoints/; RL's 0.03-0.04: rl_small.sh evaluates 2).
                              # Above 2, NoMaD-PointGoal keeps k (train.keep_checkpoints). With NEG_EXPERT=reuse NoMaD-Neg
                              # too, with each of those checkpoints as NoMaD_e (train.expert_step; rows "NoMaD-Neg
                              # ckpt<step>", each tested against NoMaD-PointGoal's at that step; NoMaD_n trained again
                              # each time, ~1 min at SCALE=small)
: "${CKPT_EVERY:=}"           # NoMaD-PointGoal's train.ckpt_every (empty: rvn-train's 1000 steps; SCALE=small trains ~11k)
: "${DEVICE:=cpu}"            # rvn-train device (cpu | cuda | auto); rvn-eval's policies stay on the CPU
: "${RENDERER:=auto}"         # rvn-gen / rvn-eval renderer: auto | gl | raycast
PY=${PYTHON:-python}
[[ "$PAD_CONTEXT" =~ ^(true|false)$ ]] || { echo "small_experiment.sh: error: PAD_CONTEXT=$PAD_CONTEXT; choose true or false" >&2; exit 2; }
if [[ -n "$DEPTH_VETO" && "$DEPTH_AUX" == 0 ]]; then
  echo "small_experiment.sh: error: DEPTH_VETO=$DEPTH_VETO needs the depth head: set DEPTH_AUX > 0 (e.g. 0.5)" >&2; exit 2
fi
[[ "$NEG_ARGMIN" =~ ^(0|1)$ ]] || { echo "small_experiment.sh: error: NEG_ARGMIN=$NEG_ARGMIN; choose 0 or 1" >&2; exit 2; }
[[ "$TURN_COMMIT" =~ ^(0|1)$ ]] || { echo "small_experiment.sh: error: TURN_COMMIT=$TURN_COMMIT; choose 0 or 1" >&2; exit 2; }
if [[ "$TURN_COMMIT" == 1 && -z "$DEPTH_VETO" ]]; then
  echo "small_experiment.sh: error: TURN_COMMIT=1 adds a row to the veto's: set DEPTH_VETO (e.g. 0.5, with DEPTH_AUX > 0)" >&2; exit 2
fi
[[ "$DEPTH_VETO_RULE" =~ ^(band|swept)$ ]] || { echo "small_experiment.sh: error: DEPTH_VETO_RULE=$DEPTH_VETO_RULE; choose swept or band" >&2; exit 2; }
if [[ ! "$EVAL_CHECKPOINTS" =~ ^[1-9][0-9]*$ ]]; then
  echo "small_experiment.sh: error: EVAL_CHECKPOINTS=$EVAL_CHECKPOINTS; give how many of NoMaD-PointGoal's last checkpoints to evaluate (1: the latest)" >&2; exit 2
fi
if [[ -n "$CKPT_EVERY" && ! "$CKPT_EVERY" =~ ^[1-9][0-9]*$ ]]; then
  echo "small_experiment.sh: error: CKPT_EVERY=$CKPT_EVERY; give NoMaD-PointGoal's steps between checkpoints (empty: rvn-train's 1000)" >&2; exit 2
fi
[[ "$SEEDS" =~ ^[0-9]+( [0-9]+)*$ ]] || { echo "small_experiment.sh: error: SEEDS=$SEEDS; give whole numbers separated by spaces, e.g. SEEDS=\"0 1\"" >&2; exit 2; }
[[ "$DEPTH_NEG_PER_SCENE" =~ ^[0-9]+$ ]] || { echo "small_experiment.sh: error: DEPTH_NEG_PER_SCENE=$DEPTH_NEG_PER_SCENE; give a whole number (0: off)" >&2; exit 2; }
if [[ "$DEPTH_NEG_PER_SCENE" != 0 && "$DEPTH_AUX" == 0 ]]; then
  echo "small_experiment.sh: error: DEPTH_NEG_PER_SCENE=$DEPTH_NEG_PER_SCENE trains the depth head: set DEPTH_AUX > 0 (e.g. 0.5) or DEPTH_NEG_PER_SCENE=0" >&2; exit 2
fi

# negatives per scene: round(TRAJ_PER_SCENE * NEG_FRACTION), at least 1
NEG_PER_SCENE=$($PY -c "print(max(1, round($TRAJ_PER_SCENE * $NEG_FRACTION)))")
EXPERT_KEEP=$((TRAJ_PER_SCENE > NEG_PER_SCENE ? TRAJ_PER_SCENE - NEG_PER_SCENE : TRAJ_PER_SCENE))
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
DATA=$OUT/data
CAMERA=("camera.width=$IMAGE" "camera.height=$IMAGE")
TRAIN_SIZE=("model.size=small" "train.batch_size=$BATCH" "data.num_workers=0" "data.goal_offset=[1,$GOAL_OFFSET_MAX]"
            "train.tqdm_interval=30" "device=$DEVICE" "data.val_root=$DATA/val_expert")
[[ -n "$MAX_STEPS" ]] && TRAIN_SIZE+=("train.max_steps=$MAX_STEPS")
DEPTH_GEN=()
if [[ "$DEPTH_AUX" != 0 ]]; then TRAIN_SIZE+=("model.depth_aux_weight=$DEPTH_AUX"); DEPTH_GEN=("dataset.save_depth=true"); fi
[[ -n "$LR" ]] && TRAIN_SIZE+=("train.lr=$LR")
TRAIN_SIZE+=("data.pad_context=$PAD_CONTEXT")
NOMAD_CKPT=()
[[ -n "$CKPT_EVERY" ]] && NOMAD_CKPT+=("train.ckpt_every=$CKPT_EVERY")
(( EVAL_CHECKPOINTS > 2 )) && NOMAD_CKPT+=("train.keep_checkpoints=$EVAL_CHECKPOINTS")
EVAL=("split=val" "episodes.num_scenes=$EVAL_SCENES" "episodes.per_scene=$EVAL_EPISODES" "episodes.n_goals=$N_GOALS"
      "env.t_max=$T_MAX" "episodes.dir=$OUT/episodes" "workers=$WORKERS" "progress=false" "seed=$SEED" "renderer=$RENDERER" "${CAMERA[@]}")

source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"   # step NAME CMD...: skip if done, log, time

# NoMaD-Neg's splits: NoMaD_e on the first EXPERT_KEEP expert trajectories of each scene (the
# other NEG_PER_SCENE are "replaced" by the negative dataset), NoMaD_n on the negatives.
neg_splits() {
  local dir=$OUT/splits_neg
  mkdir -p "$dir/rvn_expert/train" "$dir/rvn_negative/train"
  awk -F_ -v keep="$EXPERT_KEEP" '($NF + 0) < keep' "$DATA/rvn_expert/data_splits/rvn_expert/train/traj_names.txt" \
    >"$dir/rvn_expert/train/.traj_names.txt.tmp"
  mv "$dir/rvn_expert/train/.traj_names.txt.tmp" "$dir/rvn_expert/train/traj_names.txt"
  cp "$DATA/rvn_negative/data_splits/rvn_negative/train/traj_names.txt" "$dir/rvn_negative/train/.traj_names.txt.tmp"
  mv "$dir/rvn_negative/train/.traj_names.txt.tmp" "$dir/rvn_negative/train/traj_names.txt"
}

export OMP_NUM_THREADS=$THREADS MKL_NUM_THREADS=$THREADS
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}   # one packed-frame cache for the three trainings (README, Caches)
echo "small_experiment: SCALE=$SCALE OUT=$OUT: $TRAIN_SCENES train scenes x $TRAJ_PER_SCENE expert (+ $NEG_PER_SCENE negative)," \
     "${IMAGE}x$IMAGE images, epochs ViNT $VINT_EPOCHS / NoMaD $NOMAD_EPOCHS${MAX_STEPS:+ (max_steps $MAX_STEPS)}; eval $EVAL_SCENES val scenes x $EVAL_EPISODES episodes x $N_GOALS goals"

GEN=("split=train" "scenes.num_scenes=$TRAIN_SCENES" "dataset.train_fraction=1.0" "workers=$WORKERS" "progress=false" "seed=$SEED"
     "renderer=$RENDERER" "${CAMERA[@]}")
step gen_expert rvn-gen dataset=expert out_dir="$DATA/rvn_expert" trajectories_per_scene="$TRAJ_PER_SCENE" "${GEN[@]}" "${DEPTH_GEN[@]}"
step gen_negative rvn-gen dataset=negative out_dir="$DATA/rvn_negative" trajectories_per_scene="$NEG_PER_SCENE" "${GEN[@]}" "${DEPTH_GEN[@]}"
NOMAD_DEPTH=()
if [[ "$DEPTH_NEG_PER_SCENE" != 0 ]]; then
  step gen_depth_negative rvn-gen dataset=negative out_dir="$DATA/depth_negative" trajectories_per_scene="$DEPTH_NEG_PER_SCENE" "${GEN[@]}" "${DEPTH_GEN[@]}"
  NOMAD_DEPTH=("data.depth_root=$DATA/depth_negative")
fi
# held-out expert trajectories on val scenes: rvn-train logs its val loss and open-loop agreement on them
VAL_GEN=("split=val" "scenes.num_scenes=$VAL_SCENES" "dataset.train_fraction=1.0" "workers=$WORKERS" "progress=false" "seed=$SEED"
         "renderer=$RENDERER" "${CAMERA[@]}")
step gen_val rvn-gen dataset=expert out_dir="$DATA/val_expert" trajectories_per_scene="$VAL_TRAJ" "${VAL_GEN[@]}"
neg_splits

VINT_TRAIN=()
if [[ -n "${VINT_MAX_STEPS:-}" && -z "$MAX_STEPS" ]]; then VINT_TRAIN=("train.max_steps=$VINT_MAX_STEPS"); fi
step train_vint rvn-train model=vint_pointgoal data.root="$DATA/rvn_expert" out_dir="$OUT/train/vint_pointgoal" \
  train.epochs="$VINT_EPOCHS" "${TRAIN_SIZE[@]}" "${VINT_TRAIN[@]}" seed="$SEED"
# eval workers: one torch thread each
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
step eval_random rvn-eval policy=random method=Random out_dir="$OUT/eval/random" "${EVAL[@]}"
step eval_oracle rvn-eval policy=oracle method=Oracle out_dir="$OUT/eval/oracle" "${EVAL[@]}"
# blind baseline: drives straight at the point goal (what a policy scores without looking)
step eval_goal_follower rvn-eval policy=goal_follower "method=Goal follower" out_dir="$OUT/eval/goal_follower" "${EVAL[@]}"
# the action adapter's ceiling: the expert's own next poses through the IL policies' waypoint -> action rule
step eval_trajectory_oracle rvn-eval policy=trajectory_oracle "method=Trajectory oracle" policy.waypoint_index="$LOOKAHEAD" \
  out_dir="$OUT/eval/trajectory_oracle" "${EVAL[@]}"
step eval_vint rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/vint_pointgoal" method=ViNT-PointGoal +policy.waypoint_index="$LOOKAHEAD" \
  out_dir="$OUT/eval/vint_pointgoal" "${EVAL[@]}"
RUNS=("$OUT/eval/random" "$OUT/eval/oracle" "$OUT/eval/goal_follower" "$OUT/eval/trajectory_oracle" "$OUT/eval/vint_pointgoal")
# significance (Fisher's exact test on SR_1, two Poisson rates on CPK) of the comparisons the experiment is about
COMPARE=("ViNT-PointGoal=Goal follower" "Goal follower=Random")
VETO=(+policy.depth_veto="$DEPTH_VETO" +policy.depth_veto_rule="$DEPTH_VETO_RULE")
# per training seed (SEEDS), one after the other so that each seed's rows are complete before the next trains:
# NoMaD-PointGoal, then NoMaD-Neg (NEG_EXPERT=reuse: NoMaD_e is that seed's NoMaD-PointGoal run, train.expert_from,
# rvn_il/train/adopt.py, so NoMaD-Neg and NoMaD-PointGoal differ only by CoR), then their eval rows
for S in $SEEDS; do
  SFX=""; LBL=""; [[ "$S" != "$SEED" ]] && { SFX="_seed$S"; LBL=" seed$S"; }
  export OMP_NUM_THREADS=$THREADS MKL_NUM_THREADS=$THREADS
  step "train_nomad$SFX" rvn-train model=nomad_pointgoal model.prediction_type="$PREDICTION" data.root="$DATA/rvn_expert" \
    out_dir="$OUT/train/nomad_pointgoal$SFX" train.epochs="$NOMAD_EPOCHS" "${TRAIN_SIZE[@]}" "${NOMAD_DEPTH[@]}" seed="$S" \
    "${NOMAD_CKPT[@]}"
  NEG_FROM=()
  if [[ "$NEG_EXPERT" == reuse ]]; then NEG_FROM=("train.expert_from=$OUT/train/nomad_pointgoal$SFX"); fi
  # NoMaD-Neg's training settings around its out_dir (the earlier checkpoints' NoMaD-Neg below takes them too)
  NEG_DATA=(model=nomad_neg model.prediction_type="$PREDICTION" data.root="$DATA/rvn_expert"
            data.negative_root="$DATA/rvn_negative" data.splits_dir="$OUT/splits_neg" data.skip_short=true)
  NEG_TRAIN=(train.epochs="$NOMAD_EPOCHS" "${TRAIN_SIZE[@]}" "${NEG_FROM[@]}")
  step "train_nomad_neg$SFX" rvn-train "${NEG_DATA[@]}" out_dir="$OUT/train/nomad_neg$SFX" "${NEG_TRAIN[@]}" seed="$S"
  export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
  NOMAD=(policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_pointgoal$SFX")
  NEG=(policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_neg$SFX")
  step "eval_nomad$SFX" rvn-eval "${NOMAD[@]}" "method=NoMaD-PointGoal$LBL" +policy.waypoint_index="$LOOKAHEAD" \
    +policy.num_samples="$NOMAD_SAMPLES" out_dir="$OUT/eval/nomad_pointgoal$SFX" "${EVAL[@]}"
  # NoMaD-PointGoal with policy.aggregate=vote: the action most of its 8 samples lead to (rvn_il/policies/policy.py)
  step "eval_nomad_vote$SFX" rvn-eval "${NOMAD[@]}" "method=NoMaD-PointGoal-vote$LBL" +policy.aggregate=vote \
    out_dir="$OUT/eval/nomad_pointgoal_vote$SFX" "${EVAL[@]}"
  step "eval_nomad_neg$SFX" rvn-eval "${NEG[@]}" "method=NoMaD-Neg$LBL" +policy.waypoint_index="$LOOKAHEAD" \
    out_dir="$OUT/eval/nomad_neg$SFX" "${EVAL[@]}"
  RUNS+=("$OUT/eval/nomad_pointgoal$SFX" "$OUT/eval/nomad_pointgoal_vote$SFX" "$OUT/eval/nomad_neg$SFX")
  if (( EVAL_CHECKPOINTS > 1 )); then  # the kept checkpoints before the latest, newest first
    earlier_checkpoints "$OUT/train/nomad_pointgoal$SFX" model "$EVAL_CHECKPOINTS" small_experiment \
      "train.keep_checkpoints and train.ckpt_every when it trained: CKPT_EVERY"
    for at in "${EARLIER[@]}"; do
      step "eval_nomad${SFX}_ckpt$at" rvn-eval "${NOMAD[@]}" "method=NoMaD-PointGoal$LBL ckpt$at" +policy.step="$at" \
        +policy.waypoint_index="$LOOKAHEAD" +policy.num_samples="$NOMAD_SAMPLES" \
        out_dir="$OUT/eval/nomad_pointgoal${SFX}_ckpt$at" "${EVAL[@]}"
      RUNS+=("$OUT/eval/nomad_pointgoal${SFX}_ckpt$at")
      if [[ "$NEG_EXPERT" == reuse ]]; then  # NoMaD-Neg with that checkpoint as NoMaD_e (train.expert_step); NoMaD_n
        # trained again (it does not depend on NoMaD_e: the same seed, the same weights)
        OMP_NUM_THREADS=$THREADS MKL_NUM_THREADS=$THREADS step "train_nomad_neg${SFX}_ckpt$at" rvn-train "${NEG_DATA[@]}" \
          out_dir="$OUT/train/nomad_neg${SFX}_ckpt$at" "${NEG_TRAIN[@]}" train.expert_step="$at" seed="$S"
        step "eval_nomad_neg${SFX}_ckpt$at" rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/nomad_neg${SFX}_ckpt$at" \
          "method=NoMaD-Neg$LBL ckpt$at" +policy.waypoint_index="$LOOKAHEAD" out_dir="$OUT/eval/nomad_neg${SFX}_ckpt$at" \
          "${EVAL[@]}"
        RUNS+=("$OUT/eval/nomad_neg${SFX}_ckpt$at")
        COMPARE+=("NoMaD-Neg$LBL ckpt$at=NoMaD-PointGoal$LBL ckpt$at")
      fi
    done
  fi
  COMPARE+=("NoMaD-PointGoal$LBL=Goal follower" "NoMaD-PointGoal$LBL=Trajectory oracle"
            "NoMaD-PointGoal-vote$LBL=NoMaD-PointGoal$LBL" "NoMaD-Neg$LBL=NoMaD-PointGoal$LBL")
  if [[ -n "$DEPTH_VETO" ]]; then  # the depth head of NoMaD-PointGoal (NoMaD-Neg's NoMaD_e) vetoes blocked forward steps
    step "eval_nomad_vote_veto$SFX" rvn-eval "${NOMAD[@]}" "method=NoMaD-PointGoal-vote-veto$LBL" +policy.aggregate=vote \
      "${VETO[@]}" out_dir="$OUT/eval/nomad_pointgoal_vote_veto$SFX" "${EVAL[@]}"
    step "eval_nomad_neg_veto$SFX" rvn-eval "${NEG[@]}" "method=NoMaD-Neg-veto$LBL" +policy.waypoint_index="$LOOKAHEAD" \
      "${VETO[@]}" out_dir="$OUT/eval/nomad_neg_veto$SFX" "${EVAL[@]}"
    RUNS+=("$OUT/eval/nomad_pointgoal_vote_veto$SFX" "$OUT/eval/nomad_neg_veto$SFX")
    COMPARE+=("NoMaD-PointGoal-vote-veto$LBL=NoMaD-PointGoal-vote$LBL" "NoMaD-Neg-veto$LBL=NoMaD-Neg$LBL")
    if [[ "$TURN_COMMIT" == 1 ]]; then  # the veto's stalls: turns against the turn before repeat it
      step "eval_nomad_neg_veto_commit$SFX" rvn-eval "${NEG[@]}" "method=NoMaD-Neg-veto-commit$LBL" \
        +policy.waypoint_index="$LOOKAHEAD" "${VETO[@]}" +policy.turn_commit=true \
        out_dir="$OUT/eval/nomad_neg_veto_commit$SFX" "${EVAL[@]}"
      RUNS+=("$OUT/eval/nomad_neg_veto_commit$SFX")
      COMPARE+=("NoMaD-Neg-veto-commit$LBL=NoMaD-Neg-veto$LBL")
    fi
  fi
  # the paper writes argmin CoR; by its equation argmax keeps away from the negatives
  if [[ "$NEG_ARGMIN" == 1 ]]; then
    step "eval_nomad_neg_argmin$SFX" rvn-eval "${NEG[@]}" "method=NoMaD-Neg-argmin$LBL" +policy.waypoint_index="$LOOKAHEAD" \
      +policy.selection=argmin out_dir="$OUT/eval/nomad_neg_argmin$SFX" "${EVAL[@]}"
    RUNS+=("$OUT/eval/nomad_neg_argmin$SFX")
    COMPARE+=("NoMaD-Neg-argmin$LBL=NoMaD-Neg$LBL")
  fi
done
$PY -m rvn_data.benchmark.report "${RUNS[@]}" -o "$OUT/report.md" "${COMPARE[@]/#/--compare=}" \
  --title "RVN small-scale experiment (SCALE=$SCALE: $TRAIN_SCENES train scenes x $TRAJ_PER_SCENE trajectories, val $EVAL_SCENES x $EVAL_EPISODES)"
echo "small_experiment: this run took $SECONDS s ($STEPS_SECONDS s in steps run now); report: $OUT/report.md"

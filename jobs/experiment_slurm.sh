#!/usr/bin/env bash
# Paper-scale RVN experiment on a Slurm cluster (jobs/paper_scale.md): expert + negative datasets
# (800 train scenes), ViNT-PointGoal / NoMaD-PointGoal / NoMaD-Neg (full size, 100 epochs,
# torchrun), the benchmark on train / val / test (sharded over scenes), and the report.
#
#   OUT=/data/rvn PARTITION=gpu ACCOUNT=myproj bash jobs/experiment_slurm.sh
#   DRY_RUN=1 bash jobs/experiment_slurm.sh          # print the commands, run nothing
#
# Run it on a login node inside tmux/screen: hydra-submitit-launcher (conf/hydra/launcher/slurm.yaml)
# submits one array job per multirun and waits for it; training is `sbatch --wait`.
# Rerunning resumes every stage (rvn-gen skips finished scenes, rvn-train continues from its
# latest checkpoint, rvn-eval skips finished episodes).
set -euo pipefail

OUT=${OUT:-/data/rvn}
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}   # packed frames shared by the trainings (README, Caches)
SCENES=${SCENES:-800}             # train scenes (paper: 800)
TRAJ=${TRAJ:-400}                 # expert trajectories per scene (paper: 400)
TRAIN_FRACTION=${TRAIN_FRACTION:-1.0}  # share of the train scenes in the datasets' GNM train split (rvn-gen's default,
                                       # 0.8, would train on 640 of the 800; 0.8 resumes datasets made with it)
NEG_FRACTION=${NEG_FRACTION:-0.0625}  # NoMaD-Neg: share of expert trajectories replaced by negatives
EPOCHS=${EPOCHS:-100}
GEN_SHARDS=${GEN_SHARDS:-64}      # rvn-gen array tasks
GPUS=${GPUS:-4}                   # GPUs per training node (torchrun processes)
BATCH=${BATCH:-64}                # per-process batch: 4 x 64 = the official 256
EVAL_SHARD_SCENES=${EVAL_SHARD_SCENES:-5}  # scenes per rvn-eval array task
SPLITS=${SPLITS:-"train val test"}
TRAIN_TIME=${TRAIN_TIME:-3-00:00:00}
LAUNCH=("hydra/launcher=slurm" ${PARTITION:+"hydra.launcher.partition=$PARTITION"} ${ACCOUNT:+"hydra.launcher.account=$ACCOUNT"})
SBATCH=(${PARTITION:+"--partition=$PARTITION"} ${ACCOUNT:+"--account=$ACCOUNT"})

run() {  # print the command (shell-quoted), then run it unless DRY_RUN
  local line; line=$(printf ' %q' "$@")
  echo "+$line"  # one write: the training jobs print from the background
  [[ -n "${DRY_RUN:-}" ]] || "$@"
}

NEG=$(python -c "print(max(1, round($TRAJ * $NEG_FRACTION)))")   # paper: 25 per scene (20k)
KEEP=$((TRAJ > NEG ? TRAJ - NEG : TRAJ))  # NoMaD_e: 375 per scene (300k); all of them when NEG would leave none (TRAJ=1)
DATA=$OUT/data

# 1. datasets: one array task per shard of the scene list; the last shard writes splits and manifest
GEN=(split=train scenes.num_scenes="$SCENES" dataset.train_fraction="$TRAIN_FRACTION" num_shards="$GEN_SHARDS"
     "shard_index=range(0,$GEN_SHARDS)" workers=4 progress=false seed=0)
GEN_STATUS=0  # the first failure's exit status: the merges run after a failed multirun too, then the recipe stops
failed() { (( GEN_STATUS )) || GEN_STATUS=$1; }
run rvn-gen -m "${LAUNCH[@]}" dataset=expert out_dir="$DATA/rvn_expert" trajectories_per_scene="$TRAJ" "${GEN[@]}" || failed $?
run rvn-gen -m "${LAUNCH[@]}" dataset=negative out_dir="$DATA/rvn_negative" trajectories_per_scene="$NEG" "${GEN[@]}" || failed $?
# a no-op when the last shard merged; after a failed shard (the launcher stops waiting at the first, others may still
# run) it refuses, saying how many scenes are missing and naming the first
for KIND in expert negative; do
  N=$([[ $KIND == expert ]] && echo "$TRAJ" || echo "$NEG")
  run rvn-gen mode=merge dataset=$KIND out_dir="$DATA/rvn_$KIND" trajectories_per_scene="$N" split=train \
    scenes.num_scenes="$SCENES" dataset.train_fraction="$TRAIN_FRACTION" seed=0 || failed $?
done
if (( GEN_STATUS )); then
  echo "experiment_slurm.sh: error: the datasets are incomplete (rvn-gen's messages above; shard logs in" \
       "$DATA/rvn_{expert,negative}/.rvn/multirun/); rerun this script once the shards are done, finished scenes are skipped" >&2
  exit "$GEN_STATUS"
fi

# 2. NoMaD-Neg's splits: NoMaD_e on the first KEEP expert trajectories of each scene, NoMaD_n on the negatives
if [[ -z "${DRY_RUN:-}" ]]; then
  mkdir -p "$OUT/splits_neg/rvn_expert/train" "$OUT/splits_neg/rvn_negative/train"
  awk -F_ -v keep="$KEEP" '($NF + 0) < keep' "$DATA/rvn_expert/data_splits/rvn_expert/train/traj_names.txt" \
    >"$OUT/splits_neg/rvn_expert/train/traj_names.txt"
  cp "$DATA/rvn_negative/data_splits/rvn_negative/train/traj_names.txt" "$OUT/splits_neg/rvn_negative/train/"
fi

# 3. training: one node per model, torchrun over its GPUs, the three in parallel
train() {  # train NAME OVERRIDES...
  local name=$1; shift
  run sbatch --wait "${SBATCH[@]}" --job-name="rvn-train-$name" --nodes=1 --gpus-per-node="$GPUS" \
    --cpus-per-task=$((8 * GPUS)) --mem=128G --time="$TRAIN_TIME" --output="$OUT/train/$name.slurm.log" \
    --wrap="torchrun --standalone --nproc_per_node=$GPUS -m rvn_il.train.cli model=$name device=cuda \
train.epochs=$EPOCHS train.batch_size=$BATCH data.num_workers=6 out_dir=$OUT/train/$name $*"
}
run mkdir -p "$OUT/train"
TRAINING=()  # "pid name" of each background sbatch --wait (its exit status is the job's)
train vint_pointgoal data.root="$DATA/rvn_expert" & TRAINING+=("$! vint_pointgoal")
train nomad_pointgoal data.root="$DATA/rvn_expert" & TRAINING+=("$! nomad_pointgoal")
train nomad_neg data.root="$DATA/rvn_expert" data.negative_root="$DATA/rvn_negative" \
  data.splits_dir="$OUT/splits_neg" data.skip_short=true & TRAINING+=("$! nomad_neg")
# every job is waited for (a rerun would otherwise submit a second copy of one still running), then a failed one stops
# the recipe before the benchmark evaluates a model it did not finish
FAILED=()
for t in "${TRAINING[@]}"; do wait "${t%% *}" || FAILED+=("rvn-train-${t#* } ($OUT/train/${t#* }.slurm.log)"); done
if (( ${#FAILED[@]} )); then
  echo "experiment_slurm.sh: error: training job(s) failed: ${FAILED[*]}; fix the cause and rerun (rvn-train resumes from its latest checkpoint)" >&2
  exit 1
fi

# 4. benchmark: every policy on every split, array tasks of EVAL_SHARD_SCENES scenes each
evaluate() {  # evaluate SPLIT NAME METHOD OVERRIDES...
  local split=$1 name=$2 method=$3; shift 3
  local scenes=$([[ $split == train ]] && echo "$SCENES" || echo 50)
  run rvn-eval -m "${LAUNCH[@]}" split="$split" method="$method" episodes.num_scenes="$EVAL_SHARD_SCENES" \
    "episodes.first_scene=range(0,$scenes,$EVAL_SHARD_SCENES)" workers=8 progress=false \
    episodes.dir="$OUT/episodes" hydra.sweep.dir="$OUT/eval/.multirun/$split/$name" \
    "out_dir=$OUT/eval/$split/$name/scenes_\${episodes.first_scene}" "$@"
}
for SPLIT in $SPLITS; do
  evaluate "$SPLIT" random Random policy=random
  evaluate "$SPLIT" oracle Oracle policy=oracle
  evaluate "$SPLIT" vint_pointgoal ViNT-PointGoal policy=checkpoint policy.device=cuda \
    policy.checkpoint_path="$OUT/train/vint_pointgoal"
  evaluate "$SPLIT" nomad_pointgoal NoMaD-PointGoal policy=checkpoint policy.device=cuda \
    policy.checkpoint_path="$OUT/train/nomad_pointgoal"
  evaluate "$SPLIT" nomad_neg NoMaD-Neg policy=checkpoint policy.device=cuda policy.checkpoint_path="$OUT/train/nomad_neg"
  evaluate "$SPLIT" nomad_neg_argmin NoMaD-Neg-argmin policy=checkpoint policy.device=cuda \
    policy.checkpoint_path="$OUT/train/nomad_neg" +policy.selection=argmin
done

# 5. report: the shards of each method and split are merged
run python -m rvn_data.benchmark.report "$OUT/eval" -o "$OUT/report.md" --title "RVN paper-scale experiment"

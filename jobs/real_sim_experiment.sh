#!/usr/bin/env bash
# Stand-in for the paper's Real+Sim experiment (its Table 3; issue 34): NoMaD-PointGoal trained on simulated data
# alone, on "real" data alone and on both mixed (rvn-train data.datasets), each evaluated closed loop with both
# robots. No real data can be downloaded here, so the "real" dataset is a second RVN dataset that differs the way a
# real robot's data differs: another camera (REAL_HFOV, REAL_HEIGHT), another step (REAL_DSTEP, so another
# metric_waypoint_spacing) and other scenes (the train scenes after the sim ones).
#   rvn-gen sim + real (train scenes) -> rvn-train sim-only, real-only, sim+real (model.size=small, same settings)
#   -> rvn-eval each model on the sim robot and on the real robot (200 val episodes a row at SCALE=small; a model
#      on the other robot runs with embodiment_mismatch=allow, recorded in its run.json), beside the trajectory
#      oracle, the blind goal follower and a random policy on each robot -> report.md with paired tests between the compared rows.
#
#   bash jobs/real_sim_experiment.sh [OUT]               # SCALE=small on 2 CPU cores
#   SIM_DATA=runs/small_main/data/rvn_expert bash jobs/real_sim_experiment.sh   # reuse an rvn-gen expert dataset
#   SCALE=tiny bash jobs/real_sim_experiment.sh /tmp/x   # smoke test (tests/test_real_sim_smoke.py)
# Rerunning resumes (jobs/lib.sh: OUT/.done/, each tool resumes its own work); logs OUT/logs/, times OUT/timings.tsv.
set -euo pipefail

SCALE=${SCALE:-small}
OUT=${1:-${OUT:-runs/real_sim_${SCALE}}}
case "$SCALE" in
  small) : "${TRAIN_SCENES:=128}" "${TRAJ_PER_SCENE:=16}" "${EPOCHS:=2}" "${MAX_STEPS:=}" "${BATCH:=32}"
         : "${EVAL_SCENES:=50}" "${EVAL_EPISODES:=4}" "${N_GOALS:=32}" "${T_MAX:=500}" "${WORKERS:=2}" ;;
  tiny)  : "${TRAIN_SCENES:=1}" "${TRAJ_PER_SCENE:=2}" "${EPOCHS:=1}" "${MAX_STEPS:=2}" "${BATCH:=4}"
         : "${EVAL_SCENES:=1}" "${EVAL_EPISODES:=1}" "${N_GOALS:=2}" "${T_MAX:=60}" "${WORKERS:=1}" ;;
  *) echo "real_sim_experiment.sh: error: SCALE=$SCALE; choose small or tiny" >&2; exit 2 ;;
esac
: "${IMAGE:=64}" "${SEED:=0}" "${SIM_WEIGHT:=0.5}" "${GOAL_OFFSET_MAX:=40}" "${LR:=1e-3}" "${THREADS:=2}" "${DEVICE:=cpu}"
: "${REAL_HFOV:=120}" "${REAL_HEIGHT:=0.3}" "${REAL_DSTEP:=0.2}" "${RENDERER:=auto}"
PY=${PYTHON:-python}
$PY -c "import sys; w = float(sys.argv[1]); sys.exit(0 if 0 < w < 1 else 1)" "$SIM_WEIGHT" 2>/dev/null \
  || { echo "real_sim_experiment.sh: error: SIM_WEIGHT=$SIM_WEIGHT; give the sim data's share of each batch, between 0 and 1" >&2; exit 2; }
REAL_WEIGHT=$($PY -c "print(round(1 - $SIM_WEIGHT, 6))")
if [[ -n "${SIM_DATA:-}" && ! -f "$SIM_DATA/manifest.json" ]]; then
  echo "real_sim_experiment.sh: error: SIM_DATA=$SIM_DATA is not an rvn-gen dataset (no manifest.json)" >&2; exit 2
fi
mkdir -p "$OUT/logs" "$OUT/.done"
OUT=$(cd "$OUT" && pwd)
DATA=$OUT/data
SIM=${SIM_DATA:-$DATA/sim}
REAL=$DATA/real
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
export OMP_NUM_THREADS=$THREADS MKL_NUM_THREADS=$THREADS RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}

SIM_ROBOT=("camera.width=$IMAGE" "camera.height=$IMAGE")
REAL_ROBOT=("camera.width=$IMAGE" "camera.height=$IMAGE" "camera.hfov_deg=$REAL_HFOV" "camera.h_camera=$REAL_HEIGHT"
            "agent.d_step=$REAL_DSTEP")
GEN=("dataset=expert" "split=train" "scenes.num_scenes=$TRAIN_SCENES" "trajectories_per_scene=$TRAJ_PER_SCENE"
     "dataset.train_fraction=1.0" "workers=$WORKERS" "progress=false" "seed=$SEED" "renderer=$RENDERER")
[[ -n "${SIM_DATA:-}" ]] || step gen_sim rvn-gen "${GEN[@]}" "${SIM_ROBOT[@]}" out_dir="$SIM"
step gen_real rvn-gen "${GEN[@]}" "${REAL_ROBOT[@]}" "scenes.first_scene=$TRAIN_SCENES" out_dir="$REAL"

TRAIN=("model=nomad_pointgoal" "model.size=small" "model.prediction_type=sample" "train.batch_size=$BATCH"
       "train.epochs=$EPOCHS" "data.num_workers=0" "data.goal_offset=[1,$GOAL_OFFSET_MAX]" "data.pad_context=true"
       "train.lr=$LR" "train.tqdm_interval=30" "device=$DEVICE" "seed=$SEED")
[[ -n "$MAX_STEPS" ]] && TRAIN+=("train.max_steps=$MAX_STEPS")
step train_sim rvn-train "${TRAIN[@]}" "data.root=$SIM" out_dir="$OUT/train/sim"
step train_real rvn-train "${TRAIN[@]}" "data.root=$REAL" out_dir="$OUT/train/real"
# the sim data first: the checkpoint's robot is the sim one; labels of each dataset in its own steps (d_step)
step train_mix rvn-train "${TRAIN[@]}" \
  "data.datasets=[{root: $SIM, weight: $SIM_WEIGHT}, {root: $REAL, weight: $REAL_WEIGHT}]" out_dir="$OUT/train/mix"

export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=("split=val" "episodes.num_scenes=$EVAL_SCENES" "episodes.per_scene=$EVAL_EPISODES" "episodes.n_goals=$N_GOALS"
      "env.t_max=$T_MAX" "episodes.dir=$OUT/episodes" "workers=$WORKERS" "progress=false" "seed=$SEED" "renderer=$RENDERER")
RUNS=(); COMPARE=()
for ROBOT in sim real; do
  if [[ $ROBOT == sim ]]; then HERE=("${SIM_ROBOT[@]}"); else HERE=("${REAL_ROBOT[@]}"); fi
  step "eval_trajectory_oracle_$ROBOT" rvn-eval policy=trajectory_oracle "method=Trajectory oracle @$ROBOT" \
    policy.waypoint_index=null out_dir="$OUT/eval/trajectory_oracle_$ROBOT" "${EVAL[@]}" "${HERE[@]}"
  step "eval_goal_follower_$ROBOT" rvn-eval policy=goal_follower "method=Goal follower @$ROBOT" \
    out_dir="$OUT/eval/goal_follower_$ROBOT" "${EVAL[@]}" "${HERE[@]}"
  step "eval_random_$ROBOT" rvn-eval policy=random "method=Random @$ROBOT" \
    out_dir="$OUT/eval/random_$ROBOT" "${EVAL[@]}" "${HERE[@]}"
  RUNS+=("$OUT/eval/trajectory_oracle_$ROBOT" "$OUT/eval/goal_follower_$ROBOT" "$OUT/eval/random_$ROBOT")
  for MODEL in sim real mix; do
    step "eval_${MODEL}_$ROBOT" rvn-eval policy=checkpoint policy.checkpoint_path="$OUT/train/$MODEL" \
      "method=NoMaD-PointGoal $MODEL-data @$ROBOT" +policy.waypoint_index=null embodiment_mismatch=allow \
      out_dir="$OUT/eval/${MODEL}_$ROBOT" "${EVAL[@]}" "${HERE[@]}"
    RUNS+=("$OUT/eval/${MODEL}_$ROBOT")
  done
  COMPARE+=("NoMaD-PointGoal mix-data @$ROBOT=NoMaD-PointGoal sim-data @$ROBOT"
            "NoMaD-PointGoal mix-data @$ROBOT=NoMaD-PointGoal real-data @$ROBOT")
done
$PY -m rvn_data.benchmark.report "${RUNS[@]}" -o "$OUT/report.md" "${COMPARE[@]/#/--compare=}" \
  --title "Real+Sim stand-in (SCALE=$SCALE: sim = camera hfov 90 / 0.6 m, d_step 0.25; real = hfov $REAL_HFOV / $REAL_HEIGHT m, d_step $REAL_DSTEP; sim share $SIM_WEIGHT)"
echo "real_sim_experiment: this run took $SECONDS s ($STEPS_SECONDS s in steps run now); report: $OUT/report.md"

#!/usr/bin/env bash
# Copies the Real+Sim stand-in's records (jobs/real_sim_experiment.sh) into this folder and writes report.md:
#   MAX_STEPS=4000 bash jobs/real_sim_experiment.sh runs/real_sim        # the run (main at c3f8f68, 2 CPU cores, 71 min)
#   the random rows (main at bd0cabf, same episodes; the recipe has none): for R in sim real, with the robot's settings
#   rvn-eval policy=random "method=Random @$R" out_dir=runs/real_sim/eval/random_$R split=val episodes.num_scenes=50 \
#     episodes.per_scene=4 episodes.n_goals=32 env.t_max=500 episodes.dir=runs/real_sim/episodes workers=2 seed=0 \
#     camera.width=64 camera.height=64 [camera.hfov_deg=120 camera.h_camera=0.3 agent.d_step=0.2]
#   bash docs/results/2026-11-26_real_sim/assemble.sh runs/real_sim
set -euo pipefail
RUN=$(cd "${1:-runs/real_sim}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROWS=()
for robot in sim real; do
  for n in trajectory_oracle goal_follower random sim real mix; do
    d=$RUN/eval/${n}_$robot
    mkdir -p "$HERE/eval/${n}_$robot"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/${n}_$robot/"
    ROWS+=("eval/${n}_$robot")
  done
done
for n in sim real mix; do
  mkdir -p "$HERE/train/$n"; cp "$RUN/train/$n"/{config.yaml,rvn-train.log} "$HERE/train/$n/"
done
for d in sim real; do cp "$RUN/data/$d/manifest.json" "$HERE/train/manifest_$d.json"; done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=()
for robot in sim real; do
  CMP+=("NoMaD-PointGoal mix-data @$robot=NoMaD-PointGoal sim-data @$robot"
        "NoMaD-PointGoal mix-data @$robot=NoMaD-PointGoal real-data @$robot")
done
CMP+=("NoMaD-PointGoal sim-data @sim=NoMaD-PointGoal sim-data @real" "NoMaD-PointGoal real-data @real=NoMaD-PointGoal real-data @sim"
      "NoMaD-PointGoal mix-data @sim=NoMaD-PointGoal mix-data @real"
      "NoMaD-PointGoal sim-data @sim=Goal follower @sim" "NoMaD-PointGoal real-data @real=Goal follower @real")
python -m rvn_data.benchmark.report "${ROWS[@]}" -o report.md "${CMP[@]/#/--compare=}" \
  --title "Real+Sim stand-in (main c3f8f68; sim = camera hfov 90 / 0.6 m, d_step 0.25; real = hfov 120 / 0.3 m, d_step 0.2; sim share 0.5; 4,000 steps each)"

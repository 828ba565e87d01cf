#!/usr/bin/env bash
# Copies the recipe run's records into this folder and writes report.md from them:
#   bash docs/results/2026-11-26_main/assemble.sh runs/small_main
# eval/<row>/: metrics.json, episodes.jsonl, run.json, rvn-eval.log as rvn-eval wrote them;
# train/<run>/: config.yaml (settings + provenance) and rvn-train.log (val agreement per 1000 steps).
set -euo pipefail
RUN=$(cd "${1:-runs/small_main}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
for d in "$RUN"/eval/*/; do
  n=$(basename "$d"); [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
done
for d in "$RUN"/train/*/; do
  n=$(basename "$d"); mkdir -p "$HERE/train/$n"; cp "$d"/config.yaml "$HERE/train/$n/"
  cp "$d"/rvn-train.log "$HERE/train/$n/" 2>/dev/null || true
done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
ROWS=(random goal_follower trajectory_oracle oracle vint_pointgoal
      nomad_pointgoal nomad_pointgoal_vote nomad_neg nomad_pointgoal_vote_veto nomad_neg_veto
      nomad_pointgoal_seed1 nomad_pointgoal_vote_seed1 nomad_neg_seed1 nomad_pointgoal_vote_veto_seed1 nomad_neg_veto_seed1)
DIRS=(); for r in "${ROWS[@]}"; do [ -d "$HERE/eval/$r" ] && DIRS+=("$HERE/eval/$r"); done
cd "$HERE"
python -m rvn_data.benchmark.report "${DIRS[@]/#$HERE\//}" -o report.md --title "Recipe on main (jobs/small_experiment.sh, SEEDS=\"0 1\")" \
  --compare "NoMaD-Neg=NoMaD-PointGoal" --compare "NoMaD-Neg seed1=NoMaD-PointGoal seed1" \
  --compare "NoMaD-Neg=NoMaD-PointGoal-vote" --compare "NoMaD-Neg seed1=NoMaD-PointGoal-vote seed1" \
  --compare "NoMaD-Neg-veto=NoMaD-PointGoal-vote-veto" --compare "NoMaD-Neg-veto seed1=NoMaD-PointGoal-vote-veto seed1" \
  --compare "NoMaD-PointGoal-vote=NoMaD-PointGoal" --compare "NoMaD-PointGoal-vote seed1=NoMaD-PointGoal seed1" \
  --compare "NoMaD-Neg-veto=NoMaD-Neg" --compare "NoMaD-Neg-veto seed1=NoMaD-Neg seed1" \
  --compare "NoMaD-PointGoal=ViNT-PointGoal" --compare "NoMaD-PointGoal=Goal follower" --compare "ViNT-PointGoal=Goal follower"

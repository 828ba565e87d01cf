#!/usr/bin/env bash
# Copies the lever rows' records into this folder and writes report.md (beside the recipe run's reference and
# NoMaD rows in ../2026-11-26_main/eval, same 200 episodes) and scale.png / scale.md (data scale, item 6):
#   bash docs/results/2026-11-26_main_levers/assemble.sh runs/small_main
set -euo pipefail
RUN=$(cd "${1:-runs/small_main}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
LEVERS=(nomad_pointgoal_medoid nomad_neg_depthneg nomad_pointgoal_n256 nomad_pointgoal_n512 nomad_pointgoal_n1024 nomad_pointgoal_n2048
        nomad_pointgoal_medoid_seed1 nomad_neg_depthneg_seed1 nomad_neg_veto_escape)
for n in "${LEVERS[@]}"; do
  d=$RUN/eval/$n; [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
done
for n in nomad_neg_depthneg nomad_neg_depthneg_seed1 nomad_pointgoal_n256 nomad_pointgoal_n512 nomad_pointgoal_n1024 nomad_pointgoal_n2048; do
  d=$RUN/train/$n; [ -f "$d/config.yaml" ] || continue
  mkdir -p "$HERE/train/$n"; cp "$d/config.yaml" "$HERE/train/$n/"; cp "$d/rvn-train.log" "$HERE/train/$n/" 2>/dev/null || true
done
grep -E "^(eval|train)_nomad_(medoid|neg_depthneg|n[0-9]+|neg_veto_escape)" "$RUN/timings.tsv" >"$HERE/timings.tsv" || true
cd "$HERE"
BASE=../2026-11-26_main/eval
DIRS=("$BASE/random" "$BASE/goal_follower" "$BASE/trajectory_oracle" "$BASE/oracle"
      "$BASE/nomad_pointgoal" "$BASE/nomad_pointgoal_vote" "$BASE/nomad_neg" "$BASE/nomad_neg_veto"
      "$BASE/nomad_pointgoal_seed1" "$BASE/nomad_pointgoal_vote_seed1" "$BASE/nomad_neg_seed1")
for n in "${LEVERS[@]}"; do [ -d "eval/$n" ] && DIRS+=("eval/$n"); done
CMP=("NoMaD-PointGoal-medoid=NoMaD-PointGoal" "NoMaD-Neg=NoMaD-PointGoal-medoid" "NoMaD-PointGoal-vote=NoMaD-PointGoal-medoid"
     "NoMaD-PointGoal-medoid seed1=NoMaD-PointGoal seed1" "NoMaD-Neg seed1=NoMaD-PointGoal-medoid seed1"
     "NoMaD-Neg-depthneg=NoMaD-Neg" "NoMaD-Neg-depthneg=NoMaD-PointGoal" "NoMaD-Neg-depthneg=NoMaD-PointGoal-medoid"
     "NoMaD-Neg-depthneg seed1=NoMaD-Neg seed1" "NoMaD-Neg-depthneg seed1=NoMaD-PointGoal seed1"
     "NoMaD-PointGoal n512=NoMaD-PointGoal n256" "NoMaD-PointGoal n1024=NoMaD-PointGoal n512" "NoMaD-PointGoal n2048=NoMaD-PointGoal n1024"
     "NoMaD-PointGoal=NoMaD-PointGoal n2048" "NoMaD-PointGoal=NoMaD-PointGoal n1024" "NoMaD-Neg-veto-escape=NoMaD-Neg-veto")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md --title "Issue 31 levers on main (recipe run folder, same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"
SCALE=(); for n in 256 512 1024 2048; do [ -d "eval/nomad_pointgoal_n$n" ] && SCALE+=("eval/nomad_pointgoal_n$n:$n"); done
if [ ${#SCALE[@]} -gt 1 ]; then
  python scale.py "${SCALE[@]}" "$BASE/nomad_pointgoal:4096" -o scale.png >scale.md
  cat scale.md
fi

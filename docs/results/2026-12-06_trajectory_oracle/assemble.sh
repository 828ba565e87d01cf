#!/usr/bin/env bash
# Copies run.sh's record into this folder and writes report.md (the trajectory oracle beside the seed-0 rows of
# 2026-12-05_escape and 2026-12-05_turn_commit, same 200 val episodes; with policy.stop_radius=0.35 too) and
# margin_split.md:
#   bash docs/results/2026-12-06_trajectory_oracle/assemble.sh runs/trajectory_oracle
set -euo pipefail
RUN=$(cd "${1:-runs/trajectory_oracle}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for n in trajectory_oracle trajectory_oracle_stop035 trajectory_oracle_fallback; do
  d=$RUN/eval/$n; [ -f "$d/metrics.json" ] || { echo "skip $n (no metrics.json: not run or unfinished)"; continue; }
  mkdir -p "$HERE/eval/$n"; cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"; DIRS+=("eval/$n")
done
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
python -m rvn_data.benchmark.report ../2026-12-05_escape/eval/{random,goal_follower,nomad_pointgoal,nomad_neg,nomad_neg_veto} \
  ../2026-12-05_turn_commit/eval/nomad_neg_veto_commit "${DIRS[@]}" -o report.md \
  --title "The trajectory oracle reaching goals inside the expert's margin (main 1079895; seed-0 rows, same 200 val episodes)" \
  --compare-present --compare="NoMaD-Neg-veto=Trajectory oracle" --compare="NoMaD-Neg-veto-commit=Trajectory oracle" \
  --compare="Trajectory oracle stop 0.35=Trajectory oracle" --compare="Trajectory oracle fallback 0.02=Trajectory oracle" \
  --compare="NoMaD-Neg-veto=Trajectory oracle fallback 0.02" --compare="NoMaD-Neg-veto-commit=Trajectory oracle fallback 0.02"
python margin_split.py >margin_split.md

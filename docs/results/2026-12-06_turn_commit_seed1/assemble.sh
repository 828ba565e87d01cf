#!/usr/bin/env bash
# Copies run.sh's record into this folder and writes report.md: the seed-1 NoMaD-Neg-veto-commit row beside seed 1's
# rows (docs/results/2026-12-05_neg_seed1), seed 0's commit rows (docs/results/2026-12-05_turn_commit) and the
# reference rows (docs/results/2026-12-05_escape), paired on the same 200 episodes (assemble those first):
#   bash docs/results/2026-12-06_turn_commit_seed1/assemble.sh runs/turn_commit_seed1
set -euo pipefail
RUN=$(cd "${1:-runs/turn_commit_seed1}" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,goal_follower,trajectory_oracle,nomad_neg_veto} \
         ../2026-12-05_turn_commit/eval/nomad_neg_veto_commit ../2026-12-05_neg_seed1/eval/{nomad_neg,nomad_neg_veto}; do
  [ -f "$HERE/$d/metrics.json" ] && DIRS+=("$d")
done
d=$RUN/eval/nomad_neg_veto_commit
[ -f "$d/metrics.json" ] || { echo "assemble.sh: $d/metrics.json not found (not run or unfinished): run run.sh first" >&2; exit 2; }
mkdir -p "$HERE/eval/nomad_neg_veto_commit"
cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/nomad_neg_veto_commit/"
DIRS+=("eval/nomad_neg_veto_commit")
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
CMP=("NoMaD-Neg-veto-commit seed1=NoMaD-Neg-veto seed1" "NoMaD-Neg-veto-commit=NoMaD-Neg-veto"
     "NoMaD-Neg-veto-commit seed1=NoMaD-Neg-veto-commit" "NoMaD-Neg-veto-commit seed1=NoMaD-Neg seed1")
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "policy.turn_commit's second seed: NoMaD-Neg-veto with and without it, seeds 0 and 1 (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

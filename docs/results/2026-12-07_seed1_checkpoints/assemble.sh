#!/usr/bin/env bash
# Copies run.sh's records into this folder and writes report.md: seed 1's NoMaD-PointGoal at its five kept checkpoints and
# NoMaD-Neg with each as NoMaD_e, beside seed 0's same rows (../2026-12-07_nomad_checkpoints, ../2026-12-07_neg_checkpoints,
# whose reference rows serve both seeds: same episodes), each pair step by step, read over the checkpoints and pooled over
# the two seeds. Seed 1's latest rows are run.sh's when it evaluated them, else ../2026-12-05_neg_seed1's (the same
# training command without kept checkpoints); reproduction.txt compares the two where both exist:
#   bash docs/results/2026-12-07_seed1_checkpoints/assemble.sh runs/seed1_checkpoints
set -euo pipefail
RUN=$(cd "${1:-runs/seed1_checkpoints}" && pwd -P)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$HERE/../lib.sh"  # copy_eval, copy_trainings
STEPS=(ckpt8000 ckpt9000 ckpt10000 ckpt11000)  # each model's rows in step order, its latest last
DIRS=()
for n in random goal_follower trajectory_oracle oracle "${STEPS[@]/#/nomad_pointgoal_}" nomad_pointgoal; do
  DIRS+=("../2026-12-07_nomad_checkpoints/eval/$n")
done
for n in "${STEPS[@]/#/nomad_neg_}" nomad_neg; do DIRS+=("../2026-12-07_neg_checkpoints/eval/$n"); done
for model in nomad_pointgoal nomad_neg; do
  for n in "${STEPS[@]/#/${model}_}" "$model"; do
    copy_eval "$RUN" "$HERE" "$n" && continue
    if [ "$n" = "$model" ]; then  # seed 1's latest row: ../2026-12-05_neg_seed1's where run.sh has none yet
      DIRS+=("../2026-12-05_neg_seed1/eval/$n")
    else
      echo "assemble: skip $n (no metrics.json: not run or unfinished)"
    fi
  done
done
copy_trainings "$RUN" "$HERE" '*'
cp "$RUN/timings.tsv" "$HERE/timings.tsv"
cd "$HERE"
python - <<'PY' >reproduction.txt
import json, pathlib
print("seed 1's latest rows against ../2026-12-05_neg_seed1's (same training command, no kept checkpoints), episode by episode")
for n in ("nomad_pointgoal", "nomad_neg"):
    new, old = pathlib.Path("eval", n, "episodes.jsonl"), pathlib.Path("../2026-12-05_neg_seed1/eval", n, "episodes.jsonl")
    if not new.exists():
        print(f"{n}: not evaluated here"); continue
    a = {r["episode_id"]: r for r in map(json.loads, new.read_text().splitlines())}
    b = {r["episode_id"]: r for r in map(json.loads, old.read_text().splitlines())}
    same = [e for e in a if e in b and a[e] == b[e]]
    print(f"{n}: {len(same)} of {len(a)} episodes identical; differ: {sorted(set(a) - set(same))}")
PY
cat reproduction.txt
CMP=("NoMaD-Neg=NoMaD-PointGoal" "NoMaD-Neg seed1=NoMaD-PointGoal seed1" "NoMaD-Neg=Goal follower" "NoMaD-Neg=Trajectory oracle")
for at in "${STEPS[@]#ckpt}"; do  # step by step (pooled over the seeds where both have the step)
  CMP+=("NoMaD-Neg ckpt$at=NoMaD-PointGoal ckpt$at" "NoMaD-Neg seed1 ckpt$at=NoMaD-PointGoal seed1 ckpt$at")
done
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "NoMaD-PointGoal and NoMaD-Neg at NoMaD-PointGoal's last five checkpoints, training seeds 0 and 1 (same 200 val episodes)" \
  --compare-present "${CMP[@]/#/--compare=}"

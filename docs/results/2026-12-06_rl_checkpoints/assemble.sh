#!/usr/bin/env bash
# Copies run.sh's records (each RL run's evaluation at its checkpoint before the latest) into this folder and writes
# report.md: every RL row of docs/results/README.md's table beside its earlier checkpoint's row, read over both
# (significance.over_checkpoints), with NoMaD-PointGoal of both seeds and the reference rows, on the same 200 val
# episodes (episode set a7556e2bca0b); the rows at the latest checkpoints are the other folders' records:
#   bash docs/results/2026-12-06_rl_checkpoints/assemble.sh runs/rl_main runs/rl_ddppo
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIRS=()
for d in ../2026-12-05_escape/eval/{random,nomad_pointgoal} ../2026-12-05_neg_seed1/eval/nomad_pointgoal \
         ../2026-12-06_rl_main/eval/{goal_follower_stoprule,trajectory_oracle,ppo} \
         ../2026-12-06_rl_lag_ddppo/eval/{ppo_lag,ddppo} ../2026-12-06_ddppo_seed1/eval/ddppo_seed1 \
         ../2026-12-06_rl_seed1/eval/{ppo_seed1,ppo_lag_seed1} \
         ../2026-12-06_ppo_600k/eval/ppo_{600k,800k,1000k}{,_seed1} ../2026-12-06_ppo_lag_600k/eval/ppo_lag_600k{,_seed1}; do
  [ -f "$HERE/$d/metrics.json" ] || { echo "assemble: $d missing" >&2; exit 1; }
  DIRS+=("$d")
done
RUNS="ppo|ppo_lag|ppo_600k|ppo_800k|ppo_1000k|ppo_lag_600k|ddppo"  # run.sh's runs (later folders' ckpt rows left out)
for out in "${1:-runs/rl_main}" "${2:-runs/rl_ddppo}"; do
  for d in "$out"/eval/*_ckpt*; do
    n=${d##*/}
    [[ "$n" =~ ^($RUNS)(_seed1)?_ckpt[0-9]+$ ]] || continue
    mkdir -p "$HERE/eval/$n"
    cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$HERE/eval/$n/"
    DIRS+=("eval/$n")
  done
  grep -P "^eval_($RUNS)(_seed1)?_ckpt\d+\t" "$out/timings.tsv" >> "$HERE/timings.part" || true
done
mv "$HERE/timings.part" "$HERE/timings.tsv"
cd "$HERE"
CMP=()
for s in "" " seed1"; do
  for row in PPO "PPO 600k" "PPO 800k" "PPO 1000k" PPO-Lagrangian "PPO-Lagrangian 600k" DD-PPO; do
    CMP+=("$row$s=Goal follower")
  done
  CMP+=("PPO 600k$s=PPO$s" "PPO 800k$s=PPO 600k$s" "PPO 1000k$s=PPO 800k$s" "PPO 1000k$s=PPO$s"
        "PPO-Lagrangian$s=PPO$s" "PPO-Lagrangian 600k$s=PPO-Lagrangian$s" "PPO-Lagrangian 600k$s=PPO 600k$s"
        "DD-PPO$s=PPO$s" "NoMaD-PointGoal$s=PPO$s" "NoMaD-PointGoal$s=PPO 1000k$s" "NoMaD-PointGoal$s=DD-PPO$s")
done
for d in eval/*_ckpt*; do  # each run's two checkpoints against each other
  m=$(python -c "import json, sys; print(json.load(open(sys.argv[1]))['method'])" "$d/metrics.json")
  CMP+=("${m% ckpt*}=$m")
done
python -m rvn_data.benchmark.report "${DIRS[@]}" -o report.md \
  --title "Every RL row read over its run's last two checkpoints, beside NoMaD-PointGoal and the references (same 200 val episodes)" \
  "${CMP[@]/#/--compare=}"

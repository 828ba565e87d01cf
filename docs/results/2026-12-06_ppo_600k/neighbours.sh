#!/usr/bin/env bash
# How far apart two checkpoints a few updates apart evaluate: each 800k and 1000k run's other kept checkpoint (800k:
# 798,720 env steps, 3 updates before 800,256; 1000k: 993,280, 14 updates before 1,000,448) evaluated on the same 200
# val episodes as rows "PPO 799k", "PPO 993k" (and "... seed1"). rvn-eval loads a run's latest checkpoint, so each
# is a folder train/<run>_prev holding the run's config.yaml and that checkpoint (hard links) as its latest:
#   bash docs/results/2026-12-06_ppo_600k/neighbours.sh runs/rl_main      # rerun to resume
set -euo pipefail
OUT=$(cd "${1:-runs/rl_main}" && pwd)
export RVN_CACHE_DIR=$OUT/cache OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
EVAL=("split=val" "episodes.num_scenes=50" "episodes.per_scene=4" "episodes.n_goals=32" "env.t_max=500"
      "episodes.dir=$OUT/episodes" "workers=2" "progress=false" "seed=0" "renderer=auto" "camera.width=64" "camera.height=64")
mkdir -p "$OUT/logs" "$OUT/.done"
source "$(dirname "${BASH_SOURCE[0]}")/../../../jobs/lib.sh"   # step NAME CMD...: skip if done, log, time
for run in ppo_800k:798720:799k ppo_1000k:993280:993k; do
  IFS=: read -r name steps label <<<"$run"
  for s in "" _seed1; do
    src=$OUT/train/$name$s dst=$OUT/train/$name${s}_prev ckpt=$(printf 'ckpt_%012d' "$steps")
    if [[ ! -d "$dst" ]]; then  # under a temporary name, then renamed
      rm -rf "$dst.part" && mkdir -p "$dst.part/checkpoints" && cp "$src/config.yaml" "$dst.part/" &&
        cp -al "$src/checkpoints/$ckpt" "$dst.part/checkpoints/" && echo "$ckpt" >"$dst.part/checkpoints/latest" &&
        mv "$dst.part" "$dst"
    fi
    step "eval_$name${s}_prev" nice -n 15 rvn-eval policy=checkpoint policy.checkpoint_path="$dst" \
      "method=PPO $label${s:+ seed1}" out_dir="$OUT/eval/$name${s}_prev" "${EVAL[@]}"
  done
done

#!/usr/bin/env bash
# Paper-scale expert + negative datasets (800 train scenes x 400 trajectories = 320k each, every scene in the GNM
# train split: dataset.train_fraction=1.0; add dataset.train_fraction=0.8 to resume datasets made before with it)
# on a Slurm cluster: 64 array tasks, 12-13 scenes each. Edit conf/hydra/launcher/slurm.yaml
# (partition, account, setup) first. Re-running the same command resumes: finished
# trajectories and scenes are skipped, and the result is byte-identical.
set -euo pipefail
OUT=${OUT:-/data/rvn}
export RVN_CACHE_DIR=${RVN_CACHE_DIR:-$OUT/cache}   # each scene's navmesh built once for both datasets (README, Caches)
SHARDS=${SHARDS:-64}
LAST=$((SHARDS - 1))
# your arguments go to both commands, Hydra's own (hydra/launcher=..., hydra.launcher.partition=..., any hydra.*) only to
# the multirun: merge is one plain run, whose basic launcher has no partition or account (Hydra would refuse them)
MERGE_ARGS=()
for a in "$@"; do [[ "$a" =~ ^[+~]*hydra[./] ]] || MERGE_ARGS+=("$a"); done

for KIND in expert negative; do
  gen=0 merge=0
  rvn-gen -m hydra/launcher=slurm \
    dataset=${KIND} out_dir=${OUT}/rvn_${KIND} \
    scenes.num_scenes=800 trajectories_per_scene=400 split=train dataset.train_fraction=1.0 \
    shard_index="range(0,${SHARDS})" num_shards=${SHARDS} workers=4 progress=false \
    renderer=auto seed=0 "$@" || gen=$?
  # the last shard to finish writes data_splits/, data_config.yaml and manifest.json; merge is a no-op then. It runs
  # after a failed multirun too (a scene that failed, a shard that died; the launcher stops waiting at the first
  # failed shard, others may still run) and refuses, saying how many scenes are missing and naming the first;
  # rerun this script once the shards are done: finished scenes are skipped
  rvn-gen mode=merge dataset=${KIND} out_dir=${OUT}/rvn_${KIND} scenes.num_scenes=800 \
    trajectories_per_scene=400 split=train dataset.train_fraction=1.0 seed=0 renderer=auto "${MERGE_ARGS[@]}" || merge=$?
  if (( gen || merge )); then
    echo "gen_paper_scale.sh: error: the $KIND dataset is incomplete (rvn-gen -m exit $gen, merge exit $merge; shard logs in" \
         "${OUT}/rvn_${KIND}/.rvn/multirun/); rerun this script to resume" >&2
    exit $(( gen ? gen : merge ))
  fi
done

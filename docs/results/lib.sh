# Sourced by the results folders' assemble.sh: copies a run's records (what rvn-eval and rvn-train wrote) into the
# folder, so every folder keeps the same files under the same names:
#   source "$HERE/../lib.sh"; DIRS=(); copy_evals "$RUN" "$HERE" '*'; copy_trainings "$RUN" "$HERE" '*'
# Names are patterns inside RUN/eval or RUN/train, matched in the order given ('nomad_neg' 'nomad_neg_ckpt*').

# copy_eval RUN HERE NAME: RUN/eval/NAME's records into HERE/eval/NAME and "eval/NAME" onto DIRS, if it finished
# (rvn-eval writes metrics.json last); returns 1 and copies nothing if it did not.
copy_eval() {
  local d=$1/eval/$3
  [ -f "$d/metrics.json" ] || return 1
  mkdir -p "$2/eval/$3"
  cp "$d"/{metrics.json,episodes.jsonl,run.json,rvn-eval.log} "$2/eval/$3/"
  DIRS+=("eval/$3")
}

# copy_evals RUN HERE PATTERN...: copy_eval for each evaluation the patterns name; an unfinished one is said and skipped.
copy_evals() {
  local run=$1 here=$2 p d
  shift 2
  for p in "$@"; do
    for d in "$run"/eval/$p; do
      copy_eval "$run" "$here" "${d##*/}" || echo "assemble: skip ${d##*/} (no metrics.json: not run or unfinished)"
    done
  done
}

# copy_trainings RUN HERE PATTERN...: each training the patterns name that wrote its config.yaml: config.yaml,
# rvn-train.log, and each member's held-out val.json as <member>_val.json.
copy_trainings() {
  local run=$1 here=$2 p d n m
  shift 2
  for p in "$@"; do
    for d in "$run"/train/$p; do
      n=${d##*/}
      [ -f "$d/config.yaml" ] || continue
      mkdir -p "$here/train/$n"
      cp "$d/config.yaml" "$here/train/$n/"
      cp "$d/rvn-train.log" "$here/train/$n/" 2>/dev/null || true
      for m in "$d"/*/val.json; do
        if [ -f "$m" ]; then cp "$m" "$here/train/$n/$(basename "$(dirname "$m")")_val.json"; fi
      done
    done
  done
}

# merge_timings RUN HERE: RUN/timings.tsv's steps into HERE/timings.tsv, each step's figure RUN's where both have it,
# HERE's other steps kept (first-seen order): a later run folder (another seed's, made in a fresh session) adds to the
# folder's timings instead of replacing them. RUN's file must exist; HERE's need not.
merge_timings() {
  [ -f "$1/timings.tsv" ] || { echo "assemble: $1/timings.tsv not found: is $1 the run folder?" >&2; return 1; }
  { if [ -f "$2/timings.tsv" ]; then cat "$2/timings.tsv"; fi; cat "$1/timings.tsv"; } |
    awk -F'\t' '!($1 in v) {k[++n] = $1} {v[$1] = $0} END {for (i = 1; i <= n; i++) print v[k[i]]}' >"$2/.timings.tsv.tmp"
  mv "$2/.timings.tsv.tmp" "$2/timings.tsv"
}

# Shared by the job recipes: `source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"` after OUT is set and exists.
# step NAME CMD...: run CMD, log it to OUT/logs/NAME.log, time it into OUT/timings.tsv and STEPS_SECONDS, stop the
# recipe on failure, and record it in OUT/.done/NAME. Skipped instead when OUT/.done/NAME holds the same command and
# is no older than the record of any step before it in this run: so an unchanged prefix of steps is skipped, but once
# a step runs (its command changed, or it never finished), every later step runs again too, even with its command
# unchanged (an evaluation of a model just retrained, also when a run that retrained it was stopped before the
# evaluation); each tool then resumes its own work, or refuses an input that changed under it with its own error.
STEPS_SECONDS=${STEPS_SECONDS:-0}
STEP_NEWEST=""   # the newest OUT/.done record of the steps met so far in this run
# step_seen NAME...: count steps that ran in a background subshell (whose STEP_NEWEST and STEPS_SECONDS are lost) as
# met, after `wait`: the newest record, and the seconds such a step left in OUT/.done/NAME.seconds ("<run's $$> <s>";
# one an earlier run left, stopped between its `wait` and here, is dropped)
step_seen() {
  local n run s
  for n in "$@"; do
    if [[ -f "$OUT/.done/$n" && ( -z "$STEP_NEWEST" || "$OUT/.done/$n" -nt "$STEP_NEWEST" ) ]]; then
      STEP_NEWEST=$OUT/.done/$n
    fi
    if [[ $BASHPID == "$$" && -f "$OUT/.done/$n.seconds" ]]; then
      read -r run s <"$OUT/.done/$n.seconds" || true
      if [[ "$run" == "$$" ]]; then STEPS_SECONDS=$((STEPS_SECONDS + s)); fi
      rm -f "$OUT/.done/$n.seconds"
    fi
  done
}
step() {
  local name=$1; shift
  local cmd; cmd=$(printf '%q ' "$@")
  local record=$OUT/.done/$name
  if [[ -f "$record" && "$(cat "$record")" == "$cmd" && ! ( -n "$STEP_NEWEST" && "$STEP_NEWEST" -nt "$record" ) ]]; then
    echo "[$name] done before, skipped"; step_seen "$name"; return 0
  fi
  echo "[$name] $cmd"
  local t0=$SECONDS
  if ! "$@" >"$OUT/logs/$name.log" 2>&1; then
    echo "[$name] FAILED after $((SECONDS - t0)) s; last lines of $OUT/logs/$name.log:" >&2
    tail -n 20 "$OUT/logs/$name.log" >&2
    exit 1
  fi
  local took=$((SECONDS - t0))  # one reading: timings.tsv, STEPS_SECONDS and the line below agree
  printf '%s\t%s\n' "$name" "$took" >>"$OUT/timings.tsv"
  STEPS_SECONDS=$((STEPS_SECONDS + took))
  printf '%s' "$cmd" >"$record"
  step_seen "$name"
  if [[ $BASHPID != "$$" ]]; then printf '%s %s\n' "$$" "$took" >"$record.seconds"; fi  # for step_seen
  echo "[$name] ok in $took s"
}
# earlier_checkpoints RUN SUB K WHO HINT: EARLIER=(the steps of RUN/SUB's checkpoint folders ckpt_<n> before the newest,
# newest first, at most K-1 of them), the recipes' EVAL_CHECKPOINTS; where RUN keeps fewer than K, says so (WHO: the
# recipe, HINT: what set how many it keeps)
earlier_checkpoints() {
  local run=$1 sub=$2 k=$3 ckpt kept=()
  for ckpt in "$run/$sub"/ckpt_*; do if [[ -d "$ckpt" ]]; then kept=("${ckpt##*/}" "${kept[@]}"); fi; done
  if (( ${#kept[@]} < k )); then
    echo "$4: $run keeps ${#kept[@]} checkpoints ($5); EVAL_CHECKPOINTS=$k evaluates those"
  fi
  EARLIER=()
  for ckpt in "${kept[@]:1:k-1}"; do EARLIER+=("$((10#${ckpt#ckpt_}))"); done
}

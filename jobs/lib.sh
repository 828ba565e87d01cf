# Shared by the job recipes: `source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"` after OUT is set and exists.
# step NAME CMD...: run CMD unless OUT/.done/NAME holds the same command; log it to
# OUT/logs/NAME.log, time it into OUT/timings.tsv and STEPS_SECONDS, stop the recipe on failure.
STEPS_SECONDS=${STEPS_SECONDS:-0}
step() {
  local name=$1; shift
  local cmd; cmd=$(printf '%q ' "$@")
  if [[ -f "$OUT/.done/$name" && "$(cat "$OUT/.done/$name")" == "$cmd" ]]; then
    echo "[$name] done before, skipped"; return 0
  fi
  echo "[$name] $cmd"
  local t0=$SECONDS
  if ! "$@" >"$OUT/logs/$name.log" 2>&1; then
    echo "[$name] FAILED after $((SECONDS - t0)) s; last lines of $OUT/logs/$name.log:" >&2
    tail -n 20 "$OUT/logs/$name.log" >&2
    exit 1
  fi
  printf '%s\t%s\n' "$name" "$((SECONDS - t0))" >>"$OUT/timings.tsv"
  STEPS_SECONDS=$((STEPS_SECONDS + SECONDS - t0))
  printf '%s' "$cmd" >"$OUT/.done/$name"
  echo "[$name] ok in $((SECONDS - t0)) s"
}

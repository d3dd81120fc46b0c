#!/usr/bin/env bash
# Long fuzzing runs, one target after another at nice 19, each until RUNS executions or
# SECONDS_EACH seconds, whichever comes first; prints one line per target with the
# executions done (libFuzzer's final stats) and whether it crashed. New inputs go to
# build/asan/tests/fuzz/long/<target>/ (not the committed corpus); crashes to
# build/asan/tests/fuzz/artifacts/. Usage: scripts/fuzz_long.sh [RUNS=10000000]
# [SECONDS_EACH=3600] [targets...]   (after scripts/build.sh asan). Two queues use both
# cores. Do not stop the processes (SIGSTOP): libFuzzer's timeout is wall-clock time.
set -uo pipefail
cd "$(dirname "$0")/.."
runs=${1:-10000000}
seconds=${2:-3600}
shift 2 2>/dev/null || shift $#
targets=("$@")
if ((${#targets[@]} == 0)); then
  targets=(image_codec frame_decode map_requests export_reader skimap_file chunk_codec
    random_forest object_database rest_json)
fi
fuzz=build/asan/tests/fuzz
# rest_json's RSS grows ~0.4 MB per 1000 inputs under ASan's default 256 MB quarantine
# (0.07 MB without it; LeakSanitizer with every root turned off reports under 5 MB after
# 300 000 inputs, so the live heap is flat), and its rate falls from 6 000 to 1 500
# inputs/s by 5 M inputs: the long runs keep a 32 MB quarantine (a use-after-free is still
# caught for the last 32 MB freed) and an 8 GiB RSS limit.
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=32"
for t in "${targets[@]}"; do
  mkdir -p "$fuzz/long/$t" "$fuzz/artifacts"
  log="$fuzz/long/$t.log"
  start=$(date +%s)
  extra=()
  # map_requests' fixture maps grow with every frame it integrates (by design), so
  # libFuzzer's malloc/free balance check would run LeakSanitizer after most inputs (its
  # rate falls from thousands to hundreds a second); ctest's short runs keep the leak check.
  [[ $t == map_requests ]] && extra=(-detect_leaks=0)
  nice -n 19 "$fuzz/skimap_${t}_fuzz" "${extra[@]}" -runs="$runs" -max_total_time="$seconds" -timeout=30 \
    -rss_limit_mb=8192 -print_final_stats=1 -artifact_prefix="$fuzz/artifacts/$t-" \
    "$fuzz/long/$t" "tests/fuzz/corpus/$t" >"$log" 2>&1
  rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  echo "$t: ${execs:-?} executions in $(($(date +%s) - start)) s, exit $rc$( ((rc)) && echo ' (CRASH: see '"$log"')')"
done

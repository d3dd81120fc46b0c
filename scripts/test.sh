#!/usr/bin/env bash
# The whole test suite: installs dependencies, checks formatting, then runs every test once:
# - the compute-bound end-to-end tests and the build checks (label `release_only`, see
#   below) on the release build, which builds only what they run;
# - everything else on one clang build under ASan+UBSan (compiling it with
#   -Werror=thread-safety checks the lock annotations), then every fuzz target briefly
#   (SKIMAP_FUZZ_SECONDS each, default 10);
# - the concurrency tests under ThreadSanitizer (clang), built beside the ASan suite at the
#   lowest CPU priority, as the ASan build is beside the release pass.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
bash scripts/deps.sh
bash scripts/check_format.sh
jobs=$(nproc)
# The release pass: tests whose work is compute-bound and too slow under ASan (minutes each
# there): the object pipeline's training tests (300 s under ASan), the recognition suite
# (its world, trained objects and a recognised scene: 400 s under ASan), the browser test
# that trains and recognises the same scene, the ablation script's test (four recognition
# evals), PgFailoverTest's database failovers (ten kills and a paused primary, mostly
# waiting for the cluster); the layer check (reads sources and compile commands, no code of
# ours runs) and the Docker files against the release binaries. Their code runs under ASan
# through the object service tests, the unit tests of each part and, for the failovers,
# PostgresFailoverTest.* (lost COMMITs, a stalled server, reconnects).
# They carry the ctest label `release_only` (tests/CMakeLists.txt), and the target
# `release_only_tests` builds what they run, no more.
# One test more than cores: the failover tests mostly wait for the cluster (about 160 s of
# the pass), so the compute-bound tests keep both cores meanwhile.
# Builds that run beside a test pass take the CPU its tests leave idle: at the lowest CPU
# priority, in their own session (a process group the trap stops if a test fails). With the
# kernel's autogroup scheduling (on by default), `nice` weighs a task only against others of
# its session and every session gets an equal share, so `setsid nice -n 19` alone would take
# half the CPU from the tests; the session's own autogroup nice is set to 19 as well
# (docs/testing.md).
mkdir -p build
background_pids=()
# The group, or the process itself if it has not made its session yet.
trap 'for p in "${background_pids[@]}"; do kill -- -"$p" 2>/dev/null || kill "$p" 2>/dev/null || true; done' EXIT
in_background() { # LOG COMMAND...: starts COMMAND at the lowest priority; its pid in $!
  local log=$1
  shift
  setsid -w bash -c 'echo 19 >/proc/self/autogroup 2>/dev/null || true; exec nice -n 19 "$@"' \
    _ "$@" >"$log" 2>&1 &
  background_pids+=("$!")
}
wait_background() { # PID LOG WHAT: waits for a background build; its log if it failed
  if ! wait "$1"; then
    cat "$2"
    echo "test: $3 failed" >&2
    exit 1
  fi
}
bash scripts/build.sh release release_only_tests
# The clang (ASan) build starts beside the release pass, whose failover tests mostly wait.
in_background build/asan-build.log bash scripts/build.sh asan
asan_build=$!
(cd build/release && ctest --output-on-failure -j "$((jobs + 1))" -L release_only --timeout 600)
wait_background "$asan_build" build/asan-build.log "the ASan build"
# The TSan build beside the ASan suite, whose tests wait on processes, sockets and a ROS
# master.
in_background build/tsan-build.log bash scripts/build.sh tsan skimap_concurrency_test \
  skimap_server_concurrency_test
tsan_build=$!
# Every other test once, under ASan+UBSan (halt on the first report), the fuzz targets apart.
# Third-party leaks and races (Debian's uninstrumented libraries): tests/lsan.supp and
# tests/tsan.supp.
(cd build/asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
  LSAN_OPTIONS="suppressions=$root/tests/lsan.supp:print_suppressions=0" \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --output-on-failure -j "$jobs" -LE "fuzz|release_only" --timeout 900)
(cd build/asan && ctest --output-on-failure -j "$jobs" -L fuzz --timeout 900)
wait_background "$tsan_build" build/tsan-build.log "the TSan build"
(cd build/tsan && TSAN_OPTIONS="halt_on_error=1:suppressions=$root/tests/tsan.supp" ctest --output-on-failure -L concurrency --timeout 900)

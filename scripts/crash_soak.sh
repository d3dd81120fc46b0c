#!/usr/bin/env bash
# Crash-consistency soak: the crash test (tests/server/app/crash_test.cc) with many SIGKILLs at
# random moments while two clients stream into a real skimapd (ctest runs 5 kills).
# Usage: scripts/crash_soak.sh [rounds (default 25)] [seed (default random)]
#   SKIMAP_CRASH_FRAMES=N  frames per stream and round (default 24)
#   SKIP_BUILD=1           use build/release as it is
# Prints the seed (and each kill's delay); rerun a failure with the same rounds and seed
# (thread timing differs between runs, so a rerun retries the same moments, not the same
# interleaving). Exit status: the test's (124 when the time limit ran out).
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-${SKIMAP_CRASH_ROUNDS:-25}}
seed=${2:-${SKIMAP_CRASH_SEED:-$(od -An -N4 -tu4 /dev/urandom | tr -d ' ')}}
if [[ "${SKIP_BUILD:-0}" != 1 ]]; then
  bash scripts/build.sh release skimapd skimap_crash_test >/dev/null
fi
# Each round takes a few seconds (restart + replay + rebuilding both maps from frame 0);
# a generous bound so that a hang ends the soak instead of the CI job.
limit=$((120 + 30 * rounds))
echo "crash soak: $rounds kills, seed $seed, time limit ${limit}s"
start=$(date +%s)
status=0
SKIMAP_CRASH_ROUNDS=$rounds SKIMAP_CRASH_SEED=$seed timeout "$limit" \
  build/release/tests/server/app/skimap_crash_test --gtest_filter='CrashTest.*' || status=$?
echo "crash soak: $rounds kills, seed $seed: $([[ $status == 0 ]] && echo PASSED || echo "FAILED (status $status)") in $(($(date +%s) - start)) s"
exit "$status"

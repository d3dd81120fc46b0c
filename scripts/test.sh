#!/usr/bin/env bash
# The whole test suite: installs dependencies, checks formatting, builds and runs every
# test (release build); builds everything again with clang under ASan+UBSan (compiling
# with -Werror=thread-safety checks the lock annotations), runs the suite there (the
# compute-bound end-to-end tests apart, see below) and every fuzz target briefly
# (SKIMAP_FUZZ_SECONDS each, default 20); then the concurrency tests under ThreadSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
bash scripts/deps.sh
bash scripts/check_format.sh
jobs=$(nproc)
bash scripts/build.sh release
(cd build/release && ctest --output-on-failure -j "$jobs" --timeout 600)
bash scripts/build.sh asan
# The suite under ASan+UBSan (halt on the first report), the fuzz targets apart, and five
# long end-to-end tests that run in the release pass only: the object pipeline's
# training tests (300 s under ASan), the recognition suite (its world, trained objects and
# a recognised scene, takes 400 s under ASan) and the browser test that trains and
# recognises the same scene, and the ablation script's test (scripts/ablation.py: four
# recognition evals of that scene), and PgFailoverTest's database failovers (ten kills and
# a paused primary: 200 + 60 s under ASan, mostly waiting for the cluster). Their code runs
# under ASan through the object service tests, the unit tests of each part, and for the
# failovers PostgresFailoverTest.* (lost COMMITs, a stalled server, reconnects).
# Layers.* reads sources and compile commands (no code of ours runs): the release pass runs it.
heavy='^(ObjectPipelineTest[.]|skimap_recognition_test$|Viewer[.]BrowserListsInstances|Ablation[.]|PgFailoverTest[.](Killing|APaused)|Layers[.])'
# Third-party leaks and races (Debian's uninstrumented libraries): tests/lsan.supp and
# tests/tsan.supp.
(cd build/asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
  LSAN_OPTIONS="suppressions=$root/tests/lsan.supp:print_suppressions=0" \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --output-on-failure -j "$jobs" -LE fuzz -E "$heavy" --timeout 900)
(cd build/asan && ctest --output-on-failure -j "$jobs" -L fuzz --timeout 900)
bash scripts/build.sh tsan skimap_concurrency_test skimap_server_concurrency_test
(cd build/tsan && TSAN_OPTIONS="halt_on_error=1:suppressions=$root/tests/tsan.supp" ctest --output-on-failure -L concurrency --timeout 900)

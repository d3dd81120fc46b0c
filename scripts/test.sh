#!/usr/bin/env bash
# The whole test suite: installs dependencies, checks formatting, builds and runs every
# test (release build); builds everything again with clang under ASan+UBSan (compiling
# with -Werror=thread-safety checks the lock annotations), runs the suite there (the
# compute-bound end-to-end tests apart, see below) and every fuzz target briefly
# (SKIMAP_FUZZ_SECONDS each, default 20); then the concurrency tests under ThreadSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
bash scripts/check_format.sh
jobs=$(nproc)
bash scripts/build.sh release
(cd build/release && ctest --output-on-failure -j "$jobs" --timeout 600)
bash scripts/build.sh asan
# The suite under ASan+UBSan (halt on the first report), the fuzz targets apart. The
# compute-bound end-to-end tests (training, recognising and generating whole scenes: 27 of
# the 45 minutes the suite takes here under ASan) run in the release pass only; their code
# still runs under ASan through RecognitionTest.WatchInstances..., the recognition
# fixture's training and scene generation, and the unit tests of each part.
heavy='^(RecognitionTest[.](Region|EveryMini|UpdatePoses|InstancesSurvive|BadRequests)'
heavy+='|ObjectPipelineTest[.]|GeneratorTest[.])'
(cd build/asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --output-on-failure -j "$jobs" -LE fuzz -E "$heavy" --timeout 900)
(cd build/asan && ctest --output-on-failure -j "$jobs" -L fuzz --timeout 900)
bash scripts/build.sh tsan skimap_concurrency_test skimap_server_concurrency_test
(cd build/tsan && TSAN_OPTIONS=halt_on_error=1 ctest --output-on-failure -L concurrency --timeout 900)

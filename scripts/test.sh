#!/usr/bin/env bash
# The whole test suite: installs dependencies, checks formatting, builds and runs every
# test (release build), the data-structure tests again under ASan+UBSan and the
# concurrency tests under ThreadSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
bash scripts/check_format.sh
jobs=$(nproc)
bash scripts/build.sh release
(cd build/release && ctest --output-on-failure -j "$jobs" --timeout 600)
bash scripts/build.sh asan skimap_test
(cd build/asan && ctest --output-on-failure -R '^(SkipList|SkiMap|Voxel|RGB|MultiLabel|Hypotheses|Instances|Serialization|MapQueries)' --timeout 600)
bash scripts/build.sh tsan skimap_concurrency_test skimap_server_concurrency_test
(cd build/tsan && TSAN_OPTIONS=halt_on_error=1 ctest --output-on-failure -L concurrency --timeout 900)

#!/usr/bin/env bash
# Configures and builds one flavour into build/<flavour>.
# Usage: scripts/build.sh [release|asan|tsan|bench] [ninja targets...]
#   release  optimized build of everything (the default)
#   asan     ASan + UBSan with clang, debug info, for the test suite; also the libFuzzer
#            targets (tests/fuzz) and clang's -Wthread-safety analysis as errors: one clang
#            build serves all three, so the test command compiles the tree twice, not four
#            times
#   tsan     ThreadSanitizer, for the concurrency tests
#   bench    release + the side-by-side benchmarks (run scripts/deps.sh --bench first)
set -euo pipefail
cd "$(dirname "$0")/.."
flavour=${1:-release}
shift || true
args=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
case "$flavour" in
  release) ;;
  asan) args+=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DSKIMAP_SANITIZE=address
    -DCMAKE_CXX_COMPILER=clang++-14 -DSKIMAP_BUILD_FUZZ=ON -DSKIMAP_THREAD_SAFETY=ON) ;;
  tsan) args+=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DSKIMAP_SANITIZE=thread) ;;
  bench) args+=(-DSKIMAP_BUILD_BENCH=ON) ;;
  *) echo "unknown flavour: $flavour" >&2; exit 2 ;;
esac
cmake -S . -B "build/$flavour" "${args[@]}" >/dev/null
cmake --build "build/$flavour" -- "$@"

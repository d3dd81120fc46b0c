#!/usr/bin/env bash
# Configures and builds one flavour into build/<flavour>.
# Usage: scripts/build.sh [release|asan|tsan|bench] [ninja targets...]
#   release  optimized build of everything (the default)
#   asan     ASan + UBSan with clang, line tables, for the test suite; also the libFuzzer
#            targets (tests/fuzz) and clang's -Wthread-safety analysis as errors: one clang
#            build serves all three, so the test command compiles the libraries twice, not four
#            times
#   tsan     ThreadSanitizer with clang, line tables, for the concurrency tests
#   bench    release + the side-by-side benchmarks (run scripts/deps.sh --bench first)
set -euo pipefail
cd "$(dirname "$0")/.."
flavour=${1:-release}
shift || true
# ccache keyed on paths relative to the checkout, so that a fresh clone elsewhere (CI) hits
# what an earlier build of the same sources left in the cache; room for the three flavours.
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1 CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-20G}"
# The sloppiness lets ccache cache compiles that use the test programs' precompiled header
# (tests/CMakeLists.txt); our sources do not expand __DATE__ or __TIME__.
export CCACHE_SLOPPINESS="pch_defines,time_macros,include_file_mtime,include_file_ctime"
# In CI (CI=true), whose cache starts empty, ccache runs in depend mode: on a miss it takes
# the headers from the compiler's -MD list instead of running the preprocessor first
# (0.4-0.6 s of CPU per compile: about 2 CPU-minutes over the test command's 218 compiles).
# Elsewhere the default mode stays: depend mode keys on the headers' absolute paths, so a
# clone in another folder would miss everything an earlier build left (docs/testing.md).
if [[ "${CI:-}" == true ]]; then
  export CCACHE_DEPEND=1
fi
args=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
case "$flavour" in
  release) ;;
  # The sanitizer builds keep line tables only (what a report's stack needs), not full
  # debug info: a good part less to compile and link.
  asan) args+=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DSKIMAP_SANITIZE=address
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -gline-tables-only -DNDEBUG"
    -DCMAKE_CXX_COMPILER=clang++-14 -DSKIMAP_BUILD_FUZZ=ON -DSKIMAP_THREAD_SAFETY=ON) ;;
  # TSan with clang too: less compile time than gcc for the same -O2 (a server/core batch
  # 19 s against 29 s, the TSan build 135 s against 158 s), and clang's is the reference
  # ThreadSanitizer.
  tsan) args+=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DSKIMAP_SANITIZE=thread
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -gline-tables-only -DNDEBUG"
    -DCMAKE_CXX_COMPILER=clang++-14) ;;
  bench) args+=(-DSKIMAP_BUILD_BENCH=ON) ;;
  *) echo "unknown flavour: $flavour" >&2; exit 2 ;;
esac
# The browser viewer (web/, served by skimapd at /): its npm packages exactly as
# web/package-lock.json says, then web/dist, rebuilt when a source is newer (the .proto
# files too: web/src/proto.js bundles them as text).
if command -v npm >/dev/null; then
  if [[ ! -d web/node_modules || web/package-lock.json -nt web/node_modules ]]; then
    (cd web && npm ci --no-audit --no-fund --loglevel=error >/dev/null && touch node_modules)
  fi
  if [[ ! -f web/dist/index.html ]] ||
    [[ -n "$(find web/index.html web/src web/public web/vite.config.js web/package-lock.json \
      proto -newer web/dist/index.html -print -quit)" ]]; then
    (cd web && npm run --silent build >/dev/null)
  fi
else
  echo "build: no npm (scripts/deps.sh installs it): the viewer (web/) is not built" >&2
fi
cmake -S . -B "build/$flavour" "${args[@]}" >/dev/null
cmake --build "build/$flavour" -- "$@"

#!/usr/bin/env bash
# Side-by-side benchmarks: installs the peer libraries, builds build/bench, runs every
# benchmark group with JSON output into build/bench/results/<group>.json and prints the
# ratio tables (scripts/bench_report.py). 4-10 minutes on 2 shared cores, depending on load,
# plus ~3 minutes for the storage group: storage_bench (a plain program: map persistence
# beside OctoMap's files) writes its markdown tables to build/bench/results/storage.md;
# --update-docs splices them into docs/benchmarks.md ("Map storage"). A failed check in it
# (exit status 1) stops the script before any doc is written. SKIMAP_BENCH_STORAGE_ARGS
# passes flags to it (e.g. "--resolutions=0.05").
# The harness checks every structure's answers (voxel sets, radius hits); a failed check
# fails the benchmark and bench_report.py then exits non-zero without touching the docs.
# Usage: scripts/bench.sh [--no-deps] [--update-docs]
#   --no-deps      skip scripts/deps.sh --bench (not root, or peers already installed)
#   --update-docs  also rewrite the generated part of docs/benchmarks.md
# Timed groups run SKIMAP_BENCH_REPETITIONS (default 3) repetitions of at least
# SKIMAP_BENCH_MIN_TIME seconds (default 0.2) each, randomly interleaved across benchmarks so
# that load from other processes hits every structure alike; the report keeps the fastest
# repetition. SKIMAP_BENCH_GROUPS (default "insert radius queries memory storage") picks
# groups.
set -euo pipefail
cd "$(dirname "$0")/.."
deps=1 update=0
for a in "$@"; do
  case "$a" in
    --no-deps) deps=0 ;;
    --update-docs) update=1 ;;
    *) echo "unknown option: $a" >&2; exit 2 ;;
  esac
done
((deps)) && bash scripts/deps.sh --bench
bash scripts/build.sh bench skimap_bench storage_bench fleet_bench
bin=build/bench/bench/skimap_bench
out=build/bench/results
mkdir -p "$out"
min_time=${SKIMAP_BENCH_MIN_TIME:-0.2}
reps=${SKIMAP_BENCH_REPETITIONS:-3}
declare -A filter=(
  [insert]='^BM_Insert'
  [radius]='^BM_Radius'
  [queries]='^BM_(BoxQuery|VisitAll|HeightMap|OccupancyGrid)_'
  [memory]='^BM_Memory')
json_groups=0 storage=0
for g in ${SKIMAP_BENCH_GROUPS:-insert radius queries memory storage}; do
  echo "bench: $g (load: $(cut -d' ' -f1-3 /proc/loadavg))" >&2
  if [[ $g == fleet ]]; then
    # Opt-in (SKIMAP_BENCH_GROUPS=fleet, ~4 min): skimapd nodes on PostgreSQL vs SQLite and
    # failover over 20 kills; tables into $out/fleet.md (docs/benchmarks.md, "Fleet").
    build/bench/bench/fleet_bench >"$out/fleet.md"
    cat "$out/fleet.md"
    continue
  fi
  if [[ $g == storage ]]; then
    # shellcheck disable=SC2086  # flags split on purpose
    build/bench/bench/storage_bench ${SKIMAP_BENCH_STORAGE_ARGS:-} >"$out/storage.md"
    storage=1
    continue
  fi
  json_groups=1
  # One process per group: the memory group measures heap deltas in a fresh process.
  timing=(--benchmark_min_time="$min_time")
  [[ $g != memory ]] && timing+=(--benchmark_repetitions="$reps"
    --benchmark_enable_random_interleaving=true)
  "$bin" --benchmark_filter="${filter[$g]}" "${timing[@]}" --benchmark_format=json \
    >"$out/$g.json"
done
if ((json_groups)); then
  args=("$out")
  ((update)) && args+=(--update docs/benchmarks.md)
  python3 scripts/bench_report.py "${args[@]}"
fi
if ((storage)); then
  if ((update)); then
    python3 scripts/bench_report.py --splice storage_bench "$out/storage.md" docs/benchmarks.md
  fi
  cat "$out/storage.md"
fi

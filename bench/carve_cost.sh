#!/usr/bin/env bash
# What free-space carving costs end to end: one skimapd (journal on, default flags) in a
# fresh data dir, then `skimap stream SOURCE --resolution=R --carve_free_space=true|false`
# for every resolution and source, the two settings in alternating order per rep. Prints
# per run the CLI's summary line (frames/s from the first send to the last ack) and
# skimapd's CPU per frame; a last table gives off/on frames/s per pair, i.e. how many times
# longer a stream takes with carving on (docs/benchmarks.md, "Free space").
#
# Usage: bench/carve_cost.sh [--build=build/bench] [--reps=2] [--resolutions="0.05 0.02 0.01"]
#            SOURCE...   (dataset folders or bags, as `skimap stream` takes them)
set -euo pipefail
cd "$(dirname "$0")/.."
build=build/bench
reps=2
resolutions="0.05 0.02 0.01"
sources=()
for arg in "$@"; do
  case "$arg" in
    --build=*) build=${arg#--build=} ;;
    --reps=*) reps=${arg#--reps=} ;;
    --resolutions=*) resolutions=${arg#--resolutions=} ;;
    *) sources+=("$arg") ;;
  esac
done
[[ ${#sources[@]} -gt 0 ]] || sources=(../shared/data/ycbv-0000)
skimapd=$build/server/skimapd
skimap=$build/client/skimap
# shellcheck source=bench/local_skimapd.sh
source bench/local_skimapd.sh
hz=$(getconf CLK_TCK)
results=$(mktemp)
run=0
for rep in $(seq "$reps"); do
  order="true false"
  ((rep % 2 == 0)) && order="false true"
  for res in $resolutions; do
    for src in "${sources[@]}"; do
      for carve in $order; do
        run=$((run + 1))
        ticks=$(awk '{print $14 + $15}' "/proc/$server_pid/stat")
        line=$("${cli[@]}" stream "$src" --map="carve$run" --resolution="$res" \
          --carve_free_space="$carve" 2>&1 | grep '^streamed')
        ticks=$(($(awk '{print $14 + $15}' "/proc/$server_pid/stat") - ticks))
        frames=$(sed -E 's/^streamed ([0-9]+) .*/\1/' <<<"$line")
        fps=$(sed -E 's/.*\(([0-9.]+) frames\/s\).*/\1/' <<<"$line")
        cpu=$(awk -v t="$ticks" -v hz="$hz" -v n="$frames" 'BEGIN { printf "%.1f", t * 1e3 / hz / n }')
        echo "$(basename "$src") $res carve=$carve rep $rep: $line; skimapd CPU $cpu ms/frame"
        echo "$src $res $carve $fps" >>"$results"
        "${cli[@]}" maps rm "carve$run" >/dev/null
      done
    done
  done
done
echo
echo "| source | voxel | frames/s off, per rep | frames/s on | off / on |"
echo "|---|---|---|---|---|"
for src in "${sources[@]}"; do
  for res in $resolutions; do
    awk -v s="$src" -v r="$res" '$1 == s && $2 == r {
        if ($3 == "true") on[n_on++] = $4; else off[n_off++] = $4 }
      END { a = b = c = ""; for (i = 0; i < n_on; ++i) {
          a = a (i ? ", " : "") off[i]; b = b (i ? ", " : "") on[i];
          c = c (i ? ", " : "") sprintf("%.2f", off[i] / on[i]) }
        printf "| %s | %g cm | %s | %s | %s |\n", s, r * 100, a, b, c }' "$results"
  done
done
rm -f "$results"

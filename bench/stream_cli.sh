#!/usr/bin/env bash
# `skimap stream` end to end: starts skimapd (journal on, its default flags otherwise) in a
# fresh data dir on a free loopback port, streams each DATASET folder REPS times into fresh
# maps at 2 cm and prints the CLI's summary line per run (frames/s from first send to last
# ack, the client's reading and encoding included) and the CPU time per frame of the CLI
# process (its start-up included) and of skimapd; docs/benchmarks.md, "Streaming from the
# CLI".
#
# Usage: bench/stream_cli.sh [--build=build/release] [--reps=3] [--skimap=PATH] [--skimapd=PATH] DATASET...
#   Extra stream flags go in $STREAM_FLAGS (e.g. STREAM_FLAGS="--depth_encoding=rvl").
#   --skimap runs another CLI binary (e.g. one built from an older commit) against the same
#   skimapd; --skimapd runs another server binary the same way.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build/release
reps=3
skimap=""
skimapd=""
datasets=()
for arg in "$@"; do
  case "$arg" in
    --build=*) build=${arg#--build=} ;;
    --reps=*) reps=${arg#--reps=} ;;
    --skimap=*) skimap=${arg#--skimap=} ;;
    --skimapd=*) skimapd=${arg#--skimapd=} ;;
    *) datasets+=("$arg") ;;
  esac
done
[[ ${#datasets[@]} -gt 0 ]] || datasets=(../shared/data/ycbv-0000)
skimap=${skimap:-$build/client/skimap}
skimapd=${skimapd:-$build/server/skimapd}
# shellcheck source=bench/local_skimapd.sh
source bench/local_skimapd.sh
run=0
for dataset in "${datasets[@]}"; do
  for rep in $(seq "$reps"); do
    run=$((run + 1))
    server_ticks=$(awk '{print $14 + $15}' "/proc/$server_pid/stat")
    # shellcheck disable=SC2086
    out=$(/usr/bin/time -f 'client_cpu_s %U %S' "${cli[@]}" stream "$dataset" --map="bench$run" \
      --resolution=0.02 ${STREAM_FLAGS:-} 2>&1)
    server_ticks=$(($(awk '{print $14 + $15}' "/proc/$server_pid/stat") - server_ticks))
    line=$(grep '^streamed' <<<"$out")
    frames=$(sed -E 's/^streamed ([0-9]+) .*/\1/' <<<"$line")
    read -r _ user sys < <(grep '^client_cpu_s' <<<"$out")
    hz=$(getconf CLK_TCK)
    cpu=$(awk -v u="$user" -v s="$sys" -v t="$server_ticks" -v hz="$hz" -v n="$frames" \
      'BEGIN { printf "CPU per frame: client %.1f ms, server %.1f ms", (u + s) * 1e3 / n, t * 1e3 / hz / n }')
    echo "$dataset run $rep: $line; $cpu"
    "${cli[@]}" maps rm "bench$run" >/dev/null
  done
done

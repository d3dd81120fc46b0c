#!/usr/bin/env bash
# The occupancy grid with and without the seen-through rule (docs/api.md, "Seen-through
# obstacles") on one dataset: streams it into a fresh local skimapd, fetches the grid both
# ways and, for a skimap-sim render, counts phantom obstacles against its true geometry
# (bench/grid_vs_floor_plan.py).
#   bench/seen_through.sh DATASET RESOLUTION [DATASET/scene_geometry.json]
# Binaries: $skimapd and $skimap (default: the bench build's).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
skimapd=${skimapd:-$here/../build/bench/server/skimapd}
skimap=${skimap:-$here/../build/bench/client/skimap}
source "$here/local_skimapd.sh"
dataset=$1 resolution=$2 geometry=${3:-}
"${cli[@]}" stream "$dataset" --map=m --resolution="$resolution" >/dev/null 2>&1
out=$(mktemp -d)
"${cli[@]}" grid --map=m -o "$out/kept.yaml" --keep_seen_through >/dev/null
"${cli[@]}" grid --map=m -o "$out/cleared.yaml" >/dev/null
for v in kept cleared; do
  echo "== $dataset at $resolution m, $v"
  if [[ -n "$geometry" ]]; then
    python3 "$here/grid_vs_floor_plan.py" "$out/$v.yaml" "$geometry"
  else
    python3 - "$out/$v.pgm" <<'PY'
import re, sys
d = open(sys.argv[1], "rb").read()
m = re.match(rb"P5\s+(?:#[^\n]*\n\s*)*(\d+)\s+(\d+)\s+(\d+)\s", d)
cells = d[m.end():m.end() + int(m[1]) * int(m[2])]
print("occupied", cells.count(0), "free", cells.count(254), "unknown", cells.count(205))
PY
  fi
done
rm -rf "$out"

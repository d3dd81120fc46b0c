#!/usr/bin/env bash
# The main job: builds skimapd and the skimap CLI, starts skimapd (default flags: port
# 50051, data dir out/skimapd-data), streams a dataset into map "demo", writes the 2D
# occupancy grid (ROS map_server PGM + YAML) and the height map (16-bit PNG + YAML) to out/,
# and leaves the server running until Ctrl-C.
#
# Usage: scripts/run.sh [DATASET]
#   DATASET defaults to a freshly generated skimap-sim `mini` scene, or to the real sample
#   ../shared/data/ycbv-0000 when the simulator is not available.
#   SKIMAP_RUN_ONCE=1 stops the server after writing the files (for scripted runs).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
bash scripts/build.sh release skimapd skimap_cli
mkdir -p out
dataset=${1:-}
if [[ -z "$dataset" ]]; then
  if [[ -f sim/CMakeLists.txt ]] && bash scripts/build.sh release skimap-sim >/dev/null 2>&1 &&
    ./build/release/sim/skimap-sim --preset mini --out out/sim-mini --no-train --quiet; then
    dataset=out/sim-mini
  else
    echo "run.sh: simulator unavailable, using the real sample ../shared/data/ycbv-0000"
    dataset=../shared/data/ycbv-0000
  fi
fi

port=50051
http_port=8080  # skimapd's default --http_address: the REST API
cli=(./build/release/client/skimap --server="localhost:$port")
if "${cli[@]}" maps ls >/dev/null 2>&1; then
  echo "run.sh: something already answers on port $port (an earlier run.sh?); stop it first" >&2
  exit 1
fi
./build/release/server/skimapd &
server_pid=$!
trap 'kill -INT "$server_pid" 2>/dev/null; wait "$server_pid" 2>/dev/null || true' EXIT
for _ in $(seq 50); do
  "${cli[@]}" maps ls >/dev/null 2>&1 && break
  sleep 0.2
done

# Maps persist in the data dir: start the demo map afresh.
"${cli[@]}" maps rm demo >/dev/null 2>&1 || true
"${cli[@]}" stream "$dataset" --map=demo --resolution=0.02
"${cli[@]}" maps ls
"${cli[@]}" grid --map=demo -o out/demo_grid.yaml
"${cli[@]}" heightmap --map=demo -o out/demo_heightmap.png
echo
echo "Occupancy grid: $PWD/out/demo_grid.yaml (+ demo_grid.pgm)"
echo "Height map:     $PWD/out/demo_heightmap.png (+ demo_heightmap.yaml)"
if [[ "${SKIMAP_RUN_ONCE:-0}" == 1 ]]; then
  exit 0
fi
echo "skimapd is serving maps/demo on localhost:$port (try: ${cli[*]} maps info demo)."
echo "REST API: http://127.0.0.1:$http_port/v1/maps (try: curl -o grid.png" \
  "'http://127.0.0.1:$http_port/v1/maps/demo/occupancyGrid?format=png'; docs/api.md, \"REST\")."
echo "Press Ctrl-C to stop it."
trap 'kill -INT "$server_pid" 2>/dev/null' INT TERM
wait "$server_pid" || true
trap - EXIT

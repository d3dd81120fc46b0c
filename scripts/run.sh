#!/usr/bin/env bash
# The main job. Until the map server lands, this is the mapping demo: it builds a SkiMap
# from the real RGB-D sample in ../shared/data/ycbv-0000 and prints its voxel count,
# bounds, memory and an ASCII occupancy grid.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
bash scripts/build.sh release skimap_demo
./build/release/perception/skimap_demo "${@:-../shared/data/ycbv-0000}"

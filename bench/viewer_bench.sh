#!/usr/bin/env bash
# Builds skimapd and the viewer (web/dist), then runs bench/viewer_bench.mjs (the viewer's
# time to first render and frame rate on 1 M and 10 M voxel maps in headless chromium).
# Extra arguments go to the script, e.g. --sizes=1000000 --seconds=3 --out=build/viewer_bench.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh release skimapd >/dev/null
exec node bench/viewer_bench.mjs --skimapd=build/release/server/skimapd --web_root=web/dist "$@"

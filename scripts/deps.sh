#!/usr/bin/env bash
# Installs the Debian packages the project needs. Idempotent and quiet when everything is
# already there. Usage: scripts/deps.sh [--bench]   (--bench adds the peer libraries that
# only the side-by-side benchmarks need: OctoMap, OpenVDB, nanoflann, PCL, Open3D).
set -euo pipefail
pkgs=(build-essential cmake ninja-build ccache lld pkg-config clang-format
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler libabsl-dev
  libeigen3-dev libopencv-dev libsqlite3-dev libzstd-dev libassimp-dev nlohmann-json3-dev libcpp-httplib-dev
  libturbojpeg0-dev libpng-dev libtiff-dev libwebp-dev libdeflate-dev zlib1g-dev libssl-dev openssl libgtest-dev libgmock-dev libbenchmark-dev opencv-doc grpc-proto
  prometheus-cpp-dev
  clang-14 libclang-rt-14-dev python3-grpcio python3-protobuf libpq-dev postgresql
  postgresql-15-auto-failover pg-auto-failover-cli procps
  chromium python3-matplotlib
  libroscpp-dev librosbag-dev libtf2-ros-dev libmessage-filters-dev libsensor-msgs-dev
  libnav-msgs-dev libvisualization-msgs-dev libgeometry-msgs-dev libtf2-msgs-dev liblz4-dev
  python3-gencpp python3-rosmaster python3-roslaunch)
if [[ "${1:-}" == "--bench" ]]; then
  pkgs+=(liboctomap-dev libopenvdb-dev libnanoflann-dev libpcl-dev libopen3d-dev)
fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# The ROS 1 (Noetic) libraries Debian ships: the skimap-ros bridge and bag reading (ros/;
# docs/ros.md), gencpp for its service types, rosmaster and roslaunch for its tests.
# postgresql: the PostgreSQL tests start throwaway servers of their own
# (tests/common/postgres_server.h); the package's default cluster is not used.
# pg_auto_failover (and procps's pgrep): scripts/pg_cluster.sh's replicated cluster for the
# database failover tests and bench/pg_failover_bench (docs/operations.md).
# chromium: the viewer's browser test (tests/web) drives Debian's chromium headless.
# Node.js for the viewer (web/, built by scripts/build.sh) and the third-party client test (tests/interop/node): Debian's unless a node is
# already installed; its npm packages exactly as the committed package-lock.json says.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi
# tests/ros/mcap_writer: the independent MCAP (ROS 2 bag) writer of the ros/bag tests.
for node_dir in tests/interop/node tests/ros/mcap_writer; do
  node_dir="$(dirname "$0")/../$node_dir"
  if [[ ! -d "$node_dir/node_modules" || "$node_dir/package-lock.json" -nt "$node_dir/node_modules" ]]; then
    (cd "$node_dir" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
  fi
done

#!/usr/bin/env bash
# Prints the Debian packages that hold the shared libraries the given binaries link
# directly (their DT_NEEDED entries), one per line: the runtime image installs exactly
# these (apt brings their own dependencies), so it follows the build without a
# hand-kept list. Usage: docker/runtime_packages.sh BINARY...
set -euo pipefail
for bin in "$@"; do
  needed=$(readelf -d "$bin" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
  for lib in $needed; do
    path=$(ldd "$bin" | awk -v l="$lib" '$1 == l && $3 ~ /^\// {print $3}')
    [[ -n "$path" ]] || { echo "runtime_packages: $lib of $bin not found" >&2; exit 1; }
    dpkg -S "$(readlink -f "$path")" 2>/dev/null | cut -d: -f1 ||
      dpkg -S "$path" | cut -d: -f1
  done
done | sort -u

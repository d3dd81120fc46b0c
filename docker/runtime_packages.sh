#!/usr/bin/env bash
# Prints the Debian packages that hold the shared libraries the given binaries link
# directly (their DT_NEEDED entries), one per line: the runtime image installs exactly
# these (apt brings their own dependencies), so it follows the build without a
# hand-kept list. Usage: docker/runtime_packages.sh BINARY...
set -euo pipefail
# One ldd per binary and one dpkg -S for all the paths (a call per library took a minute).
paths=()
for bin in "$@"; do
  needed=$(readelf -d "$bin" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
  resolved=$(ldd "$bin")
  for lib in $needed; do
    path=$(awk -v l="$lib" '$1 == l && $3 ~ /^\// {print $3}' <<<"$resolved")
    [[ -n "$path" ]] || { echo "runtime_packages: $lib of $bin not found" >&2; exit 1; }
    paths+=("$(readlink -f "$path")")
  done
done
# dpkg knows a library by its real path or, on merged-/usr systems, by the /lib one: ask
# for both in one call and require an answer for each library.
mapfile -t unique < <(printf '%s\n' "${paths[@]}" | sort -u)
queries=()
for path in "${unique[@]}"; do queries+=("$path" "${path#/usr}"); done
owners=$(dpkg -S "${queries[@]}" 2>/dev/null || true)
for path in "${unique[@]}"; do
  awk -F': ' -v a="$path" -v b="${path#/usr}" '$2 == a || $2 == b {f = 1} END {exit !f}' \
    <<<"$owners" ||
    { echo "runtime_packages: no package holds $path" >&2; exit 1; }
done
cut -d: -f1 <<<"$owners" | sort -u

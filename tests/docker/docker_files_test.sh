#!/usr/bin/env bash
# Checks docker/Dockerfile and docker/compose.yaml against what they must not drift from
# (there is no Docker engine on the development machines: nothing here builds an image):
# - the Dockerfile builds with the README's scripts (scripts/deps.sh, scripts/build.sh)
#   and copies the binaries from where build.sh puts them;
# - every skimapd flag in compose.yaml's command and the Dockerfile's CMD is one that
#   `skimapd --help` lists, and the health check is a command the skimap CLI knows;
# - runtime_packages.sh finds the packages of the built binaries.
# Usage: docker_files_test.sh REPO_ROOT SKIMAPD SKIMAP_CLI
set -uo pipefail
root=$1 skimapd=$2 cli=$3
dockerfile=$root/docker/Dockerfile compose=$root/docker/compose.yaml
passed=0 failed=0
check() {  # check NAME CONDITION...
  local name=$1
  shift
  if "$@"; then
    passed=$((passed + 1))
  else
    failed=$((failed + 1))
    echo "FAILED: $name" >&2
  fi
}

check "Dockerfile has a build stage and a runtime stage on Debian bookworm" \
  test "$(grep -cE '^FROM debian:bookworm' "$dockerfile")" -ge 2
check "Dockerfile installs with scripts/deps.sh" grep -qE 'bash scripts/deps\.sh' "$dockerfile"
check "Dockerfile builds with scripts/build.sh release" \
  grep -qE 'bash scripts/build\.sh release' "$dockerfile"
check "the README documents the same scripts" \
  bash -c "grep -q 'scripts/build.sh' '$root/README.md' && grep -q 'scripts/deps.sh' '$root/README.md'"
# The binaries the Dockerfile copies out of build/release exist where build.sh put them.
build_dir=$(dirname "$(dirname "$skimapd")")
for path in $(grep -oE 'build/release/[A-Za-z0-9_/.-]+' "$dockerfile" | sort -u); do
  check "$path (copied by the Dockerfile) is built there" test -x "$build_dir/${path#build/release/}"
done

help=$("$skimapd" --help 2>&1)
flags_known() {  # every --flag in the given lines is in skimapd --help
  local ok=0
  for flag in $(grep -oE -- '--[a-z_]+' <<<"$1" | sort -u); do
    if ! grep -qE -- "^ *$flag( |\$)" <<<"$help"; then
      echo "  skimapd --help does not list $flag" >&2
      ok=1
    fi
  done
  return $ok
}
# compose: the uncommented list items under `command:` (up to the next key).
compose_flags=$(awk '/^    command:/{on=1; next} on && /^    [a-z]/{on=0} on && !/^ *#/' "$compose")
check "compose.yaml has skimapd flags" grep -q -- '--data_dir' <<<"$compose_flags"
check "compose.yaml's flags are skimapd's" flags_known "$compose_flags"
check "the Dockerfile's CMD flags are skimapd's" flags_known "$(grep -E '^CMD' "$dockerfile")"
check "compose.yaml keeps a data volume" grep -qE -- '- skimap-data:/var/lib/skimap' "$compose"
check "compose.yaml publishes on the host's loopback only" \
  grep -qE '"127\.0\.0\.1:50051:50051"' "$compose"
check "compose.yaml publishes the REST port on the host's loopback only" \
  grep -qE '"127\.0\.0\.1:8080:8080"' "$compose"
cli_help=$("$cli" --help 2>&1)
check "the health check is a command of the skimap CLI" grep -q 'maps ls' <<<"$cli_help"
check "compose and the Dockerfile use the same health check" \
  bash -c "grep -q '\"skimap\", \"--server=127.0.0.1:50051\", \"maps\", \"ls\"' '$compose' &&
           grep -q '\"skimap\", \"--server=127.0.0.1:50051\", \"maps\", \"ls\"' '$dockerfile'"
packages=$(bash "$root/docker/runtime_packages.sh" "$skimapd" "$cli")
check "runtime_packages.sh finds the gRPC runtime" grep -q '^libgrpc++' <<<"$packages"

echo "$passed passed, $failed failed"
[[ $failed -eq 0 ]]

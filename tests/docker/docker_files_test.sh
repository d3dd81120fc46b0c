#!/usr/bin/env bash
# Checks docker/Dockerfile and docker/compose.yaml against what they must not drift from
# (there is no Docker engine on the development machines: nothing here builds an image):
# - the Dockerfile builds with the README's scripts (scripts/deps.sh, scripts/build.sh)
#   and copies the binaries from where build.sh puts them;
# - every skimapd flag in compose.yaml's command and the Dockerfile's CMD is one that
#   `skimapd --help` lists, and the health check is a command the skimap CLI knows;
# - runtime_packages.sh finds the packages of the built binaries;
# - the compose configuration runs: scripts/dev_secrets.sh makes the secrets, skimapd starts
#   with compose's flags (secrets, data dir and ports mapped to a temporary directory and
#   free loopback ports), compose's health check passes, a client without a token is
#   refused and one with the admin token is served, all over TLS.
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
# compose-ha.yaml: every `- --flag` line of its skimapd services is skimapd's, none turns
# authentication off, and the store lists both data nodes.
compose_ha=$root/docker/compose-ha.yaml
ha_flags=$(grep -E '^ +- --' "$compose_ha")
check "compose-ha.yaml has skimapd flags" grep -q -- '--store=postgresql://' <<<"$ha_flags"
check "compose-ha.yaml's flags are skimapd's" flags_known "$ha_flags"
check "compose-ha.yaml does not turn authentication off" bash -c "! grep -qE -- '^ *- --insecure' '$compose_ha'"
check "compose-ha.yaml's store lists both data nodes" grep -q -- 'node1:5432,node2:5432' <<<"$ha_flags"
check "compose-ha.yaml builds its database image from pg_auto_failover.Dockerfile" \
  grep -q 'postgresql-15-auto-failover' "$root/docker/pg_auto_failover.Dockerfile"
check "compose.yaml keeps a data volume" grep -qE -- '- skimap-data:/var/lib/skimap' "$compose"
check "compose.yaml publishes on the host's loopback only" \
  grep -qE '"127\.0\.0\.1:50051:50051"' "$compose"
check "compose.yaml publishes the REST port on the host's loopback only" \
  grep -qE '"127\.0\.0\.1:8080:8080"' "$compose"
check "compose.yaml does not turn authentication off" bash -c "! grep -qE -- '^ *- --insecure' '$compose'"
check "the Dockerfile's CMD does not turn authentication off" bash -c "! grep -E '^CMD' '$dockerfile' | grep -q -- --insecure"
cli_help=$("$cli" --help 2>&1)
check "the health check is a command of the skimap CLI" grep -q 'skimap health' <<<"$cli_help"
health='"skimap", "--server=localhost:50051", "--tls_ca=/run/secrets/tls_ca", "health"'
check "compose and the Dockerfile use the same health check" \
  bash -c "grep -qF '$health' '$compose' && grep -qF '$health' '$dockerfile'"
# Every /run/secrets/<name> used is a secret of the service, from ./secrets/<name>, and one
# that dev_secrets.sh makes.
used=$(grep -v '^ *#' "$compose" | grep -oE '/run/secrets/[a-z_]+' | sort -u)
for path in $used; do
  name=${path#/run/secrets/}
  check "compose mounts the secret $name" \
    bash -c "grep -qE '^    secrets: \\[.*\\b$name\\b' '$compose' && grep -qE '^    file: \\./secrets/$name( |\$)' '$compose'"
  check "dev_secrets.sh makes $name" grep -qE "\\b$name\\b" "$root/scripts/dev_secrets.sh"
done

# Runs the compose configuration without Docker.
tmp=$(mktemp -d)
server_pid=""
cleanup() {
  [[ -n $server_pid ]] && kill "$server_pid" 2>/dev/null && wait "$server_pid" 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
grpc_port=$(free_port) http_port=$(free_port)
bash "$root/scripts/dev_secrets.sh" "$tmp/secrets" >/dev/null
args=()
while read -r flag; do
  case $flag in
    --address=*) flag=--address=127.0.0.1:$grpc_port ;;
    --http_address=*) flag=--http_address=127.0.0.1:$http_port ;;
    --data_dir=*) flag=--data_dir=$tmp/data ;;
    --web_root=*) flag=--web_root= ;;
  esac
  args+=("${flag//\/run\/secrets\//$tmp/secrets/}")
done < <(sed -E 's/^ *- *//; s/ +#.*//' <<<"$compose_flags" | grep -- '^--')
"$skimapd" "${args[@]}" >"$tmp/skimapd.log" 2>&1 &
server_pid=$!
# The health check as compose runs it (its CMD list), with the mapped paths and port.
mapfile -t health_cmd < <(grep -oE 'test: \[.*\]' "$compose" | grep -oE '"[^"]+"' | tr -d '"' |
  tail -n +2 | sed -e "s|/run/secrets/|$tmp/secrets/|; s|localhost:50051|localhost:$grpc_port|")
healthy=1
for _ in $(seq 1 100); do
  if "$cli" "${health_cmd[@]:1}" >"$tmp/health.out" 2>&1; then healthy=0; break; fi
  kill -0 "$server_pid" 2>/dev/null || break
  sleep 0.2
done
check "skimapd starts with compose's flags and secrets, and compose's health check passes" \
  test $healthy -eq 0
[[ $healthy -eq 0 ]] || { echo "skimapd ${args[*]}:" >&2; cat "$tmp/skimapd.log" "$tmp/health.out" >&2; }
check "the health check says SERVING" grep -q SERVING "$tmp/health.out"
client=("$cli" --server=localhost:$grpc_port --tls_ca=$tmp/secrets/tls_ca)
check "a client without a token is refused" \
  bash -c "! SKIMAP_TOKEN= ${client[*]} maps ls 2>&1 | grep -q 'no maps' && SKIMAP_TOKEN= ${client[*]} maps ls 2>&1 | grep -q UNAUTHENTICATED"
check "a client with the admin token is served" \
  bash -c "${client[*]} --token_file=$tmp/secrets/admin.token maps create m1 >/dev/null && ${client[*]} --token_file=$tmp/secrets/read.token maps ls | grep -q m1"
check "a client that does not trust the CA is refused" \
  bash -c "! $cli --server=localhost:$grpc_port --tls_ca=/etc/ssl/certs/ca-certificates.crt health >/dev/null 2>&1"

packages=$(bash "$root/docker/runtime_packages.sh" "$skimapd" "$cli")
check "runtime_packages.sh finds the gRPC runtime" grep -q '^libgrpc++' <<<"$packages"

echo "$passed passed, $failed failed"
[[ $failed -eq 0 ]]

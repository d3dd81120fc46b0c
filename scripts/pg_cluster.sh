#!/usr/bin/env bash
# pg_cluster.sh: a replicated PostgreSQL with automatic failover on this machine, from
# Debian's pg_auto_failover (postgresql-15-auto-failover, pg-auto-failover-cli): a monitor,
# a primary and one or two synchronous standbys (with two, a commit waits for one of them:
# number_sync_standbys = 1, so the cluster keeps acknowledging with a node down), each its
# own process group under DIR, listening on
# 127.0.0.1 only, trust authentication (loopback; not for a shared host). For the HA tests,
# bench/pg_failover_bench and trying skimapd on a cluster (docs/operations.md, "A
# replicated store"). Runs the servers as the `postgres` user when called as root.
#
#   scripts/pg_cluster.sh up DIR MONITOR_PORT PORT1 PORT2 [PORT3]  # prints the --store URI
#   scripts/pg_cluster.sh wait DIR [SECONDS]   # until a primary and a secondary (default 120)
#   scripts/pg_cluster.sh primary DIR          # the primary's node number (1, 2 or 3)
#   scripts/pg_cluster.sh kill DIR N           # kill -9 node N: its keeper and its postgres
#   scripts/pg_cluster.sh start DIR N          # node N's keeper again: it rejoins as standby
#   scripts/pg_cluster.sh pause DIR N / resume DIR N   # SIGSTOP / SIGCONT node N
#   scripts/pg_cluster.sh state DIR            # the monitor's view
#   scripts/pg_cluster.sh down DIR             # kill everything, remove DIR
#
# Failure detection is tuned for a LAN (the monitor's defaults suit a WAN: 20 s before a
# node is unhealthy, 30 s before a silent primary is taken as demoted); the values are in
# tune_monitor below and docs/operations.md says what each one trades.
set -euo pipefail

cmd=${1:?usage: pg_cluster.sh up|wait|primary|kill|start|pause|resume|state|down DIR ...}
dir=${2:?DIR}
bin=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -1)
[ -x "$bin/pg_ctl" ] || { echo "pg_cluster: no PostgreSQL server (scripts/deps.sh)" >&2; exit 1; }
command -v pg_autoctl >/dev/null ||
  { echo "pg_cluster: no pg_autoctl (apt-get install pg-auto-failover-cli postgresql-15-auto-failover)" >&2; exit 1; }

owner=()  # runs a command as the cluster's owner, with its pg_autoctl state under DIR
[ "$(id -u)" = 0 ] && owner=(runuser -u postgres --)
owner+=(env "XDG_CONFIG_HOME=$dir/xdg/config" "XDG_DATA_HOME=$dir/xdg/data"
  "XDG_RUNTIME_DIR=$dir/xdg/run" "PG_CONFIG=$bin/pg_config" "PATH=$bin:$PATH")
as_owner() { "${owner[@]}" "$@"; }
port() { sed -n "$1p" "$dir/ports"; }  # 1: monitor, 2: node1, 3: node2, 4: node3
nodes() { echo $(($(wc -l <"$dir/ports") - 1)); }
monitor_uri() { echo "postgres://autoctl_node@127.0.0.1:$(port 1)/pg_auto_failover?sslmode=disable"; }
sql() {  # sql PORT DB STATEMENT...: runs each statement, prints rows unaligned
  local p=$1 db=$2
  shift 2
  local args=()
  for s in "$@"; do args+=(-c "$s"); done
  as_owner psql -h 127.0.0.1 -p "$p" -d "$db" -U postgres -qAt "${args[@]}"
}
state() { as_owner pg_autoctl show state --pgdata "$dir/monitor" 2>/dev/null; }
spawn() {  # spawn NAME ARGS...: pg_autoctl in its own process group; its pid in DIR/NAME.pid
  local name=$1
  shift
  setsid "${owner[@]}" pg_autoctl "$@" >>"$dir/$name.log" 2>&1 </dev/null &
  echo $! >"$dir/$name.pid"
}
signal_group() {  # signal_group SIGNAL NAME: the keeper's process group, then postgres's
  local pid postmaster= children=
  pid=$(cat "$dir/$2.pid" 2>/dev/null) || return 0
  [ -f "$dir/$2/postmaster.pid" ] && postmaster=$(head -1 "$dir/$2/postmaster.pid")
  # Backends and the server's workers run in sessions of their own (postgres calls setsid
  # for each child): a node is all of them. They are listed before anything is signalled:
  # once the postmaster is dead they belong to init, and some (the logger, the monitor's
  # health-check worker) outlive it.
  [ -n "$postmaster" ] && children=$(pgrep -P "$postmaster" 2>/dev/null || true)
  kill "-$1" -- "-$pid" 2>/dev/null || true
  if [ -n "$postmaster" ]; then
    for child in $children; do kill "-$1" "$child" 2>/dev/null || true; done
    kill "-$1" "$postmaster" 2>/dev/null || true
  fi
}
tune_monitor() {
  sql "$(port 1)" pg_auto_failover \
    "ALTER SYSTEM SET pgautofailover.health_check_period = 1000" \
    "ALTER SYSTEM SET pgautofailover.health_check_timeout = 1000" \
    "ALTER SYSTEM SET pgautofailover.health_check_max_retries = 1" \
    "ALTER SYSTEM SET pgautofailover.health_check_retry_delay = 500" \
    "ALTER SYSTEM SET pgautofailover.node_considered_unhealthy_timeout = 2000" \
    "ALTER SYSTEM SET pgautofailover.primary_demote_timeout = 3000" \
    "ALTER SYSTEM SET pgautofailover.startup_grace_period = 2000" \
    "SELECT pg_reload_conf()" >/dev/null
}
healthy() {  # one primary, every other node a secondary
  local now
  now=$(state) || return 1
  echo "$now" | grep -qE '\| +primary \| +primary *$' &&
    [ "$(echo "$now" | grep -cE '\| +secondary \| +secondary *$')" = $(($(nodes) - 1)) ]
}
wait_healthy() {
  local deadline=$((SECONDS + ${1:-120}))
  until healthy; do
    # pg_basebackup of a new standby waits for a spread checkpoint: ask for it now.
    for n in $(seq "$(nodes)"); do sql "$(port $((n + 1)))" postgres "CHECKPOINT" >/dev/null 2>&1 || true; done
    if [ $SECONDS -ge $deadline ]; then
      echo "pg_cluster: no primary and secondary after ${1:-120} s; logs in $dir" >&2
      state >&2 || true
      return 1
    fi
    sleep 0.5
  done
}
node_args() {  # node_args N: pg_autoctl's arguments for node N
  echo --pgctl "$bin/pg_ctl" --pgdata "$dir/node$1" --pgport "$(port $(($1 + 1)))" \
    --hostname 127.0.0.1 --listen 127.0.0.1 --name "node$1"
}

case $cmd in
up)
  mkdir -p "$dir/xdg/config" "$dir/xdg/data" "$dir/xdg/run"
  chmod 700 "$dir/xdg/run"
  printf '%s\n' "${3:?MONITOR_PORT}" "${4:?PORT1}" "${5:?PORT2}" ${6:+"$6"} >"$dir/ports"
  [ "$(id -u)" = 0 ] && chown -R postgres "$dir"
  spawn monitor create monitor --pgctl "$bin/pg_ctl" --pgdata "$dir/monitor" --pgport "$(port 1)" \
    --hostname 127.0.0.1 --auth trust --no-ssl --run
  for _ in $(seq 120); do sql "$(port 1)" pg_auto_failover "SELECT 1" >/dev/null 2>&1 && break; sleep 0.5; done
  tune_monitor
  for n in $(seq "$(nodes)"); do
    # shellcheck disable=SC2046
    spawn "node$n" create postgres $(node_args $n) --monitor "$(monitor_uri)" --auth trust \
      --no-ssl --dbname skimap --run
    # The first node is the primary: the second waits for it before it clones it.
    if [ $n = 1 ]; then
      for _ in $(seq 120); do state | grep -qE 'node1 .*(wait_primary|single|primary)' && break; sleep 0.5; done
    fi
  done
  # With two standbys the monitor raises number_sync_standbys to 1 itself.
  wait_healthy 180
  hosts=
  for n in $(seq "$(nodes)"); do hosts="$hosts${hosts:+,}127.0.0.1:$(port $((n + 1)))"; done
  echo "postgresql://postgres@$hosts/skimap?target_session_attrs=read-write&connect_timeout=2"
  ;;
wait) wait_healthy "${3:-120}" ;;
primary)
  state | awk -F'|' '$7 ~ /^ *primary *$/ || $7 ~ /^ *wait_primary *$/ {gsub(/ /, "", $1); sub(/node/, "", $1); print $1; exit}'
  ;;
kill) signal_group KILL "node${3:?N}" ;;
pause) signal_group STOP "node${3:?N}" ;;
resume) signal_group CONT "node${3:?N}" ;;
start)
  # A killed postgres leaves its pid file; the keeper starts it again from there.
  # shellcheck disable=SC2046
  spawn "node${3:?N}" run --pgdata "$dir/node$3"
  ;;
state) state ;;
down)
  for name in node1 node2 node3 monitor; do signal_group CONT "$name"; signal_group KILL "$name"; done
  # Servers a killed keeper left behind (their own process groups).
  pkill -9 -f -- "-D $dir/" 2>/dev/null || true
  rm -rf "$dir"
  ;;
*) echo "pg_cluster: unknown command $cmd" >&2; exit 2 ;;
esac

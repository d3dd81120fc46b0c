# Sourced by the bench scripts that stream into a local server (stream_cli.sh,
# carve_cost.sh): starts $skimapd (journal on, its default flags otherwise) on a free
# loopback port in a fresh data dir, stops it and removes the dir when the script exits, and
# waits until `skimap maps ls` answers. Needs $skimapd and $skimap; sets port, data_dir,
# server_pid and cli (the CLI with --server).
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
data_dir=$(mktemp -d)
"$skimapd" --address="127.0.0.1:$port" --http_address= --data_dir="$data_dir" \
  >"$data_dir/skimapd.log" 2>&1 &
server_pid=$!
trap 'kill -INT "$server_pid" 2>/dev/null; wait "$server_pid" 2>/dev/null || true; rm -rf "$data_dir"' EXIT
cli=("$skimap" --server="127.0.0.1:$port")
for _ in $(seq 50); do
  "${cli[@]}" maps ls >/dev/null 2>&1 && break
  sleep 0.2
done

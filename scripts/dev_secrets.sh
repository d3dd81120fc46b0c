#!/usr/bin/env bash
# Makes the secrets docker/compose.yaml mounts, for a first deployment or a test:
#   tls_ca        a fresh CA's certificate (give it to clients: --tls_ca)
#   tls_cert      skimapd's certificate, signed by that CA, for the names in NAMES
#   tls_key       its private key
#   auth_tokens   skimapd's token file: one admin and one read token (random, 256 bits)
#   admin.token   the admin token alone (clients: --token_file), and read.token
# The CA's key is deleted once it has signed: make client certificates for mTLS with a CA
# of your own (--tls_client_ca). Keys and tokens are mode 600, owned by OWNER_UID (the
# image's skimap user) when run as root, so the container can read its bind-mounted
# secrets. An existing DIR/tls_key is never overwritten.
# Usage: scripts/dev_secrets.sh [DIR=docker/secrets] [NAMES=localhost,skimapd,127.0.0.1]
#        [OWNER_UID=10001]
set -euo pipefail
dir=${1:-$(dirname "$0")/../docker/secrets}
names=${2:-localhost,skimapd,127.0.0.1}
owner=${3:-10001}
if [[ -e $dir/tls_key ]]; then
  echo "dev_secrets.sh: $dir/tls_key exists; remove the directory's files to make new ones" >&2
  exit 1
fi
mkdir -p "$dir"
chmod 700 "$dir"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
san=""
IFS=, read -ra list <<<"$names"
for n in "${list[@]}"; do
  if [[ $n =~ ^[0-9.]+$ || $n == *:* ]]; then san+="IP:$n,"; else san+="DNS:$n,"; fi
done
umask 077
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 3650 \
  -subj "/CN=skimap secrets CA" -keyout "$tmp/ca.key" -out "$dir/tls_ca" 2>/dev/null
openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj "/CN=${list[0]}" \
  -keyout "$dir/tls_key" -out "$tmp/server.csr" 2>/dev/null
printf '%s\n' "subjectAltName=${san%,}" "basicConstraints=CA:FALSE" \
  "keyUsage=digitalSignature,keyEncipherment" "extendedKeyUsage=serverAuth" >"$tmp/ext"
openssl x509 -req -in "$tmp/server.csr" -CA "$dir/tls_ca" -CAkey "$tmp/ca.key" \
  -CAcreateserial -CAserial "$tmp/ca.srl" -days 825 -extfile "$tmp/ext" \
  -out "$dir/tls_cert" 2>/dev/null
admin=$(openssl rand -hex 32)
read=$(openssl rand -hex 32)
printf '%s\n' "$admin" >"$dir/admin.token"
printf '%s\n' "$read" >"$dir/read.token"
printf '# <token> <role> [<map>,...]: skimapd --auth_tokens_file (SIGHUP reloads it)\n%s admin\n%s read\n' \
  "$admin" "$read" >"$dir/auth_tokens"
chmod 644 "$dir/tls_ca" "$dir/tls_cert"
chmod 600 "$dir/tls_key" "$dir/auth_tokens" "$dir/admin.token" "$dir/read.token"
if [[ $(id -u) == 0 ]]; then
  chown "$owner:$owner" "$dir/tls_key" "$dir/auth_tokens"
fi
echo "dev_secrets.sh: wrote tls_ca, tls_cert, tls_key (for $names), auth_tokens, admin.token, read.token to $dir"

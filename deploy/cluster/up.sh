#!/usr/bin/env bash
# Starts a cluster on this machine, loopback only: PostgreSQL (a fresh
# cluster in a folder of its own), REPLICAS oaipp-server replicas with
# --cluster sharing it, and HAProxy in front routing by x-oaipp-mission.
#
#   bash deploy/cluster/up.sh            # proxy on 127.0.0.1:50051
#   build/client/oaipp-client run client/scenarios/e1.json --server=127.0.0.1:50051
#   bash deploy/cluster/down.sh
#
# Environment: REPLICAS (3), PROXY_PORT (50051), FIRST_REPLICA_PORT (50061;
# replica i listens on FIRST_REPLICA_PORT + i and serves metrics on
# 9470 + i), PG_PORT (55432), CLUSTER_DIR (/tmp/oaipp-cluster: data, logs,
# pid files), BUILD_DIR (./build).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
replicas="${REPLICAS:-3}"
proxy_port="${PROXY_PORT:-50051}"
first_port="${FIRST_REPLICA_PORT:-50061}"
pg_port="${PG_PORT:-55432}"
dir="${CLUSTER_DIR:-/tmp/oaipp-cluster}"
build="${BUILD_DIR:-$root/build}"
pg_bin=/usr/lib/postgresql/15/bin

if [ -e "$dir/haproxy.pid" ]; then
  echo "cluster: one is already up in $dir (bash deploy/cluster/down.sh first)" >&2
  exit 1
fi
bash "$root/deploy/install-deps.sh"
if [ ! -x "$build/server/oaipp-server" ] || [ ! -x "$build/client/oaipp-client" ]; then
  echo "cluster: building oaipp-server and oaipp-client in $build"
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$build" -j "$(nproc)" --target oaipp-server oaipp-client >"$build/cluster-build.log" 2>&1 ||
    { tail -30 "$build/cluster-build.log"; exit 1; }
fi
mkdir -p "$dir/pg"
chown postgres: "$dir/pg"

# PostgreSQL refuses to run as root: it runs as the postgres system user.
as_postgres() { runuser -u postgres -- "$@"; }
if [ ! -d "$dir/pg/data" ]; then
  as_postgres "$pg_bin/initdb" -D "$dir/pg/data" -A trust -U postgres -E UTF8 --locale=C \
    >"$dir/pg/initdb.log" 2>&1 || { tail "$dir/pg/initdb.log"; exit 1; }
fi
as_postgres "$pg_bin/pg_ctl" start -w -t 30 -D "$dir/pg/data" -l "$dir/pg/server.log" \
  -o "-p $pg_port -k $dir/pg -c listen_addresses=127.0.0.1" >/dev/null
as_postgres "$pg_bin/psql" -q -h 127.0.0.1 -p "$pg_port" -U postgres -d postgres -tc \
  "SELECT 1 FROM pg_database WHERE datname = 'oaipp'" | grep -q 1 ||
  as_postgres "$pg_bin/createdb" -h 127.0.0.1 -p "$pg_port" -U postgres oaipp
store="postgresql://postgres@127.0.0.1:$pg_port/oaipp"
echo "cluster: PostgreSQL on 127.0.0.1:$pg_port ($dir/pg)"

servers=""
for i in $(seq 1 "$replicas"); do
  port=$((first_port + i))
  setsid "$build/server/oaipp-server" --cluster --store="$store" --replica_id="replica-$i" --ring_id="$i" \
    --listen="127.0.0.1:$port" --metrics_listen="127.0.0.1:$((9470 + i))" \
    >"$dir/replica-$i.log" 2>&1 </dev/null &
  echo $! >"$dir/replica-$i.pid"
  servers+="    server replica-$i 127.0.0.1:$port id $i"$'\n'
  echo "cluster: replica-$i on 127.0.0.1:$port (log $dir/replica-$i.log)"
done

sed -e "s|@LISTEN@|127.0.0.1:$proxy_port|" "$root/deploy/cluster/haproxy.cfg.in" |
  awk -v servers="$servers" '{ if ($0 == "@SERVERS@") printf "%s", servers; else print }' \
    >"$dir/haproxy.cfg"
haproxy -c -q -f "$dir/haproxy.cfg"
haproxy -D -f "$dir/haproxy.cfg" -p "$dir/haproxy.pid"
echo "cluster: HAProxy on 127.0.0.1:$proxy_port ($dir/haproxy.cfg)"

for _ in $(seq 1 100); do
  if "$build/client/oaipp-client" health --server="127.0.0.1:$proxy_port" >/dev/null 2>&1; then
    echo "cluster: SERVING through the proxy at 127.0.0.1:$proxy_port"
    exit 0
  fi
  sleep 0.2
done
echo "cluster: not serving after 20 s; see $dir/*.log" >&2
exit 1

#!/usr/bin/env bash
# Stops what deploy/cluster/up.sh started: the proxy, the replicas (SIGTERM:
# they finish their calls and write pending snapshots) and PostgreSQL, then
# removes CLUSTER_DIR (/tmp/oaipp-cluster) unless KEEP=1.
set -uo pipefail
dir="${CLUSTER_DIR:-/tmp/oaipp-cluster}"
[ -d "$dir" ] || { echo "cluster: nothing in $dir"; exit 0; }
stop() {  # stop PIDFILE: SIGTERM, then SIGKILL after 15 s
  local pid
  pid="$(cat "$1" 2>/dev/null)" || return 0
  kill "$pid" 2>/dev/null || { rm -f "$1"; return 0; }
  for _ in $(seq 1 150); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  kill -9 "$pid" 2>/dev/null
  rm -f "$1"
}
stop "$dir/haproxy.pid"
for pidfile in "$dir"/replica-*.pid; do [ -e "$pidfile" ] && stop "$pidfile"; done
if [ -d "$dir/pg/data" ]; then
  runuser -u postgres -- /usr/lib/postgresql/15/bin/pg_ctl stop -w -t 30 -m fast \
    -D "$dir/pg/data" >/dev/null 2>&1
fi
if [ "${KEEP:-0}" != "1" ]; then rm -rf "$dir"; fi
echo "cluster: down"

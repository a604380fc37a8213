#!/usr/bin/env bash
# Brings up compose.yaml (server + PostgreSQL 15 + Prometheus) with
# podman-compose on the host's loopback, and checks that the server is
# SERVING on the PostgreSQL store, keeps a mission there across a restart,
# and that Prometheus scrapes its metrics. Brings everything down again,
# volumes and network included, whatever happens.
#
#   sudo deploy/container/compose-test.sh
#
# Environment: OAIPP_CLIENT (host client, default build/client/oaipp-client,
# relative to the repository root), OAIPP_IMAGE (server image tag, default
# localhost/oaipp:latest).
set -euo pipefail

SECONDS=0
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$repo"
# shellcheck source-path=SCRIPTDIR source=podman-env.sh
. deploy/container/podman-env.sh

export OAIPP_IMAGE=${OAIPP_IMAGE:-localhost/oaipp:latest}
client=${OAIPP_CLIENT:-build/client/oaipp-client}
case "$client" in /*) ;; *) client="$repo/$client" ;; esac

if [ "$(id -u)" -ne 0 ]; then
  echo "compose-test.sh: run as root" >&2
  exit 1
fi
if [ ! -x "$client" ]; then
  echo "compose-test.sh: no host client at $client (build it, or set OAIPP_CLIENT)" >&2
  exit 1
fi


project=oaipp-compose-test-$$
compose_file=deploy/container/compose.yaml
tmp=$(mktemp -d /tmp/oaipp-compose-test.XXXXXX)
up=0

# podman-compose prints every podman command it runs; its log goes to a file
# and only failures show it.
compose() {
  podman-compose -p "$project" -f "$compose_file" "$@" >>"$tmp/compose.log" 2>&1
}

finish() {
  local rc=$?
  if [ "$up" = 1 ]; then
    if [ "$failed" = 1 ] || [ "$rc" != 0 ]; then
      local c
      for c in postgres server prometheus; do
        echo "--- ${project}_${c}_1 log (last 15 lines)"
        pm logs --tail 15 "${project}_${c}_1" 2>&1 | oaipp_quiet_systemd_stdout || true
      done
    fi
    compose down -v -t 10 || echo "podman-compose down failed; see $tmp/compose.log"
    # podman-compose 1.0 leaves the project's network behind.
    pm network rm -f "${project}_default" >/dev/null 2>&1 || true
    local v
    for v in $(pm volume ls -q --filter "label=io.podman.compose.project=$project"); do
      pm volume rm -f "$v" >/dev/null 2>&1 || true
    done
    echo "brought down: containers $(pm ps -a -q --filter "label=io.podman.compose.project=$project" | wc -l), volumes $(pm volume ls -q --filter "label=io.podman.compose.project=$project" | wc -l) left"
  fi
  rm -rf "$tmp"
  oaipp_podman_env_cleanup
  oaipp_print_summary "$rc"
}
trap finish EXIT
oaipp_quiet_systemd_stdout() { grep -v 'unable to get systemd connection' || true; }

wait_serving() {
  local what=$1 limit=$2 t0=$SECONDS
  while [ $((SECONDS - t0)) -lt "$limit" ]; do
    if timeout 10 "$client" health --server="127.0.0.1:$grpc_port" >"$tmp/health.out" 2>&1; then
      pass "$what: SERVING after $((SECONDS - t0)) s ($(cat "$tmp/health.out"))"
      return 0
    fi
    sleep 1
  done
  fail "$what: not SERVING within $limit s: $(tail -n 1 "$tmp/health.out")"
  return 1
}

# One instant query to Prometheus' HTTP API; prints the first sample's value.
prom_value() {
  curl -fsS --max-time 5 "http://127.0.0.1:$prom_port/api/v1/query" --data-urlencode "query=$1" |
    python3 -c 'import json,sys; r=json.load(sys.stdin)["data"]["result"]; print(r[0]["value"][1] if r else "")'
}

echo "=== packages and podman"
# dnsname: containers on the compose network find each other by service name.
oaipp_need_packages podman runc debootstrap podman-compose golang-github-containernetworking-plugin-dnsname
oaipp_podman_env
compose_version=$(podman-compose version 2>/dev/null | grep -i 'podman-compose' || true)
echo "podman $(pm version --format '{{.Client.Version}}'), ${compose_version%%$'\n'*}"

echo "=== images"
timeout 1800 deploy/container/make-base-image.sh
t0=$SECONDS
# build, not just up: up builds only images that do not exist yet, so an
# edited Containerfile would not be picked up. --format docker keeps the
# HEALTHCHECKs; nice because the server build competes with other work.
if ! timeout 3600 nice -n 19 podman-compose -p "$project" -f "$compose_file" \
  --podman-build-args='--format docker' build >"$tmp/build.log" 2>&1; then
  tail -n 40 "$tmp/build.log"
  fail "image build"
  exit 1
fi
pass "images built in $((SECONDS - t0)) s ($(grep -c -- '--> Using cache' "$tmp/build.log" || true) steps from cache)"
pm images --format '{{.Repository}}:{{.Tag}} {{.Size}}' |
  grep -E "^(localhost/oaipp-postgres:15|localhost/oaipp-prometheus:latest|${OAIPP_IMAGE}) " || true

echo "=== up"
grpc_port=$(oaipp_free_port)
prom_port=$(oaipp_free_port)
export OAIPP_GRPC_PORT=$grpc_port OAIPP_PROMETHEUS_PORT=$prom_port
# A password of this run only; the containers are gone when it ends.
OAIPP_PG_PASSWORD=$(head -c 18 /dev/urandom | base64 | tr -d '/+=')
export OAIPP_PG_PASSWORD
up=1
if ! timeout 300 podman-compose -p "$project" -f "$compose_file" up -d --no-build >"$tmp/up.log" 2>&1; then
  grep -v "^\[\|^podman \|systemd connection" "$tmp/up.log" | tail -n 20
  fail "podman-compose up"
  exit 1
fi
pm ps -a --filter "label=io.podman.compose.project=$project" --format '{{.Names}} {{.Status}} {{.Ports}}'
echo "project $project: gRPC on 127.0.0.1:$grpc_port, Prometheus on 127.0.0.1:$prom_port"

wait_serving "server" 120 || exit 1
server_log() { pm logs "${project}_server_1" >"$tmp/server.log" 2>&1 || true; }
server_log
if grep -q 'store: postgresql postgresql://oaipp@postgres:5432/oaipp' "$tmp/server.log"; then
  pass "server store: $(grep -o 'store: postgresql .*' "$tmp/server.log" | head -n 1)"
else
  fail "server is not on the PostgreSQL store: $(grep 'store:' "$tmp/server.log" | head -n 1)"
fi
for c in server postgres; do
  if pm healthcheck run "${project}_${c}_1" >/dev/null 2>&1; then
    pass "HEALTHCHECK of $c: $(pm inspect --format '{{.State.Health.Status}}' "${project}_${c}_1")"
  else
    fail "HEALTHCHECK of $c"
  fi
done

echo "=== a mission into PostgreSQL"
if timeout 600 "$client" run client/scenarios/e1.json --server="127.0.0.1:$grpc_port" --keep \
  --out="$tmp/e1" >"$tmp/run.out" 2>&1; then
  pass "E1 flown: $(grep '^done:' "$tmp/run.out" | cut -c1-90)"
else
  tail -n 5 "$tmp/run.out"
  fail "E1 run"
  exit 1
fi
server_log
mission=$(grep -o 'missions/[a-z0-9-]*' "$tmp/run.out" | head -n 1 || true)
if [ -z "$mission" ]; then
  mission=$(grep -o 'event=created name=missions/[a-z0-9-]*' "$tmp/server.log" | tail -n 1 | sed 's/.*name=//' || true)
fi
rows=$(pm exec "${project}_postgres_1" psql -d oaipp -Atc \
  "SELECT (SELECT count(*) FROM missions) || ' missions, ' || (SELECT count(*) FROM records) || ' records'" 2>&1 |
  oaipp_quiet_systemd_stdout)
case "$rows" in
  "0 missions"* | "" | *ERROR*) fail "PostgreSQL tables: $rows" ;;
  *) pass "PostgreSQL holds $rows" ;;
esac
pm restart -t 20 "${project}_server_1" >/dev/null 2> >(oaipp_quiet_systemd)
wait_serving "server after restart" 120 || exit 1
if [ -n "$mission" ] && "$client" map "$mission" --server="127.0.0.1:$grpc_port" --png="$tmp/map.png" >"$tmp/map.out" 2>&1; then
  pass "$mission back from PostgreSQL after a server restart: $(cat "$tmp/map.out")"
else
  fail "mission '$mission' after restart: $(cat "$tmp/map.out" 2>/dev/null)"
fi

echo "=== Prometheus"
t0=$SECONDS
up_value=
while [ $((SECONDS - t0)) -lt 90 ]; do
  up_value=$(prom_value 'up{job="oaipp",instance="server:9464"}' 2>/dev/null || true)
  [ "$up_value" = 1 ] && break
  sleep 2
done
if [ "$up_value" = 1 ]; then
  pass "Prometheus scrapes server:9464: up{job=\"oaipp\"} = 1 after $((SECONDS - t0)) s"
  series=$(prom_value 'count({job="oaipp",__name__=~"oaipp_.*"})' || true)
  pass "Prometheus holds ${series:-0} oaipp_ series of the server"
else
  fail "Prometheus: up{job=\"oaipp\"} = '${up_value}' after 90 s"
fi

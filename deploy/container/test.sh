#!/usr/bin/env bash
# End-to-end test of the service images: builds the server image and the
# client image (with their debootstrap base), checks the server image's size
# (at most 250 MB), starts it with a named volume and the gRPC and metrics
# ports published on 127.0.0.1 only, checks health with the client image and
# with the server image's own HEALTHCHECK, checks that the image's default
# refuses to start without a tenants' token file and that a call without a
# token is refused, flies the E1 scenario with the client image (with a
# token), restarts the server container and checks that the mission came
# back from the SQLite store on the volume. The container and the volume
# are removed whatever happens.
#
#   sudo deploy/container/test.sh
#
# Environment:
#   OAIPP_IMAGE         the server image's tag (default localhost/oaipp:latest)
#   OAIPP_CLIENT_IMAGE  the client image's tag (default
#                       localhost/oaipp-client:latest)
#   JOBS                compile jobs in the image build (default 2)
set -euo pipefail

SECONDS=0
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$repo"
# shellcheck source-path=SCRIPTDIR source=podman-env.sh
. deploy/container/podman-env.sh

IMAGE=${OAIPP_IMAGE:-localhost/oaipp:latest}
CLIENT_IMAGE=${OAIPP_CLIENT_IMAGE:-localhost/oaipp-client:latest}
JOBS=${JOBS:-2}
max_server_mb=250

if [ "$(id -u)" -ne 0 ]; then
  echo "test.sh: run as root (rootful podman; rootless needs subuids this host lacks)" >&2
  exit 1
fi


name=oaipp-test-$$
volume=oaipp-test-data-$$
tmp=$(mktemp -d /tmp/oaipp-container-test.XXXXXX)
started=0

finish() {
  local rc=$?
  if [ "$started" = 1 ]; then
    if [ "$failed" = 1 ] || [ "$rc" != 0 ]; then
      echo "--- container log (last 40 lines)"
      pm logs --tail 40 "$name" 2>&1 || true
    fi
    pm rm -f -t 5 "$name" >/dev/null 2>&1 || true
  fi
  pm volume rm -f "$volume" >/dev/null 2>&1 || true
  rm -rf "$tmp"
  oaipp_podman_env_cleanup
  oaipp_print_summary "$rc"
}
trap finish EXIT

# oaipp-client from the client image, on the host's network (so 127.0.0.1
# is the published port), with the token if one is set and $tmp/out as
# /out for what it writes. The first argument is a time limit in seconds.
client() {
  local limit=$1
  shift
  timeout "$limit" podman --runtime /usr/sbin/runc run --rm --network host \
    ${OAIPP_TOKEN:+-e OAIPP_TOKEN} -v "$tmp/out:/out" "$CLIENT_IMAGE" "$@"
}

# Polls the server with the client image until it answers SERVING; fails if
# the container exits or the time runs out.
wait_serving() {
  local what=$1 limit=$2 t0=$SECONDS
  while [ $((SECONDS - t0)) -lt "$limit" ]; do
    if [ "$(pm inspect --format '{{.State.Running}}' "$name" 2>/dev/null)" != true ]; then
      fail "$what: container is not running"
      return 1
    fi
    if client 20 health --server="127.0.0.1:$port" >"$tmp/health.out" 2>&1; then
      pass "$what: SERVING after $((SECONDS - t0)) s ($(cat "$tmp/health.out"))"
      return 0
    fi
    sleep 1
  done
  fail "$what: not SERVING within $limit s: $(tail -n 1 "$tmp/health.out")"
  return 1
}

# Runs the image's HEALTHCHECK now and reports its exit and what the check
# printed (the last entry of the container's health log).
healthcheck() {
  local what=$1 rc=0 out
  pm healthcheck run "$name" >"$tmp/hc.out" 2>&1 || rc=$?
  out=$(pm inspect --format '{{with .State.Health}}{{range .Log}}{{println .Output}}{{end}}{{end}}' "$name" 2>/dev/null |
    grep -v '^$' | tail -n 1 || true)
  if [ "$rc" = 0 ]; then
    pass "$what: $(tr '\n' ' ' <"$tmp/hc.out")exit 0, check printed: $out"
  else
    fail "$what: exit $rc: $(tr '\n' ' ' <"$tmp/hc.out") $out"
  fi
}

echo "=== packages and podman"
oaipp_need_packages podman runc debootstrap openssl
oaipp_podman_env
echo "podman $(pm version --format '{{.Client.Version}}'), runtime runc $(runc --version | awk 'NR==1{print $3}')"

echo "=== base image"
timeout 1800 deploy/container/make-base-image.sh

build_image() {
  local what=$1 tag=$2 t0=$SECONDS
  shift 2
  echo "=== $what image build ($tag, JOBS=$JOBS; log in $tmp/build-$what.log while it runs)"
  # nice: the image build must not starve other work on a small machine.
  if ! timeout 3600 nice -n 19 podman --runtime /usr/sbin/runc build --format docker \
    -f deploy/container/Containerfile --build-arg JOBS="$JOBS" "$@" -t "$tag" . \
    >"$tmp/build-$what.log" 2>&1; then
    tail -n 40 "$tmp/build-$what.log"
    fail "$what image build (see the log above)"
    exit 1
  fi
  local cached steps
  cached=$(grep -c -- '--> Using cache' "$tmp/build-$what.log" || true)
  steps=$(grep -c '^\[[0-9]/[0-9]\] STEP' "$tmp/build-$what.log" || true)
  pass "$what image build in $((SECONDS - t0)) s ($steps steps, $cached from cache)"
}
build_image server "$IMAGE"
build_image client "$CLIENT_IMAGE" --target client
size=$(pm image inspect --format '{{.Size}}' "$IMAGE")
client_size=$(pm image inspect --format '{{.Size}}' "$CLIENT_IMAGE")
pm images --filter reference="$IMAGE" --filter reference="$CLIENT_IMAGE" \
  --filter reference=localhost/oaipp-base --format '{{.Repository}}:{{.Tag}} {{.ID}} {{.Size}}'
if [ "$size" -le $((max_server_mb * 1000000)) ]; then
  pass "server image size: $((size / 1000000)) MB ($size bytes; at most $max_server_mb MB)"
else
  fail "server image size: $((size / 1000000)) MB ($size bytes), over $max_server_mb MB"
fi
echo "client image size: $((client_size / 1000000)) MB ($client_size bytes)"
if pm run --rm --entrypoint /bin/sh "$IMAGE" -c \
  'ls /usr/lib/*/libopencv_imgcodecs* /usr/lib/*/libopencv_videoio* /usr/lib/*/libgdal* 2>/dev/null' |
  grep -q .; then
  fail "the server image carries OpenCV's codecs, video or GDAL"
else
  pass "the server image carries no OpenCV imgcodecs, videoio or GDAL"
fi
health_cfg=$(pm image inspect --format '{{json .HealthCheck}}' "$IMAGE")
if [ "$health_cfg" = null ] || [ -z "$health_cfg" ]; then
  fail "image has a HEALTHCHECK"
else
  pass "image has a HEALTHCHECK: $health_cfg"
fi
user=$(pm image inspect --format '{{.Config.User}}' "$IMAGE")
if [ "$user" = oaipp:oaipp ]; then pass "image runs as $user"; else fail "image user is '$user', not oaipp:oaipp"; fi
install -d -m 0777 "$tmp/out"

echo "=== no token file"
# The image's default serves nobody without tenants: it must not start.
rc=0
timeout 60 podman --runtime /usr/sbin/runc run --rm "$IMAGE" >"$tmp/no-tokens.out" 2>&1 || rc=$?
if [ "$rc" != 0 ] && grep -q -- '--token_file' "$tmp/no-tokens.out"; then
  pass "without /etc/oaipp/tokens/tokens the server exits $rc: $(grep -o -- '--token_file.*' "$tmp/no-tokens.out" | head -n 1 | cut -c1-120)"
else
  fail "without a token file: exit $rc, $(tail -n 2 "$tmp/no-tokens.out")"
fi

echo "=== start"
port=$(oaipp_free_port)
metrics_port=$(oaipp_free_port)
# One tenant; the file holds the token's hash only, readable by the
# image's user.
token=$(openssl rand -hex 24)
printf 'container-test %s\n' "$(printf %s "$token" | sha256sum | cut -d' ' -f1)" >"$tmp/tokens"
chmod 0644 "$tmp/tokens"
pm volume create "$volume" >/dev/null
started=1
pm run -d --name "$name" -v "$volume:/var/lib/oaipp" -v "$tmp/tokens:/etc/oaipp/tokens/tokens:ro" \
  -p "127.0.0.1:$port:50051" -p "127.0.0.1:$metrics_port:9464" "$IMAGE" >/dev/null 2> >(oaipp_quiet_systemd)
echo "container $name: gRPC on 127.0.0.1:$port, metrics on 127.0.0.1:$metrics_port, volume $volume"
wait_serving "start" 90 || exit 1

healthcheck "HEALTHCHECK in the container"
state=$(pm inspect --format '{{.State.Health.Status}}' "$name" 2>/dev/null || true)
if [ "$state" = healthy ]; then pass "container health state: $state"; else fail "container health state: '$state'"; fi

if timeout 10 curl -fsS "http://127.0.0.1:$metrics_port/metrics" >"$tmp/metrics.txt" &&
  grep -q '^oaipp_' "$tmp/metrics.txt"; then
  pass "metrics on 127.0.0.1:$metrics_port ($(grep -c '^oaipp_' "$tmp/metrics.txt") oaipp_ samples)"
else
  fail "metrics on 127.0.0.1:$metrics_port"
fi
pm logs "$name" >"$tmp/server.log" 2>&1
if grep -q 'store: sqlite file /var/lib/oaipp/' "$tmp/server.log"; then
  pass "$(grep -o 'store: sqlite.*' "$tmp/server.log" | head -n 1)"
else
  fail "server did not open the sqlite store on the volume: $(grep 'store:' "$tmp/server.log" | head -n 1)"
fi

echo "=== tokens"
rc=0
client 30 map missions/none --png=/out/none.png --server="127.0.0.1:$port" >"$tmp/anon.out" 2>&1 || rc=$?
if [ "$rc" != 0 ] && grep -qi 'unauthenticated' "$tmp/anon.out"; then
  pass "a call without a token is refused: $(head -n 1 "$tmp/anon.out" | cut -c1-100)"
else
  fail "a call without a token: exit $rc, $(head -n 2 "$tmp/anon.out")"
fi
# The client reads it from the environment (not the process list), which
# client() passes into its container.
export OAIPP_TOKEN=$token

echo "=== E1 mission"
t0=$SECONDS
if client 1200 run /usr/share/oaipp/scenarios/e1.json --server="127.0.0.1:$port" --keep \
  --out=/out/e1 >"$tmp/run.out" 2>&1; then
  sed 's/^/  /' "$tmp/run.out"
  pass "E1 flown in $((SECONDS - t0)) s: $(grep '^done:' "$tmp/run.out" | cut -c1-100)"
else
  rc=$?
  sed 's/^/  /' "$tmp/run.out"
  fail "E1 run exited $rc"
  exit 1
fi
# The name of the kept mission: from the client if it prints it, else from
# the server's log line for the creation.
mission=$(grep -o 'missions/[a-z0-9-]*' "$tmp/run.out" | head -n 1 || true)
if [ -z "$mission" ]; then
  mission=$(pm logs "$name" 2>&1 | grep -o 'event=created name=missions/[a-z0-9-]*' | tail -n 1 |
    sed 's/.*name=//' || true)
fi
if [ -z "$mission" ]; then
  fail "mission name of the run not found"
  exit 1
fi
if client 60 map "$mission" --server="127.0.0.1:$port" --png=/out/before.png >"$tmp/map1.out" 2>&1; then
  pass "$mission readable before restart: $(cat "$tmp/map1.out")"
else
  fail "$mission before restart: $(cat "$tmp/map1.out")"
fi

echo "=== restart"
t0=$SECONDS
pm restart -t 20 "$name" >/dev/null 2> >(oaipp_quiet_systemd)
echo "restarted in $((SECONDS - t0)) s"
wait_serving "after restart" 120 || exit 1
recovered=$(pm logs "$name" 2>&1 | grep -o 'store: recovered [0-9]* missions.*' | tail -n 1 || true)
echo "server log: $recovered"
if client 60 map "$mission" --server="127.0.0.1:$port" --png=/out/after.png >"$tmp/map2.out" 2>&1 &&
  [ -s "$tmp/out/after.png" ]; then
  trace_before=$(grep -o 'Tr(P) = [0-9.]*' "$tmp/map1.out" || true)
  trace_after=$(grep -o 'Tr(P) = [0-9.]*' "$tmp/map2.out" || true)
  if [ -n "$trace_after" ] && [ "$trace_before" = "$trace_after" ]; then
    pass "$mission survived the restart with its map ($trace_after, as before)"
  else
    fail "$mission after restart: '$trace_after', before: '$trace_before'"
  fi
else
  fail "$mission after restart: $(cat "$tmp/map2.out")"
fi
healthcheck "HEALTHCHECK after restart"

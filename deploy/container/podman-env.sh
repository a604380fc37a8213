# shellcheck shell=bash
# Sourced by the scripts in this folder: the podman set-up that works on a
# Debian 12 host running as root without systemd.
#
# default_ulimits = []: as root podman raises a container's open-files limit
# to 1048576, above this host's hard limit (20000), which it may not raise,
# so every start fails with "error setting rlimit type 7: operation not
# permitted". runc: crun fails to start containers here. CONTAINERS_CONF
# points at a private file so the host's /etc/containers stays as it was.

# Installs the Debian packages named when any is missing (root only).
oaipp_need_packages() {
  local missing=() p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "need root to install: ${missing[*]}" >&2
    return 1
  fi
  echo "installing: ${missing[*]}"
  DEBIAN_FRONTEND=noninteractive apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

# Writes the containers.conf and exports CONTAINERS_CONF, unless the caller
# already gave one. The file is removed by oaipp_podman_env_cleanup.
oaipp_podman_env() {
  if [ -z "${CONTAINERS_CONF:-}" ]; then
    OAIPP_CONTAINERS_CONF=$(mktemp /tmp/oaipp-containers.XXXXXX.conf)
    cat >"$OAIPP_CONTAINERS_CONF" <<'CONF'
[containers]
default_ulimits = []

[engine]
runtime = "runc"
CONF
    export CONTAINERS_CONF=$OAIPP_CONTAINERS_CONF
  fi
}

oaipp_podman_env_cleanup() {
  if [ -n "${OAIPP_CONTAINERS_CONF:-}" ]; then rm -f "$OAIPP_CONTAINERS_CONF"; fi
}

# Every podman call goes through here so that the runtime is runc even where
# containers.conf is not read (podman build's own runtime lookup).
pm() { podman --runtime /usr/sbin/runc "$@"; }

# A port nothing on the host listens on, below the ephemeral range.
oaipp_free_port() {
  local port
  for _ in $(seq 1 200); do
    port=$((20000 + RANDOM % 12000))
    if [ -z "$(ss -Htln "sport = :$port")" ]; then
      echo "$port"
      return 0
    fi
  done
  echo "no free port found" >&2
  return 1
}

# podman without systemd cannot set up the timer that runs a HEALTHCHECK
# every interval and logs an error on every start and stop; the check itself
# still runs with `podman healthcheck run`, which the tests use. A filter
# for stderr that drops only those lines.
oaipp_quiet_systemd() { grep -v 'unable to get systemd connection' >&2 || true; }

# A test script's checks: each PASS / FAIL line is printed and kept for the
# summary; one FAIL makes the script fail at its end.
results=()
failed=0
pass() { results+=("PASS $*"); echo "PASS $*"; }
fail() { results+=("FAIL $*"); echo "FAIL $*"; failed=1; }

# The end of a test script: the PASS / FAIL lines it gathered in `results`
# (global), the time, and exit 1 when a check failed (`failed`, global)
# although the script itself ran to its end (rc 0).
oaipp_print_summary() {
  local rc="$1" line
  if [ "$rc" != 0 ] && [ "$failed" = 0 ]; then results+=("FAIL stopped early (exit $rc)"); fi
  echo "--- summary"
  for line in "${results[@]}"; do echo "$line"; done
  echo "total time: ${SECONDS} s"
  if [ "$rc" = 0 ] && [ "$failed" = 1 ]; then exit 1; fi
}

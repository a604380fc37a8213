#!/usr/bin/env bash
# Makes localhost/oaipp-base:bookworm, a minimal Debian 12 image, with
# debootstrap from the Debian mirror this host already uses: there is no
# image registry to pull debian:bookworm from, and a base built from the
# host's own mirror keeps the image's packages the same versions as the
# host's. Skips all work when the image exists (OAIPP_BASE_REBUILD=1 forces
# a new one).
#
#   sudo deploy/container/make-base-image.sh
set -euo pipefail

IMAGE=${OAIPP_BASE_IMAGE:-localhost/oaipp-base:bookworm}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source-path=SCRIPTDIR source=podman-env.sh
. "$here/podman-env.sh"

oaipp_need_packages podman runc debootstrap
oaipp_podman_env
rootfs=
cleanup() {
  if [ -n "$rootfs" ]; then rm -rf "$rootfs"; fi
  oaipp_podman_env_cleanup
}
trap cleanup EXIT

if [ "${OAIPP_BASE_REBUILD:-0}" != 1 ] && pm image exists "$IMAGE"; then
  echo "base image $IMAGE exists"
  exit 0
fi

# The URI of the host's source for SUITE, from deb822 .sources files or
# one-line .list entries.
host_mirror() {
  local suite=$1 f
  for f in /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    # deb822 paragraphs are blank-line separated; pick the one whose Suites
    # lists the suite.
    awk -v suite="$suite" '
      BEGIN { RS = ""; FS = "\n" }
      {
        uri = ""; hit = 0
        for (i = 1; i <= NF; i++) {
          if ($i ~ /^URIs:/) { split($i, a, /[ \t]+/); uri = a[2] }
          if ($i ~ /^Suites:/) { n = split($i, s, /[ \t]+/); for (j = 2; j <= n; j++) if (s[j] == suite) hit = 1 }
        }
        if (hit && uri != "") { print uri; exit }
      }' "$f"
  done | head -n1
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [ -f "$f" ] || continue
    awk -v suite="$suite" '$1 == "deb" { for (i = 2; i <= NF; i++) if ($i !~ /^\[/ && $i ~ /:\/\//) { if ($(i+1) == suite) print $i; break } }' "$f"
  done | head -n1
}

mirror=$(host_mirror bookworm | head -n1)
security=$(host_mirror bookworm-security | head -n1)
mirror=${mirror:-http://deb.debian.org/debian}
security=${security:-http://deb.debian.org/debian-security}
echo "base image: debootstrap bookworm from $mirror (security: $security)"

rootfs=$(mktemp -d /var/tmp/oaipp-rootfs.XXXXXX)
start=$(date +%s)
# minbase: dpkg, apt and the essential set; everything else comes from the
# Containerfiles' own apt-get installs.
debootstrap --variant=minbase bookworm "$rootfs" "$mirror" >"$rootfs.log" 2>&1 || {
  tail -n 30 "$rootfs.log" >&2
  rm -f "$rootfs.log"
  exit 1
}
rm -f "$rootfs.log"

# Point apt in the image at the same mirror as the host, with updates and
# security like the host, so that image builds get the same fixes.
rm -f "$rootfs/etc/apt/sources.list"
cat >"$rootfs/etc/apt/sources.list.d/debian.sources" <<SOURCES
Types: deb
URIs: $mirror
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: $security
Suites: bookworm-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SOURCES
# A mirror that serves a frozen snapshot has Release files past their
# Valid-Until date; where the host's apt accepts that, the image's must too.
if apt-config dump | grep -q '^Acquire::Check-Valid-Until "false"'; then
  echo 'Acquire::Check-Valid-Until "false";' >"$rootfs/etc/apt/apt.conf.d/90mirror-snapshot"
fi
cat >"$rootfs/etc/apt/apt.conf.d/90container" <<'APT'
APT::Install-Recommends "false";
APT::Install-Suggests "false";
Acquire::Languages "none";
APT
# Package scripts must not start daemons during image builds (there is no
# init to run them, and a build that starts postgres would hang or fail).
printf '#!/bin/sh\nexit 101\n' >"$rootfs/usr/sbin/policy-rc.d"
chmod 0755 "$rootfs/usr/sbin/policy-rc.d"
# No manuals, translations or docs in a service image (the copyright files
# stay); the dpkg filter keeps later installs from bringing them back.
cat >"$rootfs/etc/dpkg/dpkg.cfg.d/90container-nodoc" <<'DPKG'
path-exclude=/usr/share/doc/*
path-include=/usr/share/doc/*/copyright
path-exclude=/usr/share/man/*
path-exclude=/usr/share/info/*
path-exclude=/usr/share/locale/*
path-include=/usr/share/locale/locale.alias
path-exclude=/usr/share/lintian/*
DPKG
find "$rootfs/usr/share/doc" -mindepth 1 -not -name copyright -not -type d -delete
find "$rootfs/usr/share/doc" -mindepth 1 -type d -empty -delete
find "$rootfs/usr/share/locale" -mindepth 1 -maxdepth 1 -not -name locale.alias -exec rm -rf {} +
rm -rf "$rootfs"/usr/share/man/* "$rootfs"/usr/share/info/* "$rootfs"/usr/share/lintian/*
# Images are rebuilt, not upgraded: the lists and downloaded .debs only add size.
rm -rf "$rootfs"/var/lib/apt/lists/* "$rootfs"/var/cache/apt/*.bin "$rootfs"/var/cache/apt/archives/*.deb \
  "$rootfs"/var/log/*.log "$rootfs"/var/log/apt/*

old=$(pm image inspect --format '{{.Id}}' "$IMAGE" 2>/dev/null || true)
tar --numeric-owner -C "$rootfs" -c . |
  pm import --quiet --change 'CMD ["/bin/bash"]' --change 'ENV LANG=C.UTF-8' - "$IMAGE" >/dev/null
# A replaced base would stay behind untagged; it goes unless an image or a
# container still uses it.
if [ -n "$old" ]; then pm rmi "$old" >/dev/null 2>&1 || true; fi
echo "base image $IMAGE made in $(($(date +%s) - start)) s ($(pm image inspect --format '{{.Size}}' "$IMAGE") bytes)"

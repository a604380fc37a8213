#!/usr/bin/env bash
# Sets up everything on a fresh Debian 12 machine (as root), builds the
# server and the client, starts oaipp-server on loopback, flies the E1
# scenario against it (client/scenarios/e1.json) and stops the server.
#   bash deploy/run.sh                         # E1, results in out/e1 (frames in out/e1/frames)
#   bash deploy/run.sh client/scenarios/X.json # another scenario
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
scenario="${1:-$root/client/scenarios/e1.json}"
address="127.0.0.1:${OAIPP_PORT:-50051}"

label=run
source "$root/deploy/serve.sh"
name="$(basename "$scenario" .json)"
"$build/client/oaipp-client" run "$scenario" --server="$address" --frames="out/$name/frames"

#!/usr/bin/env bash
# Who may include whom (README, "Modules"): fails, naming the file and the
# line, when a source includes a module it must not depend on.
#   bash tests/check_layering.sh [repository root]
set -uo pipefail
root="${1:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}"
cd "$root" || exit 2
status=0

# forbid DIR REGEX WHY: no #include line under DIR may match REGEX.
forbid() {
  local dir="$1" regex="$2" why="$3" hits
  hits=$(grep -rnE "^[[:space:]]*#[[:space:]]*include[[:space:]]*[<\"]($regex)" "$dir" \
           --include='*.h' --include='*.cc' 2>/dev/null)
  if [ -n "$hits" ]; then
    printf 'layering: %s must not include %s (%s):\n%s\n' "$dir/" "$regex" "$why" "$hits"
    status=1
  fi
}

forbid core   'api/|server/|client/|sim/|render/|oaipp/v1/|grpc|google/protobuf' \
  'the method knows nothing of the service'
forbid api    'server/|client/|sim/|render/|opencv' 'conversion only: core and the proto'
forbid render 'api/|server/|client/|sim/|oaipp/v1/|grpc|google/protobuf' \
  'plain shapes in, image out'
forbid sim    'server/|client/' 'the simulated world reads specs through api/'
forbid client 'server/' 'clients talk to the server over the API only'
forbid server 'client/|sim/' 'the server does not link the simulation'
for m in core api render sim client; do
  forbid "$m" 'oaipp/store/' 'the snapshot format is the server'"'"'s own'
done

if [ "$status" -eq 0 ]; then echo "layering: every module includes only what it may"; fi
exit "$status"

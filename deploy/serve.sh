# Sourced by run.sh and experiments.sh: installs the Debian packages, builds
# oaipp-server and oaipp-client in $build, starts the server on $address and
# stops it when the calling script exits. Expects $root, $build, $address
# and $label (for the progress line) to be set.
bash "$root/deploy/install-deps.sh"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
echo "$label: building oaipp-server and oaipp-client"
cmake --build "$build" -j "$(nproc)" --target oaipp-server oaipp-client >/dev/null

source "$root/deploy/process-env.sh"
# Missions are kept in $OAIPP_DATA_DIR (default ./data, the embedded SQLite
# store): a run that is cut short can be looked at after a restart.
"$build/server/oaipp-server" --listen="$address" --metrics_listen= --log_level=warn \
  --data_dir="${OAIPP_DATA_DIR:-$root/data}" &
server=$!
trap 'kill "$server" 2>/dev/null; wait "$server" 2>/dev/null || true' EXIT
cd "$root"

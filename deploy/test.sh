#!/usr/bin/env bash
# Sets up everything on a fresh Debian 12 machine (as root), builds the
# project and runs the whole test suite with ctest.
#   bash deploy/test.sh            # build dir: ./build
#   BUILD_DIR=/tmp/b bash deploy/test.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
jobs="${JOBS:-$(nproc)}"

bash "$root/deploy/install-deps.sh"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
echo "test: building with $jobs jobs in $build"
cmake --build "$build" -j "$jobs" 2>&1 | grep -E "error|warning|\*\*\*" || true
cmake --build "$build" -j "$jobs" >/dev/null  # fails loudly if the build failed
cd "$build"
ctest --output-on-failure -j "$jobs" --timeout 900

#!/usr/bin/env bash
# Sets up everything on a fresh Debian 12 machine (as root), builds the
# project twice and runs the whole test suite with ctest in each build:
#   1. Release, warnings as errors (./build);
#   2. Debug with AddressSanitizer + UndefinedBehaviorSanitizer, asserts live,
#      warnings as errors (./build-asan; -O1 so the suite fits CI's time);
# then runs each libFuzzer target for 30 s (fuzz/run.sh, clang, ./build-fuzz).
#   bash deploy/test.sh                 # all three
#   OAIPP_SANITIZERS=0 bash deploy/test.sh   # the Release build only
#   BUILD_DIR=/tmp/b bash deploy/test.sh     # build dirs /tmp/b, /tmp/b-asan and /tmp/b-fuzz
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
jobs="${JOBS:-$(nproc)}"

bash "$root/deploy/install-deps.sh"
# The store tests start a real PostgreSQL; here it is installed, so a test
# that cannot start one fails instead of skipping.
export OAIPP_REQUIRE_POSTGRES=1

# build_and_test DIR CMAKE_ARGS...: configure, build (printing only
# diagnostics), run ctest; stops the script on the first failure.
build_and_test() {
  local dir="$1"
  shift
  local started=$SECONDS
  cmake -S "$root" -B "$dir" -DOAIPP_WERROR=ON "$@" >/dev/null
  echo "test: building $(basename "$dir") with $jobs jobs"
  if ! cmake --build "$dir" -j "$jobs" >"$dir/build.log" 2>&1; then
    grep -E "error|warning|\*\*\*" "$dir/build.log" | head -50 || tail -50 "$dir/build.log"
    echo "test: the build in $dir failed (full log: $dir/build.log)" >&2
    return 1
  fi
  echo "test: built $(basename "$dir") in $((SECONDS - started)) s; running ctest"
  (cd "$dir" && ctest --output-on-failure -j "$jobs" --timeout 900)
  echo "test: $(basename "$dir") done in $((SECONDS - started)) s"
}

if [ "${OAIPP_SANITIZERS:-1}" != "0" ]; then
  # halt_on_error: the first report fails the test that caused it.
  export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:abort_on_error=1}"
  export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
  export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$root/deploy/lsan.supp}"
  build_and_test "$build-asan" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" \
    -DOAIPP_SANITIZE=address,undefined -DOAIPP_BUILD_BENCHMARKS=OFF
  unset ASAN_OPTIONS UBSAN_OPTIONS LSAN_OPTIONS
fi
build_and_test "$build" -DCMAKE_BUILD_TYPE=Release

if [ "${OAIPP_SANITIZERS:-1}" != "0" ]; then
  # Saved crash inputs (fuzz/regressions/) must run clean, and 30 s of
  # fuzzing per target (seeded, so a failure can be repeated) must find
  # nothing new.
  BUILD_DIR="$build-fuzz" JOBS="$jobs" FUZZ_SECONDS=30 FUZZ_SEED=1 bash "$root/fuzz/run.sh"
fi

#!/usr/bin/env bash
# Sets up everything on a fresh Debian 12 machine (as root) and runs every
# check the project has, in stages, then prints each stage's time:
#   format   clang-format finds no drift in tracked C++ files (check only;
#            `clang-format -i FILE` fixes one)
#   release  Release build (./build), warnings as errors, unity batches
#            (so a name two files of one target define alike fails here);
#            the slow tier and the cases labelled *-release, or every tier
#            when the asan stage is not in the run
#   asan     Debug -O1 -g1 (line tables) with AddressSanitizer and UndefinedBehaviorSanitizer,
#            asserts live (./build-asan); the unit and service tiers
#            (the slow tier is not even built), each executable in 4
#            gtest shards rather than one process per case
#   tsan     Debug -O1 with ThreadSanitizer (./build-tsan): only the tests of
#            the server, the stores and the client that run in process
#   fuzz     (not by default) each libFuzzer target for 30 s on a fixed seed
#            (fuzz/run.sh, clang, ./build-fuzz); the saved crash inputs and
#            the seed corpus replay in the other stages as unit tests
# tests/README.md says what each tier holds.
#   bash deploy/test.sh                                 # format release asan tsan
#   OAIPP_STAGES="format release" bash deploy/test.sh   # some, in this order
#   OAIPP_STAGES="fuzz" bash deploy/test.sh             # 30 s of fuzzing per target
#   OAIPP_SANITIZERS=0 bash deploy/test.sh              # format and release
#   BUILD_DIR=/tmp/b bash deploy/test.sh                # /tmp/b, /tmp/b-asan, ...
#   JOBS=4 bash deploy/test.sh                          # parallel builds and tests
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
jobs="${JOBS:-$(nproc)}"
if [ -n "${OAIPP_STAGES:-}" ]; then
  read -r -a stages <<<"$OAIPP_STAGES"
elif [ "${OAIPP_SANITIZERS:-1}" = "0" ]; then
  stages=(format release)
else
  stages=(format release asan tsan)
fi

# Each stage's name and time, printed at the end whether or not all passed.
timings=()
report() {
  local status=$?
  if [ ${#timings[@]} -gt 0 ]; then
    echo "test: stage times"
    printf '  %s\n' "${timings[@]}"
  fi
  [ "$status" -eq 0 ] && echo "test: every stage passed (${stages[*]})"
  return "$status"
}
trap report EXIT

started=$SECONDS
bash "$root/deploy/install-deps.sh"
timings+=("$(printf '%-8s %5d s' deps $((SECONDS - started)))")
# The store tests start a real PostgreSQL; here it is installed, so a test
# that cannot start one fails instead of skipping.
export OAIPP_REQUIRE_POSTGRES=1
# One thread per BLAS call and per OpenMP loop, as the programs set them
# (server/library_settings.h; tests do not run a program's main()): CHOLMOD's
# OpenMP loops ask for 4 threads whatever OMP_NUM_THREADS says, and
# OMP_THREAD_LIMIT is the one variable that caps them. Extra threads only oversubscribe the two cores here,
# and under ThreadSanitizer each unordered write of theirs is a suppressed
# report, which made a sparse-map case take minutes instead of seconds.
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_THREAD_LIMIT="${OMP_THREAD_LIMIT:-1}"
source "$root/deploy/process-env.sh"

# build DIR [TARGETS...] -- CMAKE_ARGS...: configure and build (printing only
# diagnostics); all targets unless some are named.
build() {
  local dir="$1"
  shift
  local targets=()
  while [ "$1" != "--" ]; do
    targets+=(--target "$1")
    shift
  done
  shift
  # Unity builds (a batch of a target's sources in one translation unit)
  # parse the shared headers (gRPC, protobuf, Eigen, GoogleTest) once per
  # batch rather than once per file: about a third less build time from clean.
  # Ninja for a new build folder: it starts a target's compiles while the
  # libraries it links are still compiling, where Make waits for them. A
  # folder made earlier keeps its generator, which CMake cannot change in
  # place.
  local generator=()
  [ -f "$dir/CMakeCache.txt" ] || generator=(-G Ninja)
  cmake "${generator[@]}" -S "$root" -B "$dir" -DOAIPP_WERROR=ON -DOAIPP_LINKER=lld \
    -DCMAKE_UNITY_BUILD=ON "$@" >/dev/null
  echo "test: building $(basename "$dir") with $jobs jobs"
  local started=$SECONDS
  if ! cmake --build "$dir" -j "$jobs" "${targets[@]}" >"$dir/build.log" 2>&1; then
    grep -E "error|warning|\*\*\*" "$dir/build.log" | head -50 || tail -50 "$dir/build.log"
    echo "test: the build in $dir failed (full log: $dir/build.log)" >&2
    return 1
  fi
  echo "test: built $(basename "$dir") in $((SECONDS - started)) s"
}

# run_ctest DIR CTEST_ARGS...: the tests of one build.
run_ctest() {
  local dir="$1"
  shift
  echo "test: ctest in $(basename "$dir") $*"
  (cd "$dir" && ctest --output-on-failure -j "$jobs" --timeout 900 "$@")
}

stage_format() {
  if ! command -v clang-format >/dev/null; then
    echo "test: clang-format is not installed (deploy/install-deps.sh installs it)" >&2
    return 1
  fi
  local drift
  drift=$(cd "$root" && git ls-files '*.cc' '*.h' | xargs clang-format --dry-run 2>&1 |
    grep -oE '^[^ :]+\.(cc|h):' | sort -u || true)
  if [ -n "$drift" ]; then
    echo "test: clang-format would change these files (run clang-format -i on them):" >&2
    echo "$drift" | tr -d ':' | sed 's/^/  /' >&2
    return 1
  fi
  echo "test: clang-format finds no drift"
}

stage_release() {
  build "$build" -- -DCMAKE_BUILD_TYPE=Release
  if [[ " ${stages[*]} " == *" asan "* ]]; then
    # The asan stage runs the unit and service tiers with asserts live and
    # both sanitizers; here, the slow tier and the cases that check more
    # without them (labelled *-release, tests/CMakeLists.txt).
    run_ctest "$build" -L "slow|release"
  else
    run_ctest "$build"
  fi
}

stage_asan() {
  (
    # halt_on_error: the first report fails the test that caused it.
    export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:abort_on_error=1}"
    export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
    export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$root/deploy/lsan.supp}"
    build "$build-asan" -- -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g1 -O1" \
      -DOAIPP_SANITIZE=address,undefined -DOAIPP_BUILD_BENCHMARKS=OFF -DOAIPP_SLOW_TESTS=OFF \
      -DOAIPP_TEST_SHARDS=4
    run_ctest "$build-asan" -L "unit|service"
  )
}

stage_tsan() {
  (
    # The tests marked TSAN in tests/ (the only ones this build registers):
    # the server's registry, missions, planning pool and stores, and the
    # client against the service, all in one process. Their SLOW cases run
    # in the release stage only: here they take ten times as long. Abseil's
    # locks are made visible to TSan by tests/support/tsan_absl_sync.cc.
    export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$root/tests/support/tsan.supp}"
    build "$build-tsan" tsan_self_test service_test client_test -- -DCMAKE_BUILD_TYPE=Debug \
      -DCMAKE_CXX_FLAGS_DEBUG="-g1 -O1" -DOAIPP_SANITIZE=thread -DOAIPP_BUILD_BENCHMARKS=OFF \
      -DOAIPP_SLOW_TESTS=OFF -DOAIPP_TEST_SHARDS=4
    run_ctest "$build-tsan"
  )
}

stage_fuzz() {
  # Saved crash inputs (fuzz/regressions/) must run clean, and 30 s of
  # fuzzing per target (seeded, so a failure can be repeated) must find
  # nothing new.
  BUILD_DIR="$build-fuzz" JOBS="$jobs" FUZZ_SECONDS=30 FUZZ_SEED=1 bash "$root/fuzz/run.sh"
}

for stage in "${stages[@]}"; do
  if ! declare -F "stage_$stage" >/dev/null; then
    echo "test: no stage '$stage' (format, release, asan, tsan, fuzz)" >&2
    exit 2
  fi
  started=$SECONDS
  echo "test: stage $stage"
  "stage_$stage"
  timings+=("$(printf '%-8s %5d s' "$stage" $((SECONDS - started)))")
done

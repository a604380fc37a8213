#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/README.md) with clang, AddressSanitizer
# and UndefinedBehaviorSanitizer in build-fuzz/, replays every saved
# regression input (fuzz/regressions/<target>/), then fuzzes each target for
# FUZZ_SECONDS on a copy of its seed corpus (fuzz/corpus/<target>/), one
# target after the other. Exits non-zero when a regression input fails or the
# fuzzer finds a crash; a new crash input is kept in
# build-fuzz/artifacts/<target>/.
#   bash fuzz/run.sh                            # 600 s per target
#   FUZZ_SECONDS=30 bash fuzz/run.sh            # what CI runs (deploy/test.sh)
#   FUZZ_TARGETS=fuzz_scenario bash fuzz/run.sh # one target
#   BUILD_DIR=/tmp/bf bash fuzz/run.sh          # another build directory
#   JOBS=2 bash fuzz/run.sh                     # build with two jobs
#   FUZZ_SEED=1 bash fuzz/run.sh                # the same mutations each run
#   FUZZ_KEEP_GOING=1 bash fuzz/run.sh          # fuzz past crashes (libFuzzer's
#                                               # fork mode), e.g. while a known
#                                               # bug is not fixed yet
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build-fuzz}"
seconds="${FUZZ_SECONDS:-600}"
read -r -a targets <<<"${FUZZ_TARGETS:-fuzz_requests fuzz_scenario}"

# JOBS jobs (default one) at low priority: fuzzing by hand often shares the
# machine with other builds; deploy/test.sh passes its own JOBS.
# -O1 keeps the sanitized code fast enough to fuzz; Debug keeps asserts live.
# clang does not know GCC's -Wshadow=local (top-level CMakeLists.txt).
started=$SECONDS
mkdir -p "$build"
CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" \
  -DCMAKE_CXX_FLAGS="-Wno-unknown-warning-option" \
  -DOAIPP_SANITIZE=fuzzer-no-link,address,undefined -DOAIPP_BUILD_FUZZERS=ON \
  -DOAIPP_BUILD_TESTS=OFF -DOAIPP_BUILD_BENCHMARKS=OFF >"$build/configure.log" 2>&1 || {
  tail -30 "$build/configure.log"
  echo "fuzz: configuring $build failed (full log: $build/configure.log)" >&2
  exit 1
}
echo "fuzz: building ${targets[*]} in $build"
if ! nice -n 19 cmake --build "$build" --parallel "${JOBS:-1}" --target "${targets[@]}" \
  >"$build/build.log" 2>&1; then
  grep -E "error|\*\*\*" "$build/build.log" | head -50 || tail -50 "$build/build.log"
  echo "fuzz: the build in $build failed (full log: $build/build.log)" >&2
  exit 1
fi
echo "fuzz: built in $((SECONDS - started)) s"

# Every sanitizer report is a crash; leaks too (libFuzzer checks them per input).
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$root/deploy/lsan.supp}"
# -timeout: one input running this long is a hang; -rss_limit_mb also caps a
# single allocation (libFuzzer's malloc limit defaults to it).
# FUZZ_SEED seeds libFuzzer's mutations (0, the default: a new seed each
# run); CI fixes it so that a run can be repeated.
options=(-max_len=65536 -timeout=25 -rss_limit_mb=2048 -seed="${FUZZ_SEED:-0}")
keep_going="${FUZZ_KEEP_GOING:-0}"
# summarize LOG N: the N most frequent lines of LOG that say what went wrong
# (after many crashes in fork mode, one line per kind with its count).
summarize() {
  grep -E '^==[0-9]+== ?ERROR|^SUMMARY|runtime error:|^fuzz check failed|what\(\):' "$1" |
    sed -E 's/^==[0-9]+== ?//' | cut -c1-200 | sort | uniq -c | sort -rn | head -"$2" || true
}

failed=()
for target in "${targets[@]}"; do
  binary="$build/fuzz/$target"
  regressions="$root/fuzz/regressions/$target"
  artifacts="$build/artifacts/$target"
  corpus="$build/corpus/$target"
  log="$build/logs/$target.log"
  mkdir -p "$artifacts" "$corpus" "$(dirname "$log")"
  target_options=("${options[@]}")
  [ -f "$root/fuzz/$target.dict" ] && target_options+=("-dict=$root/fuzz/$target.dict")

  # Each saved crash must run clean: libFuzzer runs files given as arguments
  # once each.
  bad=0
  if [ -d "$regressions" ]; then
    while IFS= read -r -d '' input; do
      if ! "$binary" "${target_options[@]}" "$input" >"$log" 2>&1; then
        summarize "$log" 5
        echo "fuzz: $target: regression input ${input#"$root"/} fails" >&2
        bad=1
      fi
    done < <(find "$regressions" -type f ! -name '.*' -print0 | sort -z)
  fi
  if [ "$bad" -ne 0 ]; then
    failed+=("$target (regressions)")
    # Fuzzing would only stop at the same input again (the regressions are
    # part of its corpus), unless it is to go on past crashes.
    [ "$keep_going" = "1" ] || continue
  fi

  # Fuzz on a copy of the seeds: new inputs go to the first directory, so
  # the committed corpus stays as it is. Passing regressions join the corpus.
  for seed in "$root/fuzz/corpus/$target"/*; do
    [ -e "$corpus/$(basename "$seed")" ] || cp "$seed" "$corpus/"
  done
  dirs=("$corpus")
  [ -d "$regressions" ] && [ "$bad" -eq 0 ] && dirs+=("$regressions")
  run_options=(-max_total_time="$seconds" -print_final_stats=1 -artifact_prefix="$artifacts/")
  if [ "$keep_going" = "1" ]; then
    # One fuzzing process at a time, restarted after each crash.
    run_options+=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
  fi
  stamp="$build/logs/$target.started"
  touch "$stamp"
  echo "fuzz: $target for $seconds s (log: ${log#"$root"/})"
  rc=0
  "$binary" "${target_options[@]}" "${run_options[@]}" "${dirs[@]}" >"$log" 2>&1 || rc=$?
  # libFuzzer's last status line (executions, cov: edges, ft: features,
  # corp: inputs/size, exec/s) and its final statistics.
  grep -E "^#[0-9]+" "$log" | tail -1 || true
  grep -E "^stat::(number_of_executed_units|average_exec_per_sec|new_units_added|slowest_unit_time_sec|peak_rss_mb)" \
    "$log" || true
  echo "fuzz: $target: $(find "$corpus" -type f | wc -l) inputs in the corpus"
  found=$(find "$artifacts" -type f -newer "$stamp" | wc -l)
  if [ "$rc" -ne 0 ] || [ "$found" -ne 0 ]; then
    summarize "$log" 10
    echo "fuzz: $target crashed (exit $rc, $found new input(s) in ${artifacts#"$root"/}/)." \
      "Once understood, copy each to fuzz/regressions/$target/ (fuzz/README.md)." >&2
    failed+=("$target")
  fi
done

if [ ${#failed[@]} -ne 0 ]; then
  echo "fuzz: failed: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: every target ran clean in $((SECONDS - started)) s"

// The numeric libraries' process-wide settings, made once by a program's
// main() before it starts any thread (the server, the benchmarks).
//
// - OpenBLAS: one thread per call (openblas_set_num_threads): the server has
//   threads of its own, and OpenBLAS's pool waking for small products only
//   contends with them.
// - OpenMP: CHOLMOD's OpenMP loops (the sparse map's refactorisation) ask for
//   four threads whatever OMP_NUM_THREADS says; on two cores those threads
//   waking and waiting made a 90,000-cell refactorisation three times as
//   slow (1.34 s against 0.44 s, `sparse_map_bench`, docs/benchmarks.md).
//   omp_set_max_active_levels(0) runs every parallel region on the thread
//   that enters it, as OMP_THREAD_LIMIT=1 would.
// - OpenBLAS's kernels are the one setting no call can change: OpenBLAS
//   0.3.21 chooses them when it is loaded, with the program, from the CPU or
//   from OPENBLAS_CORETYPE. It does not know CPUs newer than it and may then
//   fall back to its oldest kernels (Prescott: 3-6x slower for the Kalman
//   update, and no single-precision solves). That variable is the launcher's
//   to set (deploy/run.sh, the container and the Kubernetes manifests leave
//   the choice to OpenBLAS, which knows the machines they were measured on);
//   this logs what OpenBLAS chose and warns when it fell back on a CPU with
//   AVX2.
//
// An operator's environment wins: a setting whose variable is set is left
// as the variable says.
//
//   int main(int argc, char** argv) {
//     absl::StatusOr<oaipp::server::NumericSetup> numeric = oaipp::server::SetUpNumericLibraries();
//     if (!numeric.ok()) return 1;  // an OpenBLAS unsafe for threads
#pragma once

#include <string>

#include "absl/status/statusor.h"

namespace oaipp::server {

// What SetUpNumericLibraries found, for the program to log.
struct NumericSetup {
  // "OpenBLAS: pthreads build, Haswell kernels, 1 thread(s) per call; ..."
  std::string summary;
  // Not empty when OpenBLAS fell back to its oldest kernels on a CPU with
  // AVX2: what to set.
  std::string warning;
};

// Makes the settings above. FailedPrecondition when the process's OpenBLAS
// is not safe to call from several threads at once
// (CheckBlasIsSafeForConcurrentCalls): the program should not go on.
[[nodiscard]] absl::StatusOr<NumericSetup> SetUpNumericLibraries();
// The same for a tool that reports on stderr (the benchmarks): prints the
// warning, or the error and returns false (the program should stop).
[[nodiscard]] bool SetUpNumericLibrariesOrSay();

}  // namespace oaipp::server

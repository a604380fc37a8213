#include "server/library_settings.h"

#include <cstdio>
#include <cstdlib>
#include <string>

#include "absl/strings/str_cat.h"
#include "core/mapping/dense_backend.h"

// OpenBLAS's and libgomp's C interfaces (the libraries are linked; their
// headers are not needed for two calls).
extern "C" {
void openblas_set_num_threads(int threads);
void omp_set_max_active_levels(int levels);
}

namespace oaipp::server {
namespace {

bool IsSet(const char* name) { return std::getenv(name) != nullptr; }

}  // namespace

absl::StatusOr<NumericSetup> SetUpNumericLibraries() {
  if (!IsSet("OPENBLAS_NUM_THREADS") && !IsSet("OMP_NUM_THREADS")) openblas_set_num_threads(1);
  const bool openmp_serial = !IsSet("OMP_THREAD_LIMIT") && !IsSet("OMP_MAX_ACTIVE_LEVELS");
  if (openmp_serial) omp_set_max_active_levels(0);
  if (absl::Status safe = CheckBlasIsSafeForConcurrentCalls(); !safe.ok()) return safe;
  const BlasFacts blas = ReadBlasFacts();
  NumericSetup setup;
  setup.summary = absl::StrCat("OpenBLAS: ", blas.build, " build, ", blas.kernel, " kernels, ",
                               blas.threads, " thread(s) per call; OpenMP loops ",
                               openmp_serial ? "on one thread" : "as the environment says");
  const char* better = OpenBlasCoreTypeForThisCpu();
  if (better != nullptr && blas.kernel == "Prescott" && !IsSet("OPENBLAS_CORETYPE")) {
    setup.warning = absl::StrCat(
        "OpenBLAS does not know this CPU and chose its oldest kernels; start the program with "
        "OPENBLAS_CORETYPE=",
        better, " for kernels 3-6x faster (docs/capacity.md)");
  }
  return setup;
}

bool SetUpNumericLibrariesOrSay() {
  const absl::StatusOr<NumericSetup> numeric = SetUpNumericLibraries();
  if (!numeric.ok()) {
    std::fprintf(stderr, "%s\n", std::string(numeric.status().message()).c_str());
    return false;
  }
  if (!numeric->warning.empty()) std::fprintf(stderr, "%s\n", numeric->warning.c_str());
  return true;
}

}  // namespace oaipp::server

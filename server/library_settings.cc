#include "server/openblas_kernels.h"

#include <unistd.h>

#include <cstdlib>

#include "core/mapping/dense_backend.h"

namespace oaipp::server {

void RestartWithOpenBlasKernels(char** argv) {
  if (std::getenv("OPENBLAS_CORETYPE") != nullptr) return;
  const char* core = OpenBlasCoreTypeForThisCpu();
  if (core == nullptr || setenv("OPENBLAS_CORETYPE", core, 0) != 0) return;
  // Read when the library loads, like the kernels: no thread pool to start.
  setenv("OPENBLAS_NUM_THREADS", "1", 0);
  execv("/proc/self/exe", argv);
  // Still here: the restart failed; go on with what OpenBLAS picked.
}

}  // namespace oaipp::server

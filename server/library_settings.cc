#include "server/library_settings.h"

#include <unistd.h>

#include <cstdlib>

#include "core/mapping/dense_backend.h"

namespace oaipp::server {
namespace {

// Sets `name` to `value` unless it is set; true when it set it.
bool SetIfUnset(const char* name, const char* value) {
  return std::getenv(name) == nullptr && value != nullptr && setenv(name, value, 0) == 0;
}

}  // namespace

void RestartWithLibrarySettings(char** argv) {
  bool changed = SetIfUnset("OPENBLAS_CORETYPE", OpenBlasCoreTypeForThisCpu());
  changed = SetIfUnset("OPENBLAS_NUM_THREADS", "1") || changed;
  changed = SetIfUnset("OMP_THREAD_LIMIT", "1") || changed;
  // After the restart every variable is set (or, for the kernels, has no
  // better value), so this returns there.
  if (changed) execv("/proc/self/exe", argv);
  // Still here: nothing to change, or the restart failed.
}

}  // namespace oaipp::server

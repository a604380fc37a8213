// main() of every Google Benchmark program here: the numeric libraries set
// up as the server sets them up (server/library_settings.h: one thread
// per BLAS call and per OpenMP loop), so
// that what is timed is what the server runs.
#include "benchmark/benchmark.h"
#include "server/library_settings.h"

int main(int argc, char** argv) {
  // As the server does: the numeric libraries' threads (server/library_settings.h).
  if (!oaipp::server::SetUpNumericLibrariesOrSay()) return 1;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

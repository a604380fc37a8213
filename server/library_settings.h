// The numeric libraries' process-wide settings, for a program's main().
//
// Debian's OpenBLAS 0.3.21 does not know CPUs newer than it and falls back
// to its oldest kernels on them (3-6x slower for the Kalman update's rank
// update, and its single-precision strtri crashes from n = 133). It reads
// OPENBLAS_CORETYPE and OPENBLAS_NUM_THREADS once, in its constructor.
// CHOLMOD's OpenMP loops (the sparse map's refactorisation) ask for four
// threads whatever OMP_NUM_THREADS says; only OMP_THREAD_LIMIT, read by
// libgomp when it loads, caps them. On two cores those four threads waking
// and waiting made a 90,000-cell refactorisation take three times as long
// (1.34 s against 0.44 s, `sparse_map_bench`, docs/benchmarks.md). All three
// libraries are loaded with the program (OpenCV and pagmo2 link LAPACK), so
// the variables can only take effect in a new process image. This is the one
// place that executes the program again; it lives with the programs, not in
// a library.
//
//   int main(int argc, char** argv) {
//     oaipp::server::RestartWithLibrarySettings(argv);  // first thing
#pragma once

namespace oaipp::server {

// Sets, where unset: OMP_THREAD_LIMIT=1 and OPENBLAS_NUM_THREADS=1 (the
// server has threads of its own), and OPENBLAS_CORETYPE when this CPU has
// AVX2 or AVX-512 (see OpenBlasCoreTypeForThisCpu in
// core/mapping/dense_backend.h); then executes /proc/self/exe with the same
// arguments. Returns when nothing needed setting, or when the restart failed
// (the libraries keep their own choices). An operator's settings always win.
void RestartWithLibrarySettings(char** argv);

}  // namespace oaipp::server

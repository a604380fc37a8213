// Choosing OpenBLAS's kernels, for a program's main().
//
// Debian's OpenBLAS 0.3.21 does not know CPUs newer than it and falls back
// to its oldest kernels on them (3-6x slower for the Kalman update's rank
// update, and its single-precision strtri crashes from n = 133). It reads
// OPENBLAS_CORETYPE once, in its constructor, and it is loaded with the
// program (OpenCV and pagmo2 link LAPACK), so the variable can only take
// effect in a new process image. This is the one place that executes the
// program again; it lives with the programs, not in a library.
//
//   int main(int argc, char** argv) {
//     oaipp::server::RestartWithOpenBlasKernels(argv);  // first thing
#pragma once

namespace oaipp::server {

// When OPENBLAS_CORETYPE is unset and this CPU has AVX2 or AVX-512 (see
// OpenBlasCoreTypeForThisCpu in core/mapping/dense_backend.h): sets it, and
// OPENBLAS_NUM_THREADS=1 unless set (the server has threads of its own), and
// executes /proc/self/exe with the same arguments. Returns when nothing
// needs to change, or when the restart failed (OpenBLAS keeps its choice).
// An operator's OPENBLAS_CORETYPE always wins.
void RestartWithOpenBlasKernels(char** argv);

}  // namespace oaipp::server

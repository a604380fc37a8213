// Where the Kalman update's big product runs: Eigen (the default), or
// OpenBLAS loaded at run time.
//
// Fusing a measurement ends in P -= Bt Bt^T, a symmetric rank-m update of the
// n x n covariance (n^2 m flops: most of AddMeasurement's time). This build
// compiles Eigen for generic x86-64 (see CMakeLists.txt), so its kernels use
// 128-bit vectors; OpenBLAS picks kernels for the CPU it runs on, 3-6x faster
// for this product (docs/capacity.md). OpenBLAS is not linked: UseOpenBlas()
// opens Debian's libopenblas0-pthread with dlopen, so the server runs (on
// Eigen) where it is missing, and the core library's results stay bit for bit
// those of Eigen unless a program asks for OpenBLAS.
//
// Only the pthreads build is used, with one thread per call. The server calls
// these functions from several threads at once, and Debian's serial build
// (libopenblas0-serial, built without USE_LOCKING) hands out its scratch
// buffers without a lock: two concurrent calls can get the same buffer and
// return wrong numbers, silently (before this was fixed, 32-102 of 5000 small
// solves and rank updates per thread differed in the concurrency test of
// dense_backend_test.cc, four threads on a 2-core machine). The pthreads
// build locks its buffer pool and runs the same kernels; UseOpenBlas()
// refuses any other build, so on a serial build that test now stops at
// UseOpenBlas().
//
// OpenBLAS 0.3.21 (Debian 12) does not recognise CPUs newer than it and then
// falls back to its oldest kernels. It reads OPENBLAS_CORETYPE once, when it
// is loaded, and where it is the system's BLAS it is loaded with the program
// (OpenCV and pagmo2 link LAPACK), before main() runs. Choosing kernels is
// therefore a program's business, not this library's: the server's main()
// sets the variable from OpenBlasCoreTypeForThisCpu() and executes itself
// again (server/openblas_kernels.h).
//
// Results differ from Eigen's in the last bits (another summation order),
// and between kernels; for one machine and backend they are deterministic.
//
//   // in main(), before other threads start (it may set an environment
//   // variable):
//   if (absl::Status s = UseOpenBlas(); !s.ok()) LOG(WARNING) << s;
#pragma once

#include <string>

#include "Eigen/Core"
#include "absl/status/status.h"

namespace oaipp {

// OpenBLAS's kernel family for this CPU ("SkylakeX" with AVX-512, "Haswell"
// with AVX2 + FMA), or nullptr where OpenBLAS's own choice is right.
[[nodiscard]] const char* OpenBlasCoreTypeForThisCpu();

// Loads OpenBLAS (the pthreads build, one thread per call) and makes these
// functions use it. Call once, from one thread, before other threads start
// (it may set OPENBLAS_NUM_THREADS). FailedPrecondition (naming what is
// missing, or that the library found is not the pthreads build) leaves Eigen
// in use.
[[nodiscard]] absl::Status UseOpenBlas();

// Goes back to Eigen (tests compare the two).
void UseEigen();

// True while OpenBLAS is in use.
[[nodiscard]] bool DenseBackendIsOpenBlas();

// "eigen", or "openblas (<kernel>)".
[[nodiscard]] std::string DenseBackendName();

// The lower triangle of p += alpha * b * b^T (p n x n, b n x m); the upper
// triangle is not touched.
void SymmetricRankUpdate(double alpha, const Eigen::MatrixXd& b, Eigen::MatrixXd& p);

// b := b L^-T for the lower-triangular L held in the lower triangle of
// `lower` (m x m; what lies above the diagonal is ignored), b n x m: the
// Kalman gain's whitened columns P_:J L^-T.
void SolveRightLowerTransposed(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b);

// b := b L^-1 for L as above (m x m), b n x m.
void SolveRightLower(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b);

// b := L^-1 b for L as above (m x m), b m x k: whitened rows L^-1 P_J:.
void SolveLeftLower(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b);

// The Cholesky factor L of the symmetric positive definite s (m x m, its
// lower triangle read), written over s's lower triangle; what lies above the
// diagonal is unspecified afterwards. False when s is not positive definite.
[[nodiscard]] bool CholeskyLowerInPlace(Eigen::MatrixXd& s);

// The lower triangle of (L L^T)^-1 from the Cholesky factor L in the lower
// triangle of `lower` (m x m, as CholeskyLowerInPlace leaves it), written
// over it (LAPACK's potri); what lies above the diagonal is unspecified.
// Precondition: L's diagonal is positive.
void InverseFromCholeskyInPlace(Eigen::MatrixXd& lower);

// L^-1 for the lower-triangular L in the lower triangle of `lower` (m x m),
// written over that triangle (LAPACK's trtri); what lies above the diagonal
// is unspecified. Precondition: L's diagonal is nonzero.
void InverseLowerInPlace(Eigen::MatrixXd& lower);

// The same three in single precision (OpenBLAS's strsm, spotrf and strtri,
// or Eigen's), for the planner's objective when it runs in single
// precision (core/planning/information.h).
void SolveLeftLower(const Eigen::MatrixXf& lower, Eigen::MatrixXf& b);
[[nodiscard]] bool CholeskyLowerInPlace(Eigen::MatrixXf& s);
void InverseLowerInPlace(Eigen::MatrixXf& lower);

}  // namespace oaipp

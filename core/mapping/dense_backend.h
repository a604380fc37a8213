// Where the Kalman update's big products run: Eigen, or OpenBLAS loaded at
// run time. A DenseBackend is a small value that a map (GpMap) and the
// planner's objective (InformationParams::dense_backend) hold: the core
// library keeps no process-wide choice, and two maps in one process may use
// different backends. The default value is Eigen.
//
// Fusing a measurement ends in P -= Bt Bt^T, a symmetric rank-m update of the
// n x n covariance (n^2 m flops: most of AddMeasurement's time). This build
// compiles Eigen for generic x86-64 (see CMakeLists.txt), so its kernels use
// 128-bit vectors; OpenBLAS picks kernels for the CPU it runs on, 3-6x faster
// for this product (docs/capacity.md). OpenBLAS is not linked:
// DenseBackend::OpenBlas() opens Debian's libopenblas0-pthread with dlopen
// (once per process), so a program runs (on Eigen) where it is missing, and
// the core library's results stay bit for bit those of Eigen unless a
// program asks for OpenBLAS.
//
// Only the pthreads build is used, with one thread per call. The server calls
// these functions from several threads at once, and Debian's serial build
// (libopenblas0-serial, built without USE_LOCKING) hands out its scratch
// buffers without a lock: two concurrent calls can get the same buffer and
// return wrong numbers, silently (before this was fixed, 32-102 of 5000 small
// solves and rank updates per thread differed in the concurrency test of
// dense_backend_test.cc, four threads on a 2-core machine). The pthreads
// build locks its buffer pool and runs the same kernels; OpenBlas() refuses
// any other build.
//
// OpenBLAS 0.3.21 (Debian 12) does not recognise CPUs newer than it and then
// falls back to its oldest kernels. It reads OPENBLAS_CORETYPE once, when it
// is loaded, and where it is the system's BLAS it is loaded with the program
// (OpenCV and pagmo2 link LAPACK), before main() runs. Choosing kernels is
// therefore a program's business, not this library's: the server's main()
// sets the variable from OpenBlasCoreTypeForThisCpu() and executes itself
// again (server/library_settings.h).
//
// Results differ from Eigen's in the last bits (another summation order),
// and between kernels; for one machine and backend they are deterministic.
//
//   absl::StatusOr<DenseBackend> blas = DenseBackend::OpenBlas();
//   DenseBackend backend = blas.ok() ? *blas : DenseBackend();  // Eigen
//   map.set_dense_backend(backend);
#pragma once

#include <string>

#include "Eigen/Core"
#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace oaipp {

// OpenBLAS's kernel family for this CPU ("SkylakeX" with AVX-512, "Haswell"
// with AVX2 + FMA), or nullptr where OpenBLAS's own choice is right.
[[nodiscard]] const char* OpenBlasCoreTypeForThisCpu();

struct OpenBlasLibrary;  // the entry points found in the loaded library

class DenseBackend {
 public:
  // Eigen.
  DenseBackend() = default;

  // OpenBLAS (the pthreads build, one thread per call). The library is
  // loaded at the first call, which may set OPENBLAS_NUM_THREADS and
  // OPENBLAS_CORETYPE when unset: make it before other threads read the
  // environment. Later calls return the same backend (or error).
  // FailedPrecondition names what is missing, or that the library found is
  // not the pthreads build.
  [[nodiscard]] static absl::StatusOr<DenseBackend> OpenBlas();

  [[nodiscard]] bool is_open_blas() const { return blas_ != nullptr; }
  // "eigen", or "openblas (<kernel>)".
  [[nodiscard]] std::string name() const;
  friend bool operator==(const DenseBackend&, const DenseBackend&) = default;

  // The lower triangle of p += alpha * b * b^T (p n x n, b n x m); the upper
  // triangle is not touched.
  void SymmetricRankUpdate(double alpha, const Eigen::MatrixXd& b, Eigen::MatrixXd& p) const;

  // b := b L^-T for the lower-triangular L held in the lower triangle of
  // `lower` (m x m; what lies above the diagonal is ignored), b n x m: the
  // Kalman gain's whitened columns P_:J L^-T.
  void SolveRightLowerTransposed(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b) const;

  // b := b L^-1 for L as above (m x m), b n x m.
  void SolveRightLower(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b) const;

  // b := L^-1 b for L as above (m x m), b m x k: whitened rows L^-1 P_J:.
  void SolveLeftLower(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b) const;

  // The Cholesky factor L of the symmetric positive definite s (m x m, its
  // lower triangle read), written over s's lower triangle; what lies above
  // the diagonal is unspecified afterwards. False when s is not positive
  // definite.
  [[nodiscard]] bool CholeskyLowerInPlace(Eigen::MatrixXd& s) const;

  // The lower triangle of (L L^T)^-1 from the Cholesky factor L in the lower
  // triangle of `lower` (m x m, as CholeskyLowerInPlace leaves it), written
  // over it (LAPACK's potri); what lies above the diagonal is unspecified.
  // Precondition: L's diagonal is positive.
  void InverseFromCholeskyInPlace(Eigen::MatrixXd& lower) const;

  // L^-1 for the lower-triangular L in the lower triangle of `lower` (m x m),
  // written over that triangle (LAPACK's trtri); what lies above the
  // diagonal is unspecified. Precondition: L's diagonal is nonzero.
  void InverseLowerInPlace(Eigen::MatrixXd& lower) const;

  // The same three in single precision (OpenBLAS's strsm, spotrf and
  // strtri, or Eigen's), for the planner's objective when it runs in single
  // precision (core/planning/information.h).
  void SolveLeftLower(const Eigen::MatrixXf& lower, Eigen::MatrixXf& b) const;
  [[nodiscard]] bool CholeskyLowerInPlace(Eigen::MatrixXf& s) const;
  void InverseLowerInPlace(Eigen::MatrixXf& lower) const;

 private:
  explicit DenseBackend(const OpenBlasLibrary* blas) : blas_(blas) {}

  // nullptr: Eigen. The library's entry points live as long as the process.
  const OpenBlasLibrary* blas_ = nullptr;
};

}  // namespace oaipp

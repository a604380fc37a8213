// Where the Kalman update's big products run: Eigen, or OpenBLAS. A
// DenseBackend is a small value that a map (GpMap) and the planner's
// objective (InformationParams::dense_backend) hold: the core library keeps
// no process-wide choice, and two maps in one process may use different
// backends. The default value is Eigen.
//
// Fusing a measurement ends in P -= Bt Bt^T, a symmetric rank-m update of the
// n x n covariance (n^2 m flops: most of AddMeasurement's time). This build
// compiles Eigen for generic x86-64 (see CMakeLists.txt), so its kernels use
// 128-bit vectors; OpenBLAS picks kernels for the CPU it runs on, 3-6x faster
// for this product (docs/capacity.md). OpenBLAS is linked as any library is
// (Debian's libopenblas-pthread-dev; the programs' run path names the
// pthreads build's folder), and the core library's results stay bit for bit
// those of Eigen unless a program asks for OpenBLAS.
//
// Only the pthreads build is safe here. The server calls these functions,
// and CHOLMOD calls the same library for the sparse map, from several
// threads at once; Debian's serial build (libopenblas0-serial, built without
// USE_LOCKING) hands out its scratch buffers without a lock: two concurrent
// calls can get the same buffer and return wrong numbers, silently (32-102 of
// 5000 small solves and rank updates per thread differed in the concurrency
// test of dense_backend_test.cc, four threads on a 2-core machine, before
// this was refused). CheckBlasIsSafeForConcurrentCalls() says whether the
// library the process runs with is that build; OpenBlas() refuses others.
//
// The library keeps two process-wide settings, which belong to a program,
// not to this library: the threads per call (one, in a program with threads
// of its own: openblas_set_num_threads, at start) and the kernels, which
// OpenBLAS 0.3.21 chooses once, when it is loaded, from the CPU or from
// OPENBLAS_CORETYPE (server/library_settings.h).
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

// The OpenBLAS this process runs with, as it reports itself.
struct BlasFacts {
  std::string kernel;  // openblas_get_corename(): "SkylakeX", "Haswell", "Prescott", ...
  std::string build;   // "pthreads", "serial", "openmp" (openblas_get_parallel)
  int threads = 1;     // threads per call (openblas_get_num_threads)
};
[[nodiscard]] BlasFacts ReadBlasFacts();

// OK when the process's OpenBLAS is the pthreads build, the only one safe
// to call from several threads at once; FailedPrecondition, saying what to
// install, otherwise. Every path that calls the BLAS from more than one
// thread (the dense backend, the sparse map, the server at start) asks.
[[nodiscard]] absl::Status CheckBlasIsSafeForConcurrentCalls();

// OpenBLAS's kernel family for this CPU ("SkylakeX" with AVX-512, "Haswell"
// with AVX2 + FMA), or nullptr where OpenBLAS's own choice is right.
[[nodiscard]] const char* OpenBlasCoreTypeForThisCpu();

struct OpenBlasLibrary;  // what the linked OpenBLAS is (its kernels)

class DenseBackend {
 public:
  // Eigen.
  DenseBackend() = default;

  // OpenBLAS, as the program set it up. FailedPrecondition (from
  // CheckBlasIsSafeForConcurrentCalls) when it is not the pthreads build.
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
  // strtri where their kernels were checked, else Eigen's), for the planner's objective when it
  // runs in single precision (core/planning/information.h).
  void SolveLeftLower(const Eigen::MatrixXf& lower, Eigen::MatrixXf& b) const;
  [[nodiscard]] bool CholeskyLowerInPlace(Eigen::MatrixXf& s) const;
  void InverseLowerInPlace(Eigen::MatrixXf& lower) const;

 private:
  explicit DenseBackend(const OpenBlasLibrary* blas) : blas_(blas) {}

  // nullptr: Eigen. The library's entry points live as long as the process.
  const OpenBlasLibrary* blas_ = nullptr;
};

}  // namespace oaipp

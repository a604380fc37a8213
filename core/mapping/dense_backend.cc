#include "core/mapping/dense_backend.h"

#include <cstddef>
#include <string>
#include <type_traits>
#include <utility>

#include "Eigen/Cholesky"
#include "absl/status/statusor.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "cblas.h"  // OpenBLAS's (libopenblas-pthread-dev), with its openblas_* queries

// LAPACK's Fortran entry points in OpenBLAS; the trailing lengths of the
// character arguments are what gfortran passes for them.
extern "C" {
void dpotrf_(const char* uplo, const int* n, double* a, const int* lda, int* info,
             std::size_t uplo_length);
void dpotri_(const char* uplo, const int* n, double* a, const int* lda, int* info,
             std::size_t uplo_length);
void dtrtri_(const char* uplo, const char* diag, const int* n, double* a, const int* lda, int* info,
             std::size_t uplo_length, std::size_t diag_length);
void spotrf_(const char* uplo, const int* n, float* a, const int* lda, int* info,
             std::size_t uplo_length);
void strtri_(const char* uplo, const char* diag, const int* n, float* a, const int* lda, int* info,
             std::size_t uplo_length, std::size_t diag_length);
}

namespace oaipp {

// What the linked OpenBLAS is, read once.
struct OpenBlasLibrary {
  std::string kernel;
  // Whether its single-precision strsm, spotrf and strtri are used (else
  // the single-precision solves run on Eigen).
  bool single_kernels = false;
};

namespace {

// Kernel families (openblas_get_corename) whose strsm, spotrf and strtri
// were run for every size from 1 to 700 on one thread without a fault
// (DenseBackendTest.SinglePrecisionKernelsAgreeWithEigen runs the sizes
// that once faulted on every machine the tests run on).
bool SingleKernelsChecked(const std::string& kernel) {
  for (const char* checked : {"SkylakeX", "Cooperlake", "Haswell", "Zen", "Sandybridge"}) {
    if (absl::EqualsIgnoreCase(kernel, checked)) return true;
  }
  return false;
}

constexpr Eigen::Index kMaxInt = 0x7fffffff;  // CBLAS takes int sizes

}  // namespace

const char* OpenBlasCoreTypeForThisCpu() {
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl")) {
    return "SkylakeX";
  }
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "Haswell";
  return nullptr;
}

BlasFacts ReadBlasFacts() {
  BlasFacts facts;
  const char* core = openblas_get_corename();
  facts.kernel = core != nullptr ? core : "unknown";
  facts.threads = openblas_get_num_threads();
  switch (openblas_get_parallel()) {
    case 0:
      facts.build = "serial";
      break;
    case 1:
      facts.build = "pthreads";
      break;
    case 2:
      facts.build = "openmp";
      break;
    default:
      facts.build = "unknown";
  }
  return facts;
}

absl::Status CheckBlasIsSafeForConcurrentCalls() {
  const BlasFacts facts = ReadBlasFacts();
  if (facts.build == "pthreads") return absl::OkStatus();
  return absl::FailedPreconditionError(absl::StrCat(
      "the OpenBLAS this program runs with is the ", facts.build,
      " build, which is not safe to call from several threads at once (its buffer pool does not "
      "lock); install libopenblas0-pthread and run without LD_LIBRARY_PATH or LD_PRELOAD naming "
      "another OpenBLAS"));
}

absl::StatusOr<DenseBackend> DenseBackend::OpenBlas() {
  // Read once; the facts do not change while the process runs.
  static const absl::StatusOr<const OpenBlasLibrary*> linked =
      []() -> absl::StatusOr<const OpenBlasLibrary*> {
    if (absl::Status safe = CheckBlasIsSafeForConcurrentCalls(); !safe.ok()) return safe;
    auto* blas = new OpenBlasLibrary;
    blas->kernel = ReadBlasFacts().kernel;
    // With OpenBLAS 0.3.21's Prescott kernels (what it picks for a CPU it
    // does not know, without OPENBLAS_CORETYPE) strtri_ crashes from n = 133
    // on one thread: the single-precision kernels only where checked.
    blas->single_kernels = SingleKernelsChecked(blas->kernel);
    return blas;
  }();
  if (!linked.ok()) return linked.status();
  return DenseBackend(*linked);
}

std::string DenseBackend::name() const {
  return blas_ == nullptr ? "eigen" : absl::StrCat("openblas (", blas_->kernel, ")");
}

void DenseBackend::SymmetricRankUpdate(double alpha, const Eigen::MatrixXd& b,
                                       Eigen::MatrixXd& p) const {
  const Eigen::Index n = p.rows();
  const Eigen::Index m = b.cols();
  if (n == 0 || m == 0) return;
  if (blas_ == nullptr || n > kMaxInt || m > kMaxInt) {
    p.selfadjointView<Eigen::Lower>().rankUpdate(b, alpha);
    return;
  }
  cblas_dsyrk(CblasColMajor, CblasLower, CblasNoTrans, static_cast<int>(n), static_cast<int>(m),
              alpha, b.data(), static_cast<int>(b.outerStride()), 1.0, p.data(),
              static_cast<int>(p.outerStride()));
}

void DenseBackend::SolveRightLowerTransposed(const Eigen::MatrixXd& lower,
                                             Eigen::MatrixXd& b) const {
  if (b.size() == 0) return;  // Eigen would index an empty matrix's null data
  if (blas_ == nullptr || b.rows() > kMaxInt || b.cols() > kMaxInt) {
    lower.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(b);
    return;
  }
  cblas_dtrsm(CblasColMajor, CblasRight, CblasLower, CblasTrans, CblasNonUnit,
              static_cast<int>(b.rows()), static_cast<int>(b.cols()), 1.0, lower.data(),
              static_cast<int>(lower.outerStride()), b.data(), static_cast<int>(b.outerStride()));
}

void DenseBackend::SolveRightLower(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b) const {
  if (b.size() == 0) return;  // Eigen would index an empty matrix's null data
  if (blas_ == nullptr || b.rows() > kMaxInt || b.cols() > kMaxInt) {
    lower.triangularView<Eigen::Lower>().solveInPlace<Eigen::OnTheRight>(b);
    return;
  }
  cblas_dtrsm(CblasColMajor, CblasRight, CblasLower, CblasNoTrans, CblasNonUnit,
              static_cast<int>(b.rows()), static_cast<int>(b.cols()), 1.0, lower.data(),
              static_cast<int>(lower.outerStride()), b.data(), static_cast<int>(b.outerStride()));
}

namespace {

template <typename Scalar>
using MatrixOf = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;

// L^-1 on Eigen, for L in the lower triangle of `lower`.
template <typename Scalar>
MatrixOf<Scalar> LowerInverseOnEigen(const MatrixOf<Scalar>& lower) {
  MatrixOf<Scalar> inv = MatrixOf<Scalar>::Identity(lower.rows(), lower.rows());
  lower.template triangularView<Eigen::Lower>().solveInPlace(inv);
  return inv;
}

// Whether OpenBLAS runs Scalar's kernels (double's always, float's where
// checked), for `blas` nullptr (Eigen) or not.
template <typename Scalar>
bool OnOpenBlas(const OpenBlasLibrary* blas) {
  if (blas == nullptr) return false;
  return std::is_same_v<Scalar, double> || blas->single_kernels;
}

// The double- and single-precision versions of the three below share one
// body; only OpenBLAS's entry point differs (d... or s...).
template <typename Scalar>
void SolveLeftLowerIn(const OpenBlasLibrary* blas, const MatrixOf<Scalar>& lower,
                      MatrixOf<Scalar>& b) {
  if (b.size() == 0) return;  // Eigen would index an empty matrix's null data
  if (!OnOpenBlas<Scalar>(blas) || b.rows() > kMaxInt || b.cols() > kMaxInt) {
    lower.template triangularView<Eigen::Lower>().solveInPlace(b);
    return;
  }
  const int rows = static_cast<int>(b.rows());
  const int cols = static_cast<int>(b.cols());
  const int lda = static_cast<int>(lower.outerStride());
  const int ldb = static_cast<int>(b.outerStride());
  if constexpr (std::is_same_v<Scalar, double>) {
    cblas_dtrsm(CblasColMajor, CblasLeft, CblasLower, CblasNoTrans, CblasNonUnit, rows, cols, 1.0,
                lower.data(), lda, b.data(), ldb);
  } else {
    cblas_strsm(CblasColMajor, CblasLeft, CblasLower, CblasNoTrans, CblasNonUnit, rows, cols, 1.0F,
                lower.data(), lda, b.data(), ldb);
  }
}

template <typename Scalar>
bool CholeskyLowerInPlaceIn(const OpenBlasLibrary* blas, MatrixOf<Scalar>& s) {
  if (!OnOpenBlas<Scalar>(blas) || s.rows() > kMaxInt || s.rows() == 0) {
    // As Eigen::LLT(s) computes it, bit for bit.
    const Eigen::LLT<MatrixOf<Scalar>> llt(s);
    if (llt.info() != Eigen::Success) return false;
    s = llt.matrixLLT();
    return true;
  }
  const int n = static_cast<int>(s.rows());
  const int lda = static_cast<int>(s.outerStride());
  int info = 0;
  if constexpr (std::is_same_v<Scalar, double>) {
    dpotrf_("L", &n, s.data(), &lda, &info, 1);
  } else {
    spotrf_("L", &n, s.data(), &lda, &info, 1);
  }
  return info == 0;
}

template <typename Scalar>
void InverseLowerInPlaceIn(const OpenBlasLibrary* blas, MatrixOf<Scalar>& lower) {
  const Eigen::Index m = lower.rows();
  if (m == 0) return;
  if (!OnOpenBlas<Scalar>(blas) || m > kMaxInt) {
    lower.template triangularView<Eigen::Lower>() = LowerInverseOnEigen<Scalar>(lower);
    return;
  }
  const int n = static_cast<int>(m);
  const int lda = static_cast<int>(lower.outerStride());
  int info = 0;
  if constexpr (std::is_same_v<Scalar, double>) {
    dtrtri_("L", "N", &n, lower.data(), &lda, &info, 1, 1);
  } else {
    strtri_("L", "N", &n, lower.data(), &lda, &info, 1, 1);
  }
}

}  // namespace

void DenseBackend::SolveLeftLower(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b) const {
  SolveLeftLowerIn<double>(blas_, lower, b);
}
void DenseBackend::SolveLeftLower(const Eigen::MatrixXf& lower, Eigen::MatrixXf& b) const {
  SolveLeftLowerIn<float>(blas_, lower, b);
}
bool DenseBackend::CholeskyLowerInPlace(Eigen::MatrixXd& s) const {
  return CholeskyLowerInPlaceIn<double>(blas_, s);
}
bool DenseBackend::CholeskyLowerInPlace(Eigen::MatrixXf& s) const {
  return CholeskyLowerInPlaceIn<float>(blas_, s);
}
void DenseBackend::InverseLowerInPlace(Eigen::MatrixXd& lower) const {
  InverseLowerInPlaceIn<double>(blas_, lower);
}
void DenseBackend::InverseLowerInPlace(Eigen::MatrixXf& lower) const {
  InverseLowerInPlaceIn<float>(blas_, lower);
}

void DenseBackend::InverseFromCholeskyInPlace(Eigen::MatrixXd& lower) const {
  const Eigen::Index m = lower.rows();
  if (m == 0) return;
  if (blas_ == nullptr || m > kMaxInt) {
    // L^-1, then its lower triangle of L^-T L^-1.
    const Eigen::MatrixXd inv = LowerInverseOnEigen<double>(lower);
    Eigen::MatrixXd s = Eigen::MatrixXd::Zero(m, m);
    s.selfadjointView<Eigen::Lower>().rankUpdate(inv.transpose());
    lower.triangularView<Eigen::Lower>() = s;
    return;
  }
  const int n = static_cast<int>(m);
  const int lda = static_cast<int>(lower.outerStride());
  int info = 0;
  dpotri_("L", &n, lower.data(), &lda, &info, 1);
}

}  // namespace oaipp

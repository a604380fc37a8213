#include "core/mapping/dense_backend.h"

#include <dlfcn.h>

#include <cstddef>
#include <cstdlib>
#include <type_traits>
#include <utility>

#include "Eigen/Cholesky"
#include "absl/status/statusor.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace oaipp {
namespace {

// CBLAS's enums, as OpenBLAS's cblas.h numbers them (part of its ABI).
constexpr int kColMajor = 102;
constexpr int kLower = 122;
constexpr int kNoTrans = 111;
constexpr int kTrans = 112;
constexpr int kLeft = 141;
constexpr int kRight = 142;
constexpr int kNonUnit = 131;

using Dsyrk = void (*)(int order, int uplo, int trans, int n, int k, double alpha, const double* a,
                       int lda, double beta, double* c, int ldc);
using Dtrsm = void (*)(int order, int side, int uplo, int trans, int diag, int m, int n,
                       double alpha, const double* a, int lda, double* b, int ldb);
// LAPACK's Fortran entry point; the trailing length of `uplo` is what
// gfortran passes for a character argument.
using Dpotrf = void (*)(const char* uplo, const int* n, double* a, const int* lda, int* info,
                        std::size_t uplo_length);
using Dpotri = Dpotrf;  // the same arguments
using Dtrtri = void (*)(const char* uplo, const char* diag, const int* n, double* a, const int* lda,
                        int* info, std::size_t uplo_length, std::size_t diag_length);
using Strsm = void (*)(int order, int side, int uplo, int trans, int diag, int m, int n,
                       float alpha, const float* a, int lda, float* b, int ldb);
using Spotrf = void (*)(const char* uplo, const int* n, float* a, const int* lda, int* info,
                        std::size_t uplo_length);
using Strtri = void (*)(const char* uplo, const char* diag, const int* n, float* a, const int* lda,
                        int* info, std::size_t uplo_length, std::size_t diag_length);
using SetThreads = void (*)(int);
using CoreName = char* (*)();
using GetParallel = int (*)();

}  // namespace

struct OpenBlasLibrary {
  Dsyrk dsyrk = nullptr;
  Dtrsm dtrsm = nullptr;
  Dpotrf dpotrf = nullptr;
  Dpotri dpotri = nullptr;
  Dtrtri dtrtri = nullptr;
  Strsm strsm = nullptr;
  Spotrf spotrf = nullptr;
  Strtri strtri = nullptr;
  std::string kernel;
};

namespace {

// Kernel families (openblas_get_corename) whose strsm, spotrf and strtri
// were run for every size from 1 to 700 on one thread without a fault.
bool SingleKernelsChecked(const std::string& kernel) {
  for (const char* checked : {"SkylakeX", "Haswell", "Zen", "Sandybridge"}) {
    if (absl::EqualsIgnoreCase(kernel, checked)) return true;
  }
  return false;
}

// Sets OPENBLAS_CORETYPE for this CPU unless it is set (an operator's choice
// wins); true when it set it.
bool SetCoreTypeIfUnset() {
  if (std::getenv("OPENBLAS_CORETYPE") != nullptr) return false;
  const char* core = OpenBlasCoreTypeForThisCpu();
  return core != nullptr && setenv("OPENBLAS_CORETYPE", core, 0) == 0;
}

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

absl::StatusOr<DenseBackend> DenseBackend::OpenBlas() {
  // Loaded once; the entry points are kept for the life of the process.
  static const absl::StatusOr<const OpenBlasLibrary*> loaded =
      []() -> absl::StatusOr<const OpenBlasLibrary*> {
    SetCoreTypeIfUnset();
    // One thread per call: the server has its own threads.
    setenv("OPENBLAS_NUM_THREADS", "1", 0);
    // 0: serial build, 1: pthreads, 2: OpenMP (whose buffer pool does not
    // lock for threads it did not start). Only 1 is safe here.
    constexpr int kPthreads = 1;
    // Where OpenBLAS is the system's BLAS it was loaded with the program, and
    // the library opened below binds its internal calls (the buffer pool
    // among them) to that copy's: it must be the pthreads build too.
    if (auto global = reinterpret_cast<GetParallel>(dlsym(RTLD_DEFAULT, "openblas_get_parallel"));
        global != nullptr && global() != kPthreads) {
      return absl::FailedPreconditionError(
          "the system's BLAS is an OpenBLAS build other than pthreads (see update-alternatives "
          "--display libopenblas.so.0-x86_64-linux-gnu), which is not safe to call from several "
          "threads at once; the Kalman update runs on Eigen");
    }
    void* library = nullptr;
    for (const char* path :
         {"/usr/lib/x86_64-linux-gnu/openblas-pthread/libopenblas.so.0", "libopenblas.so.0"}) {
      library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
      if (library != nullptr) break;
    }
    if (library == nullptr) {
      return absl::FailedPreconditionError(
          "OpenBLAS (libopenblas0-pthread) could not be loaded; the Kalman update runs on Eigen");
    }
    if (auto parallel = reinterpret_cast<GetParallel>(dlsym(library, "openblas_get_parallel"));
        parallel == nullptr || parallel() != kPthreads) {
      dlclose(library);
      return absl::FailedPreconditionError(
          "the OpenBLAS found is not the pthreads build (libopenblas0-pthread), the only one safe "
          "to call from several threads at once; the Kalman update runs on Eigen");
    }
    OpenBlasLibrary blas;
    blas.dsyrk = reinterpret_cast<Dsyrk>(dlsym(library, "cblas_dsyrk"));
    blas.dtrsm = reinterpret_cast<Dtrsm>(dlsym(library, "cblas_dtrsm"));
    blas.dpotrf = reinterpret_cast<Dpotrf>(dlsym(library, "dpotrf_"));
    blas.dpotri = reinterpret_cast<Dpotri>(dlsym(library, "dpotri_"));
    blas.dtrtri = reinterpret_cast<Dtrtri>(dlsym(library, "dtrtri_"));
    blas.strsm = reinterpret_cast<Strsm>(dlsym(library, "cblas_strsm"));
    blas.spotrf = reinterpret_cast<Spotrf>(dlsym(library, "spotrf_"));
    blas.strtri = reinterpret_cast<Strtri>(dlsym(library, "strtri_"));
    // The single-precision three are optional: without them the
    // single-precision objective's solves run on Eigen.
    if (blas.dsyrk == nullptr || blas.dtrsm == nullptr || blas.dpotrf == nullptr ||
        blas.dpotri == nullptr || blas.dtrtri == nullptr) {
      dlclose(library);
      return absl::FailedPreconditionError(
          "the OpenBLAS found lacks cblas_dsyrk, cblas_dtrsm, dpotrf_, dpotri_ or dtrtri_; the "
          "Kalman update and the objective run on Eigen");
    }
    // A copy loaded with the program sized its pool before the variable was
    // set (when no restart set it): one thread per call in both copies.
    for (void* scope : {RTLD_DEFAULT, library}) {
      if (auto set_threads = reinterpret_cast<SetThreads>(dlsym(scope, "openblas_set_num_threads"));
          set_threads != nullptr) {
        set_threads(1);
      }
    }
    auto core_name = reinterpret_cast<CoreName>(dlsym(library, "openblas_get_corename"));
    blas.kernel = core_name != nullptr ? core_name() : "unknown";
    // The single-precision kernels only where they were checked: with
    // OpenBLAS 0.3.21's Prescott kernels (what it picks for a CPU it does not
    // know, without OPENBLAS_CORETYPE) strtri_ crashes from n = 133 on one
    // thread. Elsewhere the single-precision solves run on Eigen.
    if (!SingleKernelsChecked(blas.kernel)) {
      blas.strsm = nullptr;
      blas.spotrf = nullptr;
      blas.strtri = nullptr;
    }
    return new OpenBlasLibrary(std::move(blas));
  }();
  if (!loaded.ok()) return loaded.status();
  return DenseBackend(*loaded);
}

std::string DenseBackend::name() const {
  return blas_ == nullptr ? "eigen" : absl::StrCat("openblas (", blas_->kernel, ")");
}

void DenseBackend::SymmetricRankUpdate(double alpha, const Eigen::MatrixXd& b,
                                       Eigen::MatrixXd& p) const {
  const OpenBlasLibrary* blas = blas_;
  const Eigen::Index n = p.rows();
  const Eigen::Index m = b.cols();
  // CBLAS takes int sizes: a larger product stays on Eigen.
  constexpr Eigen::Index kMaxInt = 0x7fffffff;
  if (n == 0 || m == 0) return;
  if (blas == nullptr || n > kMaxInt || m > kMaxInt) {
    p.selfadjointView<Eigen::Lower>().rankUpdate(b, alpha);
    return;
  }
  blas->dsyrk(kColMajor, kLower, kNoTrans, static_cast<int>(n), static_cast<int>(m), alpha,
              b.data(), static_cast<int>(b.outerStride()), 1.0, p.data(),
              static_cast<int>(p.outerStride()));
}

void DenseBackend::SolveRightLowerTransposed(const Eigen::MatrixXd& lower,
                                             Eigen::MatrixXd& b) const {
  if (b.size() == 0) return;  // Eigen would index an empty matrix's null data
  const OpenBlasLibrary* blas = blas_;
  constexpr Eigen::Index kMaxInt = 0x7fffffff;
  if (blas == nullptr || b.rows() > kMaxInt || b.cols() > kMaxInt) {
    lower.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(b);
    return;
  }
  blas->dtrsm(kColMajor, kRight, kLower, kTrans, kNonUnit, static_cast<int>(b.rows()),
              static_cast<int>(b.cols()), 1.0, lower.data(), static_cast<int>(lower.outerStride()),
              b.data(), static_cast<int>(b.outerStride()));
}

void DenseBackend::SolveRightLower(const Eigen::MatrixXd& lower, Eigen::MatrixXd& b) const {
  if (b.size() == 0) return;  // Eigen would index an empty matrix's null data
  const OpenBlasLibrary* blas = blas_;
  constexpr Eigen::Index kMaxInt = 0x7fffffff;
  if (blas == nullptr || b.rows() > kMaxInt || b.cols() > kMaxInt) {
    lower.triangularView<Eigen::Lower>().solveInPlace<Eigen::OnTheRight>(b);
    return;
  }
  blas->dtrsm(kColMajor, kRight, kLower, kNoTrans, kNonUnit, static_cast<int>(b.rows()),
              static_cast<int>(b.cols()), 1.0, lower.data(), static_cast<int>(lower.outerStride()),
              b.data(), static_cast<int>(b.outerStride()));
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

// OpenBLAS's kernel for Scalar (`d` for double, `s` for float), or nullptr
// on Eigen (blas nullptr) or where the library lacks it.
template <typename Scalar, typename D, typename S>
auto KernelOf(const OpenBlasLibrary* blas, D OpenBlasLibrary::*d, S OpenBlasLibrary::*s) {
  if constexpr (std::is_same_v<Scalar, double>) {
    return blas == nullptr ? D{nullptr} : blas->*d;
  } else {
    return blas == nullptr ? S{nullptr} : blas->*s;
  }
}

// The double- and single-precision versions of the three below share one
// body; only OpenBLAS's entry point differs (d... or s...).
template <typename Scalar>
void SolveLeftLowerIn(const OpenBlasLibrary* blas, const MatrixOf<Scalar>& lower,
                      MatrixOf<Scalar>& b) {
  if (b.size() == 0) return;  // Eigen would index an empty matrix's null data
  const auto trsm = KernelOf<Scalar>(blas, &OpenBlasLibrary::dtrsm, &OpenBlasLibrary::strsm);
  constexpr Eigen::Index kMaxInt = 0x7fffffff;
  if (trsm == nullptr || b.rows() > kMaxInt || b.cols() > kMaxInt) {
    lower.template triangularView<Eigen::Lower>().solveInPlace(b);
    return;
  }
  trsm(kColMajor, kLeft, kLower, kNoTrans, kNonUnit, static_cast<int>(b.rows()),
       static_cast<int>(b.cols()), Scalar{1}, lower.data(), static_cast<int>(lower.outerStride()),
       b.data(), static_cast<int>(b.outerStride()));
}

template <typename Scalar>
bool CholeskyLowerInPlaceIn(const OpenBlasLibrary* blas, MatrixOf<Scalar>& s) {
  const auto potrf = KernelOf<Scalar>(blas, &OpenBlasLibrary::dpotrf, &OpenBlasLibrary::spotrf);
  constexpr Eigen::Index kMaxInt = 0x7fffffff;
  if (potrf == nullptr || s.rows() > kMaxInt || s.rows() == 0) {
    // As Eigen::LLT(s) computes it, bit for bit.
    const Eigen::LLT<MatrixOf<Scalar>> llt(s);
    if (llt.info() != Eigen::Success) return false;
    s = llt.matrixLLT();
    return true;
  }
  const int n = static_cast<int>(s.rows());
  const int lda = static_cast<int>(s.outerStride());
  int info = 0;
  potrf("L", &n, s.data(), &lda, &info, 1);
  return info == 0;
}

template <typename Scalar>
void InverseLowerInPlaceIn(const OpenBlasLibrary* blas, MatrixOf<Scalar>& lower) {
  const auto trtri = KernelOf<Scalar>(blas, &OpenBlasLibrary::dtrtri, &OpenBlasLibrary::strtri);
  constexpr Eigen::Index kMaxInt = 0x7fffffff;
  const Eigen::Index m = lower.rows();
  if (m == 0) return;
  if (trtri == nullptr || m > kMaxInt) {
    lower.template triangularView<Eigen::Lower>() = LowerInverseOnEigen<Scalar>(lower);
    return;
  }
  const int n = static_cast<int>(m);
  const int lda = static_cast<int>(lower.outerStride());
  int info = 0;
  trtri("L", "N", &n, lower.data(), &lda, &info, 1, 1);
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
  const OpenBlasLibrary* blas = blas_;
  constexpr Eigen::Index kMaxInt = 0x7fffffff;
  const Eigen::Index m = lower.rows();
  if (m == 0) return;
  if (blas == nullptr || m > kMaxInt) {
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
  blas->dpotri("L", &n, lower.data(), &lda, &info, 1);
}

}  // namespace oaipp

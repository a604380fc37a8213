#include "core/mapping/gmrf_prior.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include "boost/math/tools/minima.hpp"
#include "unsupported/Eigen/FFT"

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "core/mapping/gp_map.h"
#include "core/mapping/sparse_gp_map.h"

namespace oaipp {
namespace {

using Complex = std::complex<double>;

// The 2-D DFT of an n x n row-major array, rows then columns; the inverse
// is scaled by 1 / n^2.
void Dft2(std::vector<Complex>& data, int n, bool inverse) {
  Eigen::FFT<double> fft;
  std::vector<Complex> in(n), out(n);
  for (int pass = 0; pass < 2; ++pass) {
    for (int line = 0; line < n; ++line) {
      for (int k = 0; k < n; ++k) in[k] = pass == 0 ? data[line * n + k] : data[k * n + line];
      if (inverse) {
        fft.inv(out, in);
      } else {
        fft.fwd(out, in);
      }
      for (int k = 0; k < n; ++k) (pass == 0 ? data[line * n + k] : data[k * n + line]) = out[k];
    }
  }
}

// Autocovariance over lags (row-major, lags wrapped) of the prior whose
// spectrum on the lattice is `spectrum`, after the published code's noise
// term and `observed` label^-2 of uniform observation of every cell:
// S / (1 + S (1 / sn2 + observed)).
std::vector<double> PublishedPriorLags(const std::vector<double>& spectrum, double noise_var,
                                       double observed, int n) {
  const double precision = 1.0 / noise_var + observed;
  std::vector<Complex> data(spectrum.size());
  for (std::size_t k = 0; k < spectrum.size(); ++k) {
    data[k] = spectrum[k] / (1.0 + spectrum[k] * precision);
  }
  Dft2(data, n, /*inverse=*/true);
  std::vector<double> lags(data.size());
  for (std::size_t k = 0; k < data.size(); ++k) lags[k] = data[k].real();
  return lags;
}

// The long-wavelength term for K = a I + G and scale s: what lifts the
// GMRF's precision at zero frequency, a^3 / s, to the kernel's
// `zero_frequency_precision` (none where it is already there).
double LongWavelengthPrecision(double a, double scale, double zero_frequency_precision) {
  return std::max(0.0, zero_frequency_precision - a * a * a / scale);
}

// The lattice spectrum of the GMRF with K = a I + G, Q = K^3 / s + d I.
std::vector<double> GmrfSpectrum(double a, double scale, double d,
                                 const std::vector<double>& lambda) {
  const int n = static_cast<int>(lambda.size());
  std::vector<double> s(static_cast<std::size_t>(n) * n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double k = a + lambda[i] + lambda[j];
      s[i * n + j] = 1.0 / (k * k * k / scale + d);
    }
  }
  return s;
}

double MeanPublished(const std::vector<double>& spectrum, double noise_var) {
  double sum = 0.0;
  for (double v : spectrum) sum += v / (1.0 + v / noise_var);
  return sum / static_cast<double>(spectrum.size());
}

// The uniform observation precisions, label^-2 added to 1 / sn2, at which
// the fit compares covariances: the prior itself, and every cell seen with
// about the precision of one look from 20 m (1.6 under the paper's
// noise), two to three looks, and many (docs/method.md §3.9).
constexpr double kFittedObservation[] = {0.0, 1.0, 3.0, 10.0};

}  // namespace

GmrfFit FitGmrfToPublishedPrior(const GpParams& params, double resolution_m) {
  const double h = resolution_m, l = params.length_scale_m;
  // Lags out to 8 l and beyond wrap-around; a power of two for the DFT.
  int n = 64;
  while (n < 16.0 * l / h && n < 512) n *= 2;
  // The Matérn 3/2 kernel sampled at the lattice's lags, wrapped.
  std::vector<Complex> kernel(static_cast<std::size_t>(n) * n);
  for (int i = 0; i < n; ++i) {
    const double dy = h * std::min(i, n - i);
    for (int j = 0; j < n; ++j) {
      const double dx = h * std::min(j, n - j);
      kernel[i * n + j] = Matern32(std::hypot(dx, dy), l, params.signal_var);
    }
  }
  Dft2(kernel, n, /*inverse=*/false);
  std::vector<double> dense_spectrum(kernel.size());
  for (std::size_t k = 0; k < kernel.size(); ++k) dense_spectrum[k] = kernel[k].real();
  const double zero_frequency_precision = 1.0 / dense_spectrum[0];
  std::vector<std::vector<double>> dense;
  for (double observed : kFittedObservation) {
    dense.push_back(PublishedPriorLags(dense_spectrum, params.noise_var, observed, n));
  }

  std::vector<double> lambda(n);
  for (int k = 0; k < n; ++k) lambda[k] = 2.0 - 2.0 * std::cos(2.0 * std::numbers::pi * k / n);
  // The lags fitted: one octant (the rest follow by symmetry) within 3 l.
  std::vector<int> fitted;
  for (int i = 0; i < n / 2; ++i) {
    for (int j = 0; j <= i; ++j) {
      if (std::hypot(i, j) * h <= 3.0 * l) fitted.push_back(i * n + j);
    }
  }
  auto spectrum = [&](double a, double scale) {
    return GmrfSpectrum(a, scale, LongWavelengthPrecision(a, scale, zero_frequency_precision),
                        lambda);
  };
  // For a given a: the scale whose P0 has the dense interior variance
  // (bisection on log s; the variance grows with s).
  auto scale_for = [&](double a) {
    double lo = std::log(1e-12), hi = std::log(1e12);
    for (int it = 0; it < 80; ++it) {
      const double mid = 0.5 * (lo + hi);
      const double v = MeanPublished(spectrum(a, std::exp(mid)), params.noise_var);
      (v < dense[0][0] ? lo : hi) = mid;
    }
    return std::exp(0.5 * (lo + hi));
  };
  // Squared differences over the fitted lags, each observation level's
  // relative to its dense variance.
  auto misfit = [&](double log_a) {
    const double a = std::exp(log_a);
    const std::vector<double> fitted_spectrum = spectrum(a, scale_for(a));
    double sum = 0.0;
    for (std::size_t level = 0; level < std::size(kFittedObservation); ++level) {
      const std::vector<double> lags =
          PublishedPriorLags(fitted_spectrum, params.noise_var, kFittedObservation[level], n);
      const std::vector<double>& target = dense[level];
      for (int k : fitted) sum += std::pow((lags[k] - target[k]) / target[0], 2);
    }
    return sum;
  };
  // Brent's minimisation on log a (Boost.Math), to about 1e-7 relative in a.
  const auto [log_a, best] = boost::math::tools::brent_find_minima(
      misfit, std::log(1e-4), std::log(10.0), std::numeric_limits<double>::digits / 2);
  (void)best;
  GmrfFit fit;
  fit.a = std::exp(log_a);
  fit.scale = scale_for(fit.a);
  fit.long_wavelength = LongWavelengthPrecision(fit.a, fit.scale, zero_frequency_precision);
  const std::vector<double> lags =
      PublishedPriorLags(spectrum(fit.a, fit.scale), params.noise_var, 0.0, n);
  fit.dense_p0_variance = dense[0][0];
  fit.fitted_p0_variance = lags[0];
  for (int k : fitted) {
    fit.worst_lag_difference = std::max(fit.worst_lag_difference, std::abs(lags[k] - dense[0][k]));
  }
  return fit;
}

namespace {

// The SPDE's field on the lattice, without the variance match below.
absl::StatusOr<GmrfPrior> MakeUnmatchedPrior(const FieldGrid& grid, const GpParams& params,
                                             const GmrfOptions& options, const GmrfFit& fit) {
  GmrfPrior prior;
  prior.fit = fit;
  const double a = prior.fit.a;
  const double margin = std::ceil(options.margin_ranges * prior.fit.range_cells());
  const double nx = grid.nx() + 2.0 * margin, ny = grid.ny() + 2.0 * margin;
  if (nx * ny > static_cast<double>(std::numeric_limits<int>::max() / 32)) {
    return absl::ResourceExhaustedError(
        absl::StrCat("the prior's lattice of ", nx, " x ", ny, " states is too large"));
  }
  prior.margin_cells = static_cast<int>(margin);
  prior.lattice_nx = static_cast<int>(nx);
  prior.lattice_ny = static_cast<int>(ny);
  const int lx = prior.lattice_nx, ly = prior.lattice_ny, n = lx * ly;

  // K = a I + G, G the graph Laplacian of the 4-neighbour lattice.
  std::vector<Eigen::Triplet<double, int>> k_entries;
  k_entries.reserve(static_cast<std::size_t>(n) * 5);
  for (int r = 0; r < ly; ++r) {
    for (int c = 0; c < lx; ++c) {
      const int s = r * lx + c;
      int degree = 0;
      auto neighbour = [&](int rr, int cc) {
        if (rr < 0 || rr >= ly || cc < 0 || cc >= lx) return;
        k_entries.emplace_back(s, rr * lx + cc, -1.0);
        ++degree;
      };
      neighbour(r - 1, c);
      neighbour(r + 1, c);
      neighbour(r, c - 1);
      neighbour(r, c + 1);
      k_entries.emplace_back(s, s, a + degree);
    }
  }
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> k(n, n);
  k.setFromTriplets(k_entries.begin(), k_entries.end());
  const Eigen::SparseMatrix<double, Eigen::ColMajor, int> k2 = k * k;
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> q = (1.0 / prior.fit.scale) * (k2 * k);
  // Exactly symmetric, whatever order the product summed in.
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> qt = q.transpose();
  q = 0.5 * (q + qt);

  prior.field_state.resize(grid.num_cells());
  for (int cell = 0; cell < grid.num_cells(); ++cell) {
    prior.field_state[cell] =
        (grid.Row(cell) + prior.margin_cells) * lx + grid.Col(cell) + prior.margin_cells;
  }
  for (int s = 0; s < n; ++s) q.coeffRef(s, s) += prior.fit.long_wavelength;
  for (int s : prior.field_state) q.coeffRef(s, s) += 1.0 / params.noise_var;
  prior.precision = q.triangularView<Eigen::Lower>();
  prior.precision.makeCompressed();
  prior.prior_mean = params.prior_mean;
  return prior;
}

// Where field cell `index` (of `n` along one axis) lies in a reference
// field of `reference_n` = min(n, 2 band + 1) along it: itself on a field
// no wider than the reference, else the same distance from the nearer edge
// within `band` of it, and the reference's middle farther in.
int ReferenceIndex(int index, int n, int band, int reference_n) {
  if (n == reference_n || index < band) return index;
  if (n - 1 - index < band) return reference_n - (n - index);
  return band;
}

}  // namespace

int VarianceMatchBand(const GpParams& params, double resolution_m) {
  const double band = std::ceil(4.0 * params.length_scale_m / resolution_m);
  return static_cast<int>(std::clamp(band, 2.0, static_cast<double>(kMaxVarianceMatchBand)));
}

absl::StatusOr<GmrfPrior> MakeGmrfPrior(const FieldGrid& grid, const GpParams& params,
                                        const GmrfOptions& options) {
  OAIPP_RETURN_IF_ERROR(params.Validate());
  if (!(options.margin_ranges >= 0.0) || !std::isfinite(options.margin_ranges)) {
    return absl::InvalidArgumentError(
        absl::StrCat("margin_ranges: must be >= 0 and finite, got ", options.margin_ranges));
  }
  const double h = grid.resolution_m();
  const GmrfFit fit = FitGmrfToPublishedPrior(params, h);
  OAIPP_ASSIGN_OR_RETURN(GmrfPrior prior, MakeUnmatchedPrior(grid, params, options, fit));

  // The variance match: both priors' variances on a reference field of at
  // most (2 band + 1)^2 cells, the dense one's exactly, the unmatched sparse
  // one's by its own inference (its lattice and margin as the field's).
  // Edge effects reach about two length scales (gmrf_prior.h), so every cell
  // farther than `band` from an edge has the reference's middle variance.
  const int band = VarianceMatchBand(params, h);
  const int ref_nx = std::min(grid.nx(), 2 * band + 1), ref_ny = std::min(grid.ny(), 2 * band + 1);
  OAIPP_ASSIGN_OR_RETURN(const FieldGrid reference,
                         FieldGrid::Create(grid.min_W(), ref_nx, ref_ny, h));
  OAIPP_ASSIGN_OR_RETURN(const Eigen::MatrixXd dense, PriorCovariance(reference, params));
  OAIPP_ASSIGN_OR_RETURN(GmrfPrior unmatched, MakeUnmatchedPrior(reference, params, options, fit));
  unmatched.information = Eigen::VectorXd::Zero(unmatched.num_states());
  OAIPP_ASSIGN_OR_RETURN(SparseGpMap reference_map,
                         SparseGpMap::FromPrior(reference, std::move(unmatched)));
  OAIPP_ASSIGN_OR_RETURN(const Eigen::VectorXd sparse, reference_map.Variances());

  // Q <- D Q D with D = diag(sqrt(sparse / dense)) on the field's states
  // (1 on the margin's): the covariance becomes D^-1 Sigma D^-1, every
  // field cell's variance the dense prior's, every correlation unchanged,
  // the pattern too.
  Eigen::VectorXd d = Eigen::VectorXd::Ones(prior.num_states());
  for (int cell = 0; cell < grid.num_cells(); ++cell) {
    const int r = ReferenceIndex(grid.Row(cell), grid.ny(), band, ref_ny);
    const int c = ReferenceIndex(grid.Col(cell), grid.nx(), band, ref_nx);
    const int ref = reference.Index(r, c);
    d[prior.field_state[cell]] = std::sqrt(sparse[ref] / dense(ref, ref));
  }
  using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  for (int col = 0; col < prior.precision.outerSize(); ++col) {
    for (SparseMatrix::InnerIterator it(prior.precision, col); it; ++it) {
      it.valueRef() *= d[it.row()] * d[col];
    }
  }
  const SparseMatrix q = prior.precision.selfadjointView<Eigen::Lower>();
  prior.information = q * Eigen::VectorXd::Constant(prior.num_states(), params.prior_mean);
  return prior;
}

absl::Status SetPriorMean(GmrfPrior& prior, const FieldGrid& grid,
                          const Eigen::VectorXd& field_mean) {
  if (field_mean.size() != grid.num_cells() ||
      static_cast<int>(prior.field_state.size()) != grid.num_cells()) {
    return absl::InvalidArgumentError(absl::StrCat("field_mean: ", field_mean.size(),
                                                   " values for a prior of ",
                                                   prior.field_state.size(), " field cells"));
  }
  const int m = prior.margin_cells;
  Eigen::VectorXd mu(prior.num_states());
  for (int r = 0; r < prior.lattice_ny; ++r) {
    const int row = std::clamp(r - m, 0, grid.ny() - 1);
    for (int c = 0; c < prior.lattice_nx; ++c) {
      const int col = std::clamp(c - m, 0, grid.nx() - 1);
      mu[r * prior.lattice_nx + c] = field_mean[grid.Index(row, col)];
    }
  }
  prior.information = prior.precision.selfadjointView<Eigen::Lower>() * mu;
  return absl::OkStatus();
}

GmrfPriorCache::GmrfPriorCache(int capacity) : priors_(capacity) {}

absl::StatusOr<std::shared_ptr<const GmrfPrior>> GmrfPriorCache::Get(const FieldGrid& grid,
                                                                     const GpParams& params,
                                                                     const GmrfOptions& options) {
  const Key key{.shape = PriorShapeKey::Of(grid, params),
                .prior_mean = params.prior_mean,
                .margin_ranges = options.margin_ranges};
  return priors_.Get(key, [&] { return MakeGmrfPrior(grid, params, options); });
}

}  // namespace oaipp

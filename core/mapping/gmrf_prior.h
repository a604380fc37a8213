// A prior with an exactly sparse precision for large fields (docs/method.md
// §3.9): the Gaussian Markov random field of the SPDE
//   (kappa^2 - Laplacian)^(3/2) u = W / tau
// on a regular lattice (Lindgren, Rue and Lindström 2011, alpha = 3), whose
// solution is a Matérn field of smoothness nu = 2, with a long-wavelength
// term added to its precision (below). It stands in for the mission's
// Matérn 3/2 GP where a dense covariance (8 n^2 bytes) cannot be held.
//
// What the map works with is the published code's prior
// P0 = (K^-1 + I / sn2)^-1 (docs/method.md §3), here
// (D (Q_spde + I_field / sn2) D)^-1: the noise term only adds to the field
// cells' diagonal, and the diagonal D is the variance match (below). Q_spde's parameters are fitted
// to that prior, not to the kernel alone, on the infinite lattice of the field's resolution, by
// exact spectral sums (FitGmrfToPublishedPrior):
// - a long-wavelength term d I makes Q_spde's precision at zero frequency
//   the kernel's (the SPDE's own falls short of it once kappa is fitted);
// - the scale makes an interior cell's P0 variance equal the dense prior's;
// - kappa then makes the covariances at every lag within 3 l of a cell
//   agree best in least squares, relative to the cell's variance, for P0
//   and for the posteriors of every cell observed uniformly with 1, 3 and
//   10 label^-2 of precision. Fitted to P0 alone, the posterior after
//   a search's measurements came out 2-3 % too uncertain, which searched
//   measurably differently from the dense map (docs/method.md §3.9).
// nu = 2 and not nu = 1: P0 is what the noise term leaves of the kernel's
// spectrum, its high frequencies, where nu = 1 has far more power than
// Matérn 3/2 (its P0 variance comes out ~40 % high), nu = 2 a little less.
//
// The lattice extends the field by a margin on each side, so that the
// SPDE's free (Neumann) boundary, which inflates the variance at an edge,
// lies outside the field; the margin's states are marginalised exactly by
// the inference and never reported.
//
// The published prior's variance is not the same everywhere: its noise term
// reduces it less where a cell has fewer neighbours, so it is 40 % higher at
// an edge and twice as high at a corner, and the fitted field follows that
// only to a few per cent. The variance match makes every field cell's prior
// variance the dense prior's: Q <- D Q D, D diagonal (so the pattern, the
// correlations and the exactness of the inference are unchanged), with
// D^2 the ratio of the two variances. Both differ from their interior value
// only within about two length scales of an edge (by less than 1e-5 of it
// beyond), so the ratios come from a reference field of (2 band + 1)^2
// cells, band = VarianceMatchBand, computed whole for each prior (about
// 0.25 s for the paper's preset), and a cell of the field takes the
// reference cell at its distance from the nearer edges.
//
// On the lattice with spacing h (the field's resolution), K = a I + G with
// a = kappa^2 h^2 and G the graph Laplacian (4 on the diagonal inside, the
// node's degree at an edge; -1 to each of the four neighbours), and
//   Q_spde = K^3 / s + d I,
// s the covariance scale, d >= 0 the long-wavelength term: a 25-point
// stencil, at most 25 non-zeros a row, positive definite for any a, s > 0.
// The prior's precision is D (Q_spde + I_field / sn2) D (the variance
// match above).
//
//   OAIPP_ASSIGN_OR_RETURN(GmrfPrior prior, MakeGmrfPrior(grid, GpParams::PaperPreset(1.0)));
//   // prior.precision: lower triangle of Q (states x states)
//   // prior.field_state[c]: the state of field cell c
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "Eigen/SparseCore"
#include "absl/status/statusor.h"
#include "core/common/single_flight_cache.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_params.h"
#include "core/mapping/prior_cache.h"

namespace oaipp {

// The version of the sparse prior: its fit, the form of its precision and
// its lattice (the margin). A large-field map's numbers depend on all
// three, so a variance or trace kept from a build with another version is
// not this build's (server/store/state_codec.cc); a change to any of them
// takes a new number. 1: fitted to P0 alone; 2 and 3: to P0 and uniformly
// observed posteriors, with the long-wavelength term (2 was briefly built
// with a longer margin); 4: 3 with the variance match.
inline constexpr unsigned kGmrfFitVersion = 4;

// The variance match's band, in cells: 4 length scales, at least 2 and at
// most kMaxVarianceMatchBand (its reference field then has 1,681 cells).
// The cap binds for length scales above 5 cells (the paper's preset has
// 3.7): then the band holds fewer than 4 length scales, and from about 9
// cells (the band under 2.2 of them) the reference's middle is no longer
// free of its edges' effect, so the match there is close, not exact.
inline constexpr int kMaxVarianceMatchBand = 20;
[[nodiscard]] int VarianceMatchBand(const GpParams& params, double resolution_m);

struct GmrfOptions {
  // Lattice nodes added beyond the field on each side, in units of the
  // prior's range (GmrfFit::range_cells, beyond which its correlation is
  // below 0.1). Valid: >= 0, finite.
  double margin_ranges = 1.0;
  bool operator==(const GmrfOptions&) const = default;
};

// The fitted parameters, and how well P0 then agrees on the infinite
// lattice.
struct GmrfFit {
  double a = 0.0;      // kappa^2 h^2
  double scale = 0.0;  // s
  // d, label^-2: Q_spde's precision at zero frequency, a^3 / s + d, is the
  // Matérn kernel's.
  double long_wavelength = 0.0;
  // The dense and the fitted P0's interior variance and, over the lags
  // fitted, the largest difference of a covariance (both in label units
  // squared).
  double dense_p0_variance = 0.0;
  double fitted_p0_variance = 0.0;
  double worst_lag_difference = 0.0;
  // The range 4 / kappa, in lattice cells. For the SPDE alone its
  // correlation falls to about 0.14 there; the long-wavelength term lowers
  // the fitted field's correlation at that lag (to 0.05 for the paper's
  // preset), although its tail, oscillating, decays more slowly (at 0.87
  // kappa when d s = a^3): at one range and beyond, what the margin cuts is
  // smaller than for the SPDE alone (TheRangeIsWhereTheCorrelationIsSmall).
  [[nodiscard]] double range_cells() const { return 4.0 / std::sqrt(a); }
};

// The fit above for a field of resolution h = resolution_m. Precondition:
// params.Validate() is ok and resolution_m > 0. Costs a few milliseconds
// for the paper's preset (l / h = 3.7), more as l / h grows.
[[nodiscard]] GmrfFit FitGmrfToPublishedPrior(const GpParams& params, double resolution_m);

struct GmrfPrior {
  // The lattice: (nx + 2 margin) x (ny + 2 margin) states, row-major.
  int lattice_nx = 0;
  int lattice_ny = 0;
  int margin_cells = 0;
  GmrfFit fit;
  // Lower triangle (column-major) of the prior precision over all states:
  // D (Q_spde + I_field / sn2) D, D the variance match. Exactly symmetric
  // as a whole.
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> precision;
  // Q mu0 (the prior mean is mu0 at every state).
  Eigen::VectorXd information;
  double prior_mean = 0.0;
  // field_state[c]: the state of field cell c.
  std::vector<int> field_state;
  [[nodiscard]] int num_states() const { return lattice_nx * lattice_ny; }
};

// The prior for `grid` and `params` (see above). InvalidArgument naming the
// field for invalid params or options; ResourceExhausted when the lattice
// would exceed 2^31 / 32 states.
[[nodiscard]] absl::StatusOr<GmrfPrior> MakeGmrfPrior(const FieldGrid& grid, const GpParams& params,
                                                      const GmrfOptions& options = {});

// Gives `prior` (made for `grid`) the mean `field_mean`, one value per cell
// in the grid's order, and on each margin state the nearest field cell's,
// so that a map reaching past the field continues it: information = Q mu.
// The precision is unchanged. InvalidArgument when the sizes differ.
[[nodiscard]] absl::Status SetPriorMean(GmrfPrior& prior, const FieldGrid& grid,
                                        const Eigen::VectorXd& field_mean);

// GMRF priors shared between large-field maps of the same shape: the fit and
// the lattice's precision (about 1 s at 90,000 cells) depend only on the
// grid's shape and resolution, the GP parameters and the options, not on
// where the field lies or what stands on it, so missions over one kind of
// field (and a replica taking over a site's missions) compute it once.
// Thread-safe; holds at most `capacity` priors (16 MB each at 90,000 cells),
// the least recently used dropped beyond that.
//
//   GmrfPriorCache cache(/*capacity=*/2);
//   OAIPP_ASSIGN_OR_RETURN(auto prior, cache.Get(grid, GpParams::PaperPreset(1.0)));
//   OAIPP_ASSIGN_OR_RETURN(SparseGpMap map, SparseGpMap::FromPrior(grid, *prior));  // a copy
class GmrfPriorCache {
 public:
  // capacity >= 1 (smaller values are raised to 1).
  explicit GmrfPriorCache(int capacity = 2);
  // MakeGmrfPrior(grid, params, options), equal bit for bit: computed on the
  // first request for its key and shared after that. Errors as
  // MakeGmrfPrior, and not remembered.
  [[nodiscard]] absl::StatusOr<std::shared_ptr<const GmrfPrior>> Get(
      const FieldGrid& grid, const GpParams& params, const GmrfOptions& options = {});
  // How many priors were computed (cache misses).
  [[nodiscard]] std::int64_t computations() const { return priors_.computations(); }

 private:
  struct Key {
    PriorShapeKey shape;
    double prior_mean = 0.0;  // Q mu0 is the prior's information
    double margin_ranges = 0.0;
    bool operator==(const Key&) const = default;
  };
  SingleFlightCache<Key, GmrfPrior> priors_;
};

}  // namespace oaipp

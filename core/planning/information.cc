#include "core/planning/information.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <type_traits>
#include <unordered_map>

#include "Eigen/Cholesky"
#include "absl/strings/str_cat.h"
#include "core/common/geometry.h"
#include "core/common/status_macros.h"
#include "core/mapping/dense_backend.h"
#include "core/planning/conditioning_chain.h"

namespace oaipp {
namespace {

// Observed cells with merged precisions, in first-seen order.
class MergedCells {
 public:
  void Add(const PoseObservation& pose) {
    for (int cell : pose.cells) {
      auto [it, inserted] = slot_.try_emplace(cell, static_cast<int>(cells_.size()));
      if (inserted) {
        cells_.push_back(cell);
        precision_.push_back(0.0);
      }
      precision_[it->second] += 1.0 / pose.variance;
    }
  }
  [[nodiscard]] bool empty() const { return cells_.empty(); }
  [[nodiscard]] const std::vector<int>& cells() const { return cells_; }
  // The cell's index in cells(), or -1 when it is not among them.
  [[nodiscard]] int Slot(int cell) const {
    const auto it = slot_.find(cell);
    return it == slot_.end() ? -1 : it->second;
  }
  // The merged noise variance of cells()[slot].
  [[nodiscard]] double Noise(int slot) const { return 1.0 / precision_[slot]; }

  // Lower Cholesky factor of P_KK + diag(1 / precision).
  [[nodiscard]] Eigen::LLT<Eigen::MatrixXd> Factor(const Eigen::MatrixXd& cov) const {
    const auto m = static_cast<Eigen::Index>(cells_.size());
    Eigen::MatrixXd s(m, m);
    for (Eigen::Index b = 0; b < m; ++b) {
      for (Eigen::Index a = b; a < m; ++a) s(a, b) = cov(cells_[a], cells_[b]);
      s(b, b) += 1.0 / precision_[b];
    }
    return Eigen::LLT<Eigen::MatrixXd>(s);  // reads the lower triangle only
  }

  // The same factor as a matrix (L in its lower triangle), computed by the
  // dense backend (core/mapping/dense_backend.h; Eigen's bits by default).
  // In double or single precision; with `ok`, whether it succeeded.
  template <typename Scalar = double>
  [[nodiscard]] Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> FactorLower(
      const DenseBackend& backend, const Eigen::MatrixXd& cov, bool* ok = nullptr) const {
    std::vector<int> order(cells_.size());
    std::iota(order.begin(), order.end(), 0);
    return FactorLower<Scalar>(backend, cov, order, ok);
  }

  // The same factor with the cells taken in `order` (slots, a permutation
  // of 0 .. size - 1), in double or single precision.
  // With `ok`, whether the factorisation succeeded.
  template <typename Scalar = double>
  [[nodiscard]] Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> FactorLower(
      const DenseBackend& backend, const Eigen::MatrixXd& cov, const std::vector<int>& order,
      bool* ok = nullptr) const {
    const auto m = static_cast<Eigen::Index>(order.size());
    Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> s(m, m);
    for (Eigen::Index b = 0; b < m; ++b) {
      const int cb = cells_[order[b]];
      for (Eigen::Index a = b; a < m; ++a) {
        s(a, b) = static_cast<Scalar>(cov(cells_[order[a]], cb));
      }
      s(b, b) += static_cast<Scalar>(1.0 / precision_[order[b]]);
    }
    // Positive definite by construction (a covariance plus positive noise);
    // like Factor's, a failure is not reported unless asked for.
    const bool factored = backend.CholeskyLowerInPlace(s);
    if (ok != nullptr) *ok = factored;
    return s;
  }

  // Lower Cholesky factor of R - P_KK, R = diag(1 / precision): what takes
  // these cells' precision back out of a covariance P that has it
  // (RemovePoses). Positive definite when P holds that precision; nullopt
  // otherwise or when some r_j / (R - P_KK)_jj exceeds `max_amplification`
  // (the subtraction loses about log10 of it in digits).
  [[nodiscard]] std::optional<Eigen::MatrixXd> RemovalFactorLower(const DenseBackend& backend,
                                                                  const Eigen::MatrixXd& cov,
                                                                  double max_amplification) const {
    const auto m = static_cast<Eigen::Index>(cells_.size());
    Eigen::MatrixXd s(m, m);
    for (Eigen::Index b = 0; b < m; ++b) {
      for (Eigen::Index a = b; a < m; ++a) s(a, b) = -cov(cells_[a], cells_[b]);
      const double r = 1.0 / precision_[b];
      s(b, b) += r;
      if (!(s(b, b) > 0.0) || r > max_amplification * s(b, b)) return std::nullopt;
    }
    if (!backend.CholeskyLowerInPlace(s)) return std::nullopt;
    return s;
  }

 private:
  std::vector<int> cells_;
  std::vector<double> precision_;
  std::unordered_map<int, int> slot_;
};

// The adaptive objective takes a seen cell's variance from its merged noise
// r only while r is at most this many times the cell's variance before the
// path (InformationEvaluator::Adaptive): r - r^2 (S^-1)_jj loses about
// log10 of the ratio in digits. Single precision keeps 7 digits, so it
// takes the solve sooner.
template <typename Scalar>
constexpr double kSeenNoiseRatio = 100.0;
template <>
constexpr double kSeenNoiseRatio<float> = 10.0;

// L^-1 B_K: for the fused cells K, L the factor of B_KK + R: the rows whose
// column norms are the variance reductions and whose Frobenius norm is the
// trace reduction.
// In the precision of `lower` (B rounded to it).
template <typename Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> WhitenedRows(
    const DenseBackend& backend, const MergedCells& fused, const Eigen::MatrixXd& base,
    const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& lower) {
  const std::vector<int>& k = fused.cells();
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> rows(static_cast<Eigen::Index>(k.size()),
                                                             base.cols());
  for (Eigen::Index a = 0; a < rows.rows(); ++a) {
    rows.row(a) = base.col(k[a]).transpose().template cast<Scalar>();
  }
  backend.SolveLeftLower(lower, rows);
  return rows;
}

// cov := cov + sign rows^T rows, both triangles.
void RankUpdate(const DenseBackend& backend, double sign, const Eigen::MatrixXd& rows,
                Eigen::MatrixXd& cov) {
  backend.SymmetricRankUpdate(sign, rows.transpose(), cov);
  cov.triangularView<Eigen::StrictlyUpper>() = cov.transpose();
}

}  // namespace

void FusePoses(const DenseBackend& backend, std::span<const PoseObservation> poses,
               Eigen::MatrixXd& cov) {
  MergedCells fused;
  for (const PoseObservation& pose : poses) fused.Add(pose);
  if (fused.empty()) return;
  RankUpdate(backend, -1.0, WhitenedRows(backend, fused, cov, fused.FactorLower(backend, cov)),
             cov);
}

absl::Status RemovePoses(const DenseBackend& backend, std::span<const PoseObservation> poses,
                         double max_amplification, Eigen::MatrixXd& cov) {
  MergedCells removed;
  for (const PoseObservation& pose : poses) removed.Add(pose);
  if (removed.empty()) return absl::OkStatus();
  std::optional<Eigen::MatrixXd> lower =
      removed.RemovalFactorLower(backend, cov, max_amplification);
  if (!lower.has_value()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "RemovePoses: R - P_KK over ", removed.cells().size(),
        " cells is not positive definite, or too close to singular to subtract exactly"));
  }
  RankUpdate(backend, 1.0, WhitenedRows(backend, removed, cov, *lower), cov);
  return absl::OkStatus();
}

std::int64_t DistinctCells(std::span<const PoseObservation> poses) {
  MergedCells merged;
  for (const PoseObservation& pose : poses) merged.Add(pose);
  return static_cast<std::int64_t>(merged.cells().size());
}

absl::Status InformationEvaluator::Condition(std::vector<PoseObservation> prefix,
                                             ConditionedCache* shared, ChainedPrefix chain) {
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    if (prefix[i].scored) {
      return absl::InvalidArgumentError(absl::StrCat(
          "prefix[", i, "].scored: a conditioned prefix earns nothing, must be false"));
    }
  }
  prefix_.clear();
  conditioned_.reset();
  // The detection objective reads the mean alone: nothing to condition.
  if (params_.kind == ObjectiveKind::kDetection) return absl::OkStatus();
  base_squared_.resize(0, 0);
  work_without_square_ = 0.0;
  MergedCells fused;
  for (const PoseObservation& pose : prefix) fused.Add(pose);
  if (fused.empty()) return absl::OkStatus();
  auto compute = [&]() -> absl::StatusOr<Eigen::MatrixXd> {
    Eigen::MatrixXd conditioned = cov_;
    FusePoses(params_.dense_backend, prefix, conditioned);
    return conditioned;
  };
  if (chain.chain != nullptr) {
    OAIPP_ASSIGN_OR_RETURN(
        conditioned_, chain.chain->Condition(cov_, chain.source, prefix, params_.dense_backend));
  } else if (shared != nullptr) {
    PrefixKey key;
    for (const PoseObservation& pose : prefix) {
      key.cells.push_back(pose.cells);
      key.variances.push_back(pose.variance);
    }
    OAIPP_ASSIGN_OR_RETURN(conditioned_, shared->Get(key, compute));
  } else {
    OAIPP_ASSIGN_OR_RETURN(Eigen::MatrixXd own, compute());
    conditioned_ = std::make_shared<const Eigen::MatrixXd>(std::move(own));
  }
  prefix_ = std::move(prefix);
  return absl::OkStatus();
}

std::size_t InformationEvaluator::PrefixLength(std::span<const PoseObservation> poses) const {
  if (prefix_.empty() || poses.size() < prefix_.size()) return 0;
  for (std::size_t i = 0; i < prefix_.size(); ++i) {
    const PoseObservation& a = poses[i];
    const PoseObservation& b = prefix_[i];
    if (a.scored || a.variance != b.variance || a.cells != b.cells) return 0;
  }
  return prefix_.size();
}

double InformationEvaluator::Evaluate(std::span<const PoseObservation> poses) const {
  if (params_.kind == ObjectiveKind::kDetection) return Detection(poses);
  const std::size_t skip = PrefixLength(poses);
  if (skip == 0 && !prefix_.empty()) ++prefix_misses_;
  const Eigen::MatrixXd& base = skip > 0 ? *conditioned_ : cov_;
  const auto rest = poses.subspan(skip);
  return params_.kind == ObjectiveKind::kAdaptive
             ? Adaptive(rest, base)
             : NonAdaptive(rest, base, skip > 0 || prefix_.empty());
}

Eigen::VectorXd InformationEvaluator::PosteriorVariances(
    std::span<const PoseObservation> poses) const {
  const std::size_t skip = PrefixLength(poses);
  const Eigen::MatrixXd& base = skip > 0 ? *conditioned_ : cov_;
  MergedCells fused;
  for (const PoseObservation& pose : poses.subspan(skip)) fused.Add(pose);
  Eigen::VectorXd var = base.diagonal();
  if (fused.empty()) return var;
  const DenseBackend& backend = params_.dense_backend;
  if (params_.single_precision) {
    // A factor that fails in single precision (a covariance plus noise
    // should not) takes double's below.
    bool factored = false;
    const Eigen::MatrixXf lower = fused.FactorLower<float>(backend, base, &factored);
    if (factored) {
      const Eigen::MatrixXf rows = WhitenedRows(backend, fused, base, lower);
      for (Eigen::Index c = 0; c < rows.cols(); ++c) {
        var[c] -= rows.col(c).cast<double>().squaredNorm();
      }
      return var;
    }
  }
  var -= WhitenedRows(backend, fused, base, fused.FactorLower(backend, base))
             .colwise()
             .squaredNorm()
             .transpose();
  return var;
}

const std::vector<int>& InformationEvaluator::EarningCells(const PoseObservation& pose,
                                                           std::vector<int>& scratch) const {
  if (area_.empty()) return pose.cells;
  scratch.clear();
  for (int c : pose.cells) {
    if (InArea(c)) scratch.push_back(c);
  }
  return scratch;
}

double InformationEvaluator::PoseValue(const PoseObservation& pose,
                                       const Eigen::VectorXd& variances) const {
  const double reward = pose.scored ? params_.AltitudeReward(pose.altitude_m) : 0.0;
  if (reward <= 0.0) return 0.0;
  double av = 0.0;
  for (int c : pose.cells) {
    if (!InArea(c)) continue;
    av += params_.CellValue(mean_[c], variances[c], pose.variance, PriorVariance(c));
  }
  return av * reward;
}

double InformationEvaluator::Adaptive(std::span<const PoseObservation> poses,
                                      const Eigen::MatrixXd& base) const {
  return params_.single_precision ? AdaptiveIn<float>(poses, base)
                                  : AdaptiveIn<double>(poses, base);
}

template <typename Scalar>
double InformationEvaluator::AdaptiveIn(std::span<const PoseObservation> poses,
                                        const Eigen::MatrixXd& base) const {
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
  double total = 0.0;
  MergedCells fused;
  std::vector<Eigen::Index> seen, unseen;  // positions in the pose's cells
  std::vector<int> seen_slots;             // the seen cells' slots in `fused`
  std::vector<int> order;                  // slots of `fused`, seen cells last
  std::vector<char> is_seen;
  std::vector<int> inside;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const PoseObservation& pose = poses[i];
    const double reward = pose.scored ? params_.AltitudeReward(pose.altitude_m) : 0.0;
    // The cells that earn; each one's predicted variance depends on the
    // fused cells only, so the others are skipped here and fused below.
    const std::vector<int>& cells = reward > 0.0 ? EarningCells(pose, inside) : pose.cells;
    if (reward > 0.0 && !cells.empty()) {
      const auto m = static_cast<Eigen::Index>(cells.size());
      Eigen::VectorXd var(m);
      for (Eigen::Index j = 0; j < m; ++j) var[j] = base(cells[j], cells[j]);
      if (!fused.empty()) {
        // With K the fused cells, S = B_KK + R = L L^T and a cell j of the
        // pose: var_j = B_jj - |L^-1 B_Kj|^2. For j in K, B_Kj = (S - R) e_j
        // gives var_j = r_j - r_j^2 (S^-1)_jj instead, and with K ordered so
        // that the pose's seen cells O come last, (S^-1)_OO = (L_OO
        // L_OO^T)^-1: a triangular inverse of |O| rows rather than a solve
        // against all |K| rows per seen cell. Consecutive shots overlap, so
        // most cells are seen ones. A cell whose merged noise r_j is far
        // above its variance (a detector at its worst altitude) takes the
        // solve: r_j - r_j^2 (S^-1)_jj would cancel there. So does a cell
        // listed twice.
        seen.clear();
        seen_slots.clear();
        unseen.clear();
        const auto k = static_cast<Eigen::Index>(fused.cells().size());
        is_seen.assign(static_cast<std::size_t>(k), 0);
        for (Eigen::Index j = 0; j < m; ++j) {
          const int slot = fused.Slot(cells[j]);
          if (slot >= 0 && !is_seen[static_cast<std::size_t>(slot)] &&
              fused.Noise(slot) <= kSeenNoiseRatio<Scalar> * var[j]) {
            seen.push_back(j);
            seen_slots.push_back(slot);
            is_seen[static_cast<std::size_t>(slot)] = 1;
          } else {
            unseen.push_back(j);
          }
        }
        order.clear();
        for (int slot = 0; slot < k; ++slot) {
          if (!is_seen[static_cast<std::size_t>(slot)]) order.push_back(slot);
        }
        order.insert(order.end(), seen_slots.begin(), seen_slots.end());
        bool factored = true;
        const Matrix lower =
            fused.template FactorLower<Scalar>(params_.dense_backend, base, order, &factored);
        if constexpr (!std::is_same_v<Scalar, double>) {
          // A covariance plus noise should factor in single precision too;
          // where it does not, the whole value is taken in double.
          if (!factored) return AdaptiveIn<double>(poses, base);
        }
        if (!unseen.empty()) {
          const auto u = static_cast<Eigen::Index>(unseen.size());
          Matrix cross(k, u);  // B_K,J for the unseen cells
          for (Eigen::Index b = 0; b < u; ++b) {
            const int cell = cells[unseen[b]];
            for (Eigen::Index a = 0; a < k; ++a) {
              cross(a, b) = static_cast<Scalar>(base(fused.cells()[order[a]], cell));
            }
          }
          params_.dense_backend.SolveLeftLower(lower, cross);
          for (Eigen::Index b = 0; b < u; ++b) {
            var[unseen[b]] -= cross.col(b).template cast<double>().squaredNorm();
          }
        }
        if (!seen.empty()) {
          const auto o = static_cast<Eigen::Index>(seen.size());
          Matrix inv = lower.bottomRightCorner(o, o);
          params_.dense_backend.InverseLowerInPlace(inv);
          for (Eigen::Index b = 0; b < o; ++b) {
            // (S^-1)_jj: column b of L_OO^-1, which is zero above row b.
            const double s_inv = inv.col(b).tail(o - b).template cast<double>().squaredNorm();
            const double r = fused.Noise(seen_slots[b]);
            var[seen[b]] = r - r * r * s_inv;
          }
        }
      }
      double av = 0.0;
      for (Eigen::Index j = 0; j < m; ++j) {
        const int cell = cells[j];
        av += params_.CellValue(mean_[cell], var[j], pose.variance, PriorVariance(cell));
      }
      total += av * reward;
    }
    if (i + 1 < poses.size()) fused.Add(pose);
  }
  return total;
}

double InformationEvaluator::Detection(std::span<const PoseObservation> poses) const {
  // The probability that the person, if in x, is still unseen: the product
  // of (1 - p_j) over the poses so far that see x (1 for a cell not seen).
  std::unordered_map<int, double> unseen;
  double total = 0.0;
  double weight = 1.0;  // gamma^i
  for (const PoseObservation& pose : poses) {
    // At or above h_sat a pose sees nothing, as in the adaptive objective.
    const double p =
        pose.altitude_m >= params_.h_sat_m ? 0.0 : std::clamp(pose.detection_probability, 0.0, 1.0);
    double mass = 0.0;
    for (int c : pose.cells) {
      if (!InArea(c)) continue;  // no mass to find there
      auto [it, inserted] = unseen.try_emplace(c, 1.0);
      mass += std::clamp(mean_[c], 0.0, 1.0) * it->second;
      it->second *= 1.0 - p;
    }
    if (pose.scored) {
      total += weight * p * mass;
      weight *= params_.detection_discount;
    }
  }
  return total;
}

double InformationEvaluator::NonAdaptive(std::span<const PoseObservation> poses,
                                         const Eigen::MatrixXd& base, bool base_is_cached) const {
  // Unscored poses set the baseline: the trace after them, not before.
  MergedCells baseline, all;
  for (const PoseObservation& pose : poses) {
    all.Add(pose);
    if (!pose.scored) baseline.Add(pose);
  }
  auto reduction = [&](const MergedCells& fused) {
    if (fused.empty()) return 0.0;
    const std::vector<int>& k = fused.cells();
    const auto m = static_cast<Eigen::Index>(k.size());
    const Eigen::LLT<Eigen::MatrixXd> factor = fused.Factor(base);
    if (base_is_cached && m < base.cols() / 2 && UseBaseSquared(m, base.cols())) {
      // sum((B_KK + R)^-1 o (B A B)_KK), A the area's diagonal 0/1 (the
      // identity without one): about m^3 once B A B is known.
      const Eigen::MatrixXd& g = BaseSquared();
      const Eigen::MatrixXd s_inv = factor.solve(Eigen::MatrixXd::Identity(m, m));
      double sum = 0.0;
      for (Eigen::Index b = 0; b < m; ++b) {
        for (Eigen::Index a = 0; a < m; ++a) sum += s_inv(a, b) * g(k[a], k[b]);
      }
      return sum;
    }
    // |L^-1 B_K,:|_F^2 over the area's columns: m^2 n, cheaper when K is
    // most of the field.
    const auto rows = WhitenedRows(params_.dense_backend, fused, base, factor.matrixLLT());
    if (area_.empty()) return rows.squaredNorm();
    double sum = 0.0;
    for (Eigen::Index c = 0; c < rows.cols(); ++c) {
      if (InArea(static_cast<int>(c))) sum += rows.col(c).squaredNorm();
    }
    return sum;
  };
  return reduction(all) - reduction(baseline);
}

bool InformationEvaluator::UseBaseSquared(Eigen::Index m, Eigen::Index n) const {
  if (base_squared_.size() > 0) return true;
  const double build =
      0.5 * static_cast<double>(n) * static_cast<double>(n) * static_cast<double>(n);
  if (work_without_square_ >= build) return true;
  work_without_square_ += static_cast<double>(m) * static_cast<double>(m) * static_cast<double>(n);
  return false;
}

const Eigen::MatrixXd& InformationEvaluator::BaseSquared() const {
  if (base_squared_.size() == 0) {
    // B symmetric: B^2 = B B^T, a symmetric rank-n update (half a product);
    // with an area, B A B = B_:A B_:A^T, the update by its columns only.
    const Eigen::MatrixXd& base = prefix_.empty() ? cov_ : *conditioned_;
    base_squared_ = Eigen::MatrixXd::Zero(base.rows(), base.cols());
    if (area_.empty()) {
      base_squared_.selfadjointView<Eigen::Lower>().rankUpdate(base);
    } else {
      std::vector<Eigen::Index> inside;
      for (Eigen::Index c = 0; c < base.cols(); ++c) {
        if (InArea(static_cast<int>(c))) inside.push_back(c);
      }
      // No column (an area off this map): B A B = 0, and Eigen's product
      // must not see an empty operand.
      if (!inside.empty()) {
        const Eigen::MatrixXd columns = base(Eigen::all, inside);
        base_squared_.selfadjointView<Eigen::Lower>().rankUpdate(columns);
      }
    }
    base_squared_.triangularView<Eigen::StrictlyUpper>() = base_squared_.transpose();
  }
  return base_squared_;
}

double ReferenceInformation(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
                            const InformationParams& params, std::span<const PoseObservation> poses,
                            std::span<const std::uint8_t> area) {
  auto inside = [&](int c) { return area.empty() || area[static_cast<std::size_t>(c)] != 0; };
  // The trace over the area's cells.
  auto trace = [&](const Eigen::MatrixXd& m) {
    double sum = 0.0;
    for (Eigen::Index c = 0; c < m.rows(); ++c) {
      if (inside(static_cast<int>(c))) sum += m(c, c);
    }
    return sum;
  };
  Eigen::MatrixXd p = covariance;  // the copy the fast path avoids
  double total = 0.0;
  double trace_start = trace(p);
  for (const PoseObservation& pose : poses) {
    const auto m = static_cast<Eigen::Index>(pose.cells.size());
    if (params.kind == ObjectiveKind::kAdaptive && pose.scored) {
      const double reward = params.AltitudeReward(pose.altitude_m);
      double av = 0.0;
      for (int c : pose.cells) {
        if (inside(c)) av += params.CellValue(mean[c], p(c, c), pose.variance, covariance(c, c));
      }
      total += av * reward;
    }
    if (m == 0) continue;
    // Kalman covariance update: P -= P_:J (P_JJ + var I)^-1 P_J:.
    Eigen::MatrixXd pj(p.rows(), m);
    for (Eigen::Index j = 0; j < m; ++j) pj.col(j) = p.col(pose.cells[j]);
    Eigen::MatrixXd s(m, m);
    for (Eigen::Index j = 0; j < m; ++j) s.col(j) = pj.col(j)(pose.cells);
    s.diagonal().array() += pose.variance;
    const Eigen::MatrixXd gain = Eigen::LLT<Eigen::MatrixXd>(s).solve(pj.transpose());  // S^-1 P_J:
    p -= pj * gain;
    if (!pose.scored) trace_start = trace(p);
  }
  if (params.kind == ObjectiveKind::kNonAdaptive) return trace_start - trace(p);
  return total;
}

}  // namespace oaipp

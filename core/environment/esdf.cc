#include "core/environment/esdf.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/common/field_error.h"

namespace oaipp {
namespace {

constexpr float kFar = std::numeric_limits<float>::infinity();

// One-dimensional squared distance transform of a sampled function
// (Felzenszwalb & Huttenlocher 2012, Algorithm 1): d[q] = min_p (q - p)^2 + f[p].
// Sites with f = +inf are skipped. `v` and `z` are scratch of size n and n + 1.
void DistanceTransform1d(const float* f, int n, float* d, int* v, double* z) {
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (!(f[q] < kFar)) continue;
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -std::numeric_limits<double>::infinity();
      z[1] = std::numeric_limits<double>::infinity();
      continue;
    }
    double s;
    while (true) {
      const int p = v[k];
      s = ((static_cast<double>(f[q]) + double(q) * q) -
           (static_cast<double>(f[p]) + double(p) * p)) /
          (2.0 * (q - p));
      if (s > z[k] || k == 0) break;  // z[0] = -inf: the first site always stays
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = std::numeric_limits<double>::infinity();
  }
  if (k < 0) {
    std::fill(d, d + n, kFar);
    return;
  }
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < q) ++j;
    const double dq = q - v[j];
    d[q] = static_cast<float>(dq * dq + f[v[j]]);
  }
}

}  // namespace

namespace {

// Voxels along axis `a` of `domain` (already padded): Create's rule.
double AxisVoxels(const Aabb& domain, int a, double voxel_m) {
  return std::ceil(domain.Size()[a] / voxel_m - 1e-9);
}

}  // namespace

std::int64_t Esdf::VoxelCount(const Aabb& volume, const EsdfConfig& config) {
  constexpr std::int64_t kTooMany = std::numeric_limits<std::int64_t>::max();
  if (!(config.voxel_size_m > 0.0)) return kTooMany;
  const Aabb domain = volume.Inflated(config.truncation_m);
  std::int64_t count = 1;
  for (int a = 0; a < 3; ++a) {
    const double n = AxisVoxels(domain, a, config.voxel_size_m);
    if (!(n <= 1e6)) return kTooMany;
    count *= std::max<std::int64_t>(1, static_cast<std::int64_t>(n));
  }
  return count;
}

absl::StatusOr<Esdf> Esdf::Create(const Aabb& volume, const EsdfConfig& config) {
  if (!AllFinite(volume.min_W) || !AllFinite(volume.max_W)) {
    return absl::InvalidArgumentError("volume: bounds must be finite");
  }
  for (int a = 0; a < 3; ++a) {
    if (!(volume.max_W[a] > volume.min_W[a])) {
      return absl::InvalidArgumentError(absl::StrCat("volume: max must exceed min on axis ", a,
                                                     " (min ", volume.min_W[a], ", max ",
                                                     volume.max_W[a], ")"));
    }
  }
  if (!(config.voxel_size_m > 0.0 && config.voxel_size_m <= 10.0)) {
    return FieldError(absl::StatusCode::kInvalidArgument,
                      absl::StrCat("$0: must be in (0, 10], got ", config.voxel_size_m),
                      {"esdf.voxel_size_m"});
  }
  if (!(config.truncation_m >= config.voxel_size_m && std::isfinite(config.truncation_m))) {
    return FieldError(absl::StatusCode::kInvalidArgument,
                      absl::StrCat("$0: must be finite and >= $1, got ", config.truncation_m),
                      {"esdf.truncation_m", "esdf.voxel_size_m"});
  }
  Esdf esdf;
  esdf.voxel_m_ = config.voxel_size_m;
  esdf.truncation_m_ = config.truncation_m;
  const Aabb domain = volume.Inflated(config.truncation_m);
  esdf.origin_W_ = domain.min_W;
  std::int64_t count = 1;
  for (int a = 0; a < 3; ++a) {
    const double n = AxisVoxels(domain, a, config.voxel_size_m);
    if (n > 1e6) {
      return FieldError(absl::StatusCode::kResourceExhausted,
                        "$0: the grid is too large along one axis", {"esdf.voxel_size_m"});
    }
    esdf.dims_[a] = std::max(1, static_cast<int>(n));
    count *= esdf.dims_[a];
  }
  if (count > config.max_voxels) {
    return FieldError(absl::StatusCode::kResourceExhausted,
                      absl::StrCat("$0: ", count, " voxels exceed the limit of ", config.max_voxels,
                                   "; use a larger voxel"),
                      {"esdf.voxel_size_m"});
  }
  esdf.values_ = std::make_shared<std::vector<float>>(static_cast<std::size_t>(count),
                                                      static_cast<float>(config.truncation_m));
  return esdf;
}

Esdf Esdf::Clone() const {
  Esdf copy;
  copy.dims_ = dims_;
  copy.origin_W_ = origin_W_;
  copy.voxel_m_ = voxel_m_;
  copy.truncation_m_ = truncation_m_;
  copy.values_ = values_;
  copy.last_recomputed_ = last_recomputed_;
  return copy;
}

std::vector<float>& Esdf::Writable() {
  // use_count() == 1 means no other Esdf holds the values, so no other
  // thread can be reading them through one; a stale count above 1 only
  // costs a copy.
  if (values_.use_count() > 1) values_ = std::make_shared<std::vector<float>>(*values_);
  return *values_;
}

VoxelBox Esdf::BoxAround(const Aabb& region_W, double margin_m) const {
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    const double lo = (region_W.min_W[a] - margin_m - origin_W_[a]) / voxel_m_ - 0.5;
    const double hi = (region_W.max_W[a] + margin_m - origin_W_[a]) / voxel_m_ - 0.5;
    // Clamped as doubles first: a region far outside the grid must not
    // overflow the conversion to int.
    const double limit = static_cast<double>(dims_[a]);
    box.lo[a] = static_cast<int>(std::clamp(std::floor(lo), 0.0, limit));
    box.hi[a] = static_cast<int>(std::clamp(std::ceil(hi) + 1.0, 0.0, limit));
  }
  return box;
}

void Esdf::Rebuild(std::span<const Shape* const> shapes) {
  VoxelBox all;
  all.hi = dims_;
  Recompute(shapes, all);
}

void Esdf::Update(std::span<const Shape* const> shapes, const Aabb& changed_W) {
  // Surface voxels can change within half a diagonal of the changed
  // geometry, and a clamped value depends only on surface voxels within the
  // truncation distance.
  const double half_diag = 0.5 * std::sqrt(3.0) * voxel_m_;
  const VoxelBox out = BoxAround(changed_W, half_diag + truncation_m_ + voxel_m_);
  std::int64_t total = static_cast<std::int64_t>(values_->size());
  if (out.Count() * 2 > total) {
    Rebuild(shapes);
    return;
  }
  Recompute(shapes, out);
}

void Esdf::Recompute(std::span<const Shape* const> shapes, const VoxelBox& out) {
  const double half_diag = 0.5 * std::sqrt(3.0) * voxel_m_;
  // Every surface voxel within the truncation distance of `out` lies in `in`.
  const int pad = static_cast<int>(std::ceil(truncation_m_ / voxel_m_)) + 1;
  VoxelBox in;
  for (int a = 0; a < 3; ++a) {
    in.lo[a] = std::max(0, out.lo[a] - pad);
    in.hi[a] = std::min(dims_[a], out.hi[a] + pad);
  }
  const std::array<int, 3> n{in.hi[0] - in.lo[0], in.hi[1] - in.lo[1], in.hi[2] - in.lo[2]};
  const std::int64_t count = static_cast<std::int64_t>(n[0]) * n[1] * n[2];
  last_recomputed_ = out.Count();
  if (count == 0) return;
  auto local = [&](int i, int j, int k) {
    return (i - in.lo[0]) + static_cast<std::int64_t>(n[0]) *
                                ((j - in.lo[1]) + static_cast<std::int64_t>(n[1]) * (k - in.lo[2]));
  };

  // 1. Exact signed distance near each shape (inside its box grown by half a
  //    diagonal): enough to know every surface voxel and every inside voxel.
  std::vector<float> exact(static_cast<std::size_t>(count), kFar);
  for (const Shape* shape : shapes) {
    const VoxelBox b = BoxAround(BoundingBox(*shape), half_diag);
    for (int k = std::max(b.lo[2], in.lo[2]); k < std::min(b.hi[2], in.hi[2]); ++k) {
      for (int j = std::max(b.lo[1], in.lo[1]); j < std::min(b.hi[1], in.hi[1]); ++j) {
        for (int i = std::max(b.lo[0], in.lo[0]); i < std::min(b.hi[0], in.hi[0]); ++i) {
          float& e = exact[local(i, j, k)];
          e = std::min(e, static_cast<float>(SignedDistance(*shape, VoxelCentre(i, j, k))));
        }
      }
    }
  }

  // 2. Squared distance (in voxels^2) to the nearest surface voxel centre,
  //    one axis at a time.
  std::vector<float> d2(static_cast<std::size_t>(count));
  for (std::int64_t idx = 0; idx < count; ++idx) {
    d2[idx] = std::abs(exact[idx]) <= half_diag ? 0.0f : kFar;
  }
  const int longest = std::max({n[0], n[1], n[2]});
  std::vector<float> line_in(longest), line_out(longest);
  std::vector<int> v(longest);
  std::vector<double> z(longest + 1);
  const std::array<std::int64_t, 3> stride{1, n[0], static_cast<std::int64_t>(n[0]) * n[1]};
  for (int axis = 0; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3;
    const int a2 = (axis + 2) % 3;
    for (int u = 0; u < n[a2]; ++u) {
      for (int w = 0; w < n[a1]; ++w) {
        const std::int64_t base = u * stride[a2] + w * stride[a1];
        const std::int64_t s = stride[axis];
        bool any = false;
        for (int q = 0; q < n[axis]; ++q) {
          line_in[q] = d2[base + q * s];
          any |= line_in[q] < kFar;
        }
        if (!any) continue;  // nothing to propagate along this line
        DistanceTransform1d(line_in.data(), n[axis], line_out.data(), v.data(), z.data());
        for (int q = 0; q < n[axis]; ++q) d2[base + q * s] = line_out[q];
      }
    }
  }

  // 3. Write the output box: exact values on surface voxels, the transform
  //    elsewhere (within half a diagonal of the truth), signed by the exact
  //    inside test, clamped.
  const float trunc = static_cast<float>(truncation_m_);
  std::vector<float>& values = Writable();
  for (int k = out.lo[2]; k < out.hi[2]; ++k) {
    for (int j = out.lo[1]; j < out.hi[1]; ++j) {
      for (int i = out.lo[0]; i < out.hi[0]; ++i) {
        const std::int64_t l = local(i, j, k);
        const float e = exact[l];
        float value;
        if (std::abs(e) <= half_diag) {
          value = e;
        } else {
          const float dist = static_cast<float>(voxel_m_ * std::sqrt(static_cast<double>(d2[l])));
          // Where an obstacle's own exact distance is known it bounds the
          // union's: from above outside (the minimum over all obstacles is
          // exact, one obstacle's is an upper bound), from below inside
          // (every point of the union's surface lies outside each obstacle).
          // It also covers surfaces beyond the grid's edge.
          value = e < 0.0f ? -std::min(std::max(dist, -e), trunc) : std::min({dist, e, trunc});
        }
        values[Index(i, j, k)] = std::clamp(value, -trunc, trunc);
      }
    }
  }
}

double Esdf::DistanceAndGradient(const Vec3& p_W, Vec3* gradient_W) const {
  // Continuous voxel coordinates with voxel centres at integers.
  std::array<int, 3> i0;
  std::array<double, 3> t;
  for (int a = 0; a < 3; ++a) {
    double c = (p_W[a] - origin_W_[a]) / voxel_m_ - 0.5;
    c = std::clamp(c, 0.0, static_cast<double>(dims_[a] - 1));
    i0[a] = std::min(static_cast<int>(std::floor(c)), std::max(0, dims_[a] - 2));
    t[a] = dims_[a] > 1 ? c - i0[a] : 0.0;
  }
  const std::vector<float>& values = *values_;
  auto at = [&](int di, int dj, int dk) {
    return static_cast<double>(
        values[Index(std::min(i0[0] + di, dims_[0] - 1), std::min(i0[1] + dj, dims_[1] - 1),
                     std::min(i0[2] + dk, dims_[2] - 1))]);
  };
  const double c000 = at(0, 0, 0), c100 = at(1, 0, 0), c010 = at(0, 1, 0), c110 = at(1, 1, 0);
  const double c001 = at(0, 0, 1), c101 = at(1, 0, 1), c011 = at(0, 1, 1), c111 = at(1, 1, 1);
  const double c00 = c000 + t[0] * (c100 - c000), c10 = c010 + t[0] * (c110 - c010);
  const double c01 = c001 + t[0] * (c101 - c001), c11 = c011 + t[0] * (c111 - c011);
  const double c0 = c00 + t[1] * (c10 - c00), c1 = c01 + t[1] * (c11 - c01);
  if (gradient_W != nullptr) {
    const double dx0 = (c100 - c000) + t[1] * ((c110 - c010) - (c100 - c000));
    const double dx1 = (c101 - c001) + t[1] * ((c111 - c011) - (c101 - c001));
    const double gx = dx0 + t[2] * (dx1 - dx0);
    const double gy = (c10 - c00) + t[2] * ((c11 - c01) - (c10 - c00));
    const double gz = c1 - c0;
    *gradient_W = Vec3(gx, gy, gz) / voxel_m_;
  }
  return c0 + t[2] * (c1 - c0);
}

double Esdf::Distance(const Vec3& p_W) const { return DistanceAndGradient(p_W, nullptr); }

namespace {

// FNV-1a over the value bits: a key for the pool's table, never trusted
// alone (equal keys are compared in full).
std::uint64_t HashValues(std::span<const float> values) {
  std::uint64_t h = 1469598103934665603ull;
  for (const float v : values) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    h = (h ^ bits) * 1099511628211ull;
  }
  return h;
}

}  // namespace

bool EsdfPool::Share(Esdf& esdf) {
  {
    // A clone of a pooled grid (a mission copied from the server's world
    // cache) is pooled already: no need to hash its megabytes again.
    absl::MutexLock lock(&mu_);
    for (const auto& [key, e] : grids_) {
      if (e.values.lock() == esdf.values_) return false;
    }
  }
  const std::uint64_t key = HashValues(*esdf.values_);
  absl::MutexLock lock(&mu_);
  // Expired entries are dropped as they are met.
  auto [first, last] = grids_.equal_range(key);
  for (auto it = first; it != last;) {
    std::shared_ptr<std::vector<float>> held = it->second.values.lock();
    if (held == nullptr) {
      it = grids_.erase(it);
      continue;
    }
    const Entry& e = it->second;
    if (held == esdf.values_) return false;  // already the pooled grid
    if (e.dims == esdf.dims_ && e.origin_W == esdf.origin_W_ && e.voxel_m == esdf.voxel_m_ &&
        e.truncation_m == esdf.truncation_m_ && held->size() == esdf.values_->size() &&
        std::memcmp(held->data(), esdf.values_->data(), held->size() * sizeof(float)) == 0) {
      esdf.values_ = std::move(held);
      return true;
    }
    ++it;
  }
  grids_.emplace(
      key, Entry{esdf.dims_, esdf.origin_W_, esdf.voxel_m_, esdf.truncation_m_, esdf.values_});
  return false;
}

int EsdfPool::size() const {
  absl::MutexLock lock(&mu_);
  int alive = 0;
  for (const auto& [key, e] : grids_) alive += e.values.expired() ? 0 : 1;
  return alive;
}

}  // namespace oaipp

#include "core/environment/esdf.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/common/field_error.h"

namespace oaipp {

namespace {

// Voxels along axis `a` of `domain` (already padded): Create's rule.
double AxisVoxels(const Aabb& domain, int a, double voxel_m) {
  return std::ceil(domain.Size()[a] / voxel_m - 1e-9);
}

int CeilDiv(int a, int b) { return (a + b - 1) / b; }

// The grid Create would make over `volume`: its voxels per axis, or false
// when an axis is too long.
bool GridDims(const Aabb& volume, const EsdfConfig& config, std::array<int, 3>* dims) {
  const Aabb domain = volume.Inflated(config.truncation_m);
  for (int a = 0; a < 3; ++a) {
    const double n = AxisVoxels(domain, a, config.voxel_size_m);
    if (!(n <= 1e6)) return false;
    (*dims)[a] = std::max(1, static_cast<int>(n));
  }
  return true;
}

// The voxel box within `margin_m` of `region_W` on a grid at `origin_W`.
VoxelBox VoxelsAround(const Aabb& region_W, double margin_m, const Vec3& origin_W, double voxel_m,
                      const std::array<int, 3>& dims) {
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    const double lo = (region_W.min_W[a] - margin_m - origin_W[a]) / voxel_m - 0.5;
    const double hi = (region_W.max_W[a] + margin_m - origin_W[a]) / voxel_m - 0.5;
    // Clamped as doubles first: a region far outside the grid must not
    // overflow the conversion to int.
    const double limit = static_cast<double>(dims[a]);
    box.lo[a] = static_cast<int>(std::clamp(std::floor(lo), 0.0, limit));
    box.hi[a] = static_cast<int>(std::clamp(std::ceil(hi) + 1.0, 0.0, limit));
  }
  return box;
}

VoxelBox BlocksOfVoxels(const VoxelBox& voxels) {
  VoxelBox blocks;
  for (int a = 0; a < 3; ++a) {
    blocks.lo[a] = voxels.lo[a] / Esdf::kBlock;
    blocks.hi[a] = voxels.hi[a] > voxels.lo[a] ? CeilDiv(voxels.hi[a], Esdf::kBlock) : blocks.lo[a];
  }
  return blocks;
}

// How far an obstacle's geometry reaches into a grid's values.
double ReachOf(double voxel_m, double truncation_m) {
  return 0.5 * std::sqrt(3.0) * voxel_m + truncation_m + voxel_m;
}

}  // namespace

std::int64_t Esdf::VoxelCount(const Aabb& volume, const EsdfConfig& config) {
  constexpr std::int64_t kTooMany = std::numeric_limits<std::int64_t>::max();
  std::array<int, 3> dims;
  if (!(config.voxel_size_m > 0.0) || !GridDims(volume, config, &dims)) return kTooMany;
  return static_cast<std::int64_t>(dims[0]) * dims[1] * dims[2];
}

std::int64_t Esdf::HeldVoxelBound(const Aabb& volume, const EsdfConfig& config,
                                  std::span<const Shape* const> shapes) {
  absl::StatusOr<Esdf> grid = Create(volume, config);
  if (!grid.ok()) return std::numeric_limits<std::int64_t>::max();
  return grid->HeldVoxelBound(shapes);
}

std::int64_t Esdf::HeldVoxelBound(std::span<const Shape* const> shapes) const {
  const std::int64_t table = static_cast<std::int64_t>(bdims_[0]) * bdims_[1] * bdims_[2];
  VoxelBox all;
  all.hi = bdims_;
  const std::vector<std::uint8_t> kinds = Classify(shapes, all, nullptr);
  return table + kBlockVoxels * std::count(kinds.begin(), kinds.end(), kNearBlock);
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
  if (config.build_threads < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("esdf.build_threads: must be >= 1, got ", config.build_threads));
  }
  Esdf esdf;
  esdf.voxel_m_ = config.voxel_size_m;
  esdf.truncation_m_ = config.truncation_m;
  esdf.max_voxels_ = config.max_voxels;
  esdf.build_threads_ = config.build_threads;
  esdf.origin_W_ = volume.Inflated(config.truncation_m).min_W;
  if (!GridDims(volume, config, &esdf.dims_)) {
    return FieldError(absl::StatusCode::kResourceExhausted,
                      "$0: the grid is too large along one axis", {"esdf.voxel_size_m"});
  }
  std::int64_t blocks = 1;
  for (int a = 0; a < 3; ++a) {
    esdf.bdims_[a] = CeilDiv(esdf.dims_[a], kBlock);
    blocks *= esdf.bdims_[a];
  }
  if (blocks > config.max_voxels) {
    return FieldError(absl::StatusCode::kResourceExhausted,
                      absl::StrCat("$0: a table of ", blocks, " blocks exceeds the limit of ",
                                   config.max_voxels, " voxels; use a larger voxel"),
                      {"esdf.voxel_size_m"});
  }
  esdf.grid_ = std::make_shared<Grid>();
  esdf.grid_->slots.assign(static_cast<std::size_t>(blocks), kFree);
  return esdf;
}

Esdf Esdf::Clone() const {
  Esdf copy;
  copy.dims_ = dims_;
  copy.bdims_ = bdims_;
  copy.origin_W_ = origin_W_;
  copy.voxel_m_ = voxel_m_;
  copy.truncation_m_ = truncation_m_;
  copy.max_voxels_ = max_voxels_;
  copy.build_threads_ = build_threads_;
  copy.grid_ = grid_;
  copy.last_recomputed_ = last_recomputed_;
  return copy;
}

Esdf::Grid& Esdf::Writable() {
  // use_count() == 1 means no other Esdf holds the values, so no other
  // thread can be reading them through one; a stale count above 1 only
  // costs a copy.
  if (grid_.use_count() > 1) grid_ = std::make_shared<Grid>(*grid_);
  return *grid_;
}

float Esdf::Value(int i, int j, int k) const {
  const std::int32_t slot = grid_->slots[BlockIndex(i / kBlock, j / kBlock, k / kBlock)];
  if (slot < 0) {
    return static_cast<float>(slot == kFree ? truncation_m_ : -truncation_m_);
  }
  return grid_->blocks[static_cast<std::size_t>(slot) * kBlockVoxels + (i % kBlock) +
                       kBlock * ((j % kBlock) + kBlock * (k % kBlock))];
}

std::vector<float> Esdf::DenseValues() const {
  std::vector<float> values;
  values.reserve(static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2]);
  for (int k = 0; k < dims_[2]; ++k) {
    for (int j = 0; j < dims_[1]; ++j) {
      for (int i = 0; i < dims_[0]; ++i) values.push_back(Value(i, j, k));
    }
  }
  return values;
}

std::int64_t Esdf::allocated_blocks() const {
  return static_cast<std::int64_t>(grid_->blocks.size() / kBlockVoxels - grid_->unused.size());
}

std::size_t Esdf::MemoryBytes() const {
  return grid_->slots.capacity() * sizeof(std::int32_t) + grid_->blocks.size() * sizeof(float) +
         grid_->unused.capacity() * sizeof(std::int32_t);
}

namespace {

// Calls visit(block values or nullptr, code) for every block slot in order:
// what two grids must agree on to hold equal values.
template <typename Visit>
void ForEachBlock(const std::vector<std::int32_t>& slots, const std::vector<float>& blocks,
                  Visit visit) {
  for (std::size_t b = 0; b < slots.size(); ++b) {
    const std::int32_t s = slots[b];
    visit(s < 0 ? nullptr : blocks.data() + static_cast<std::size_t>(s) * Esdf::kBlockVoxels, s);
  }
}

}  // namespace

bool Esdf::SameValues(const Esdf& other) const {
  if (dims_ != other.dims_ || origin_W_ != other.origin_W_ || voxel_m_ != other.voxel_m_ ||
      truncation_m_ != other.truncation_m_) {
    return false;
  }
  if (grid_ == other.grid_) return true;
  const Grid& a = *grid_;
  const Grid& b = *other.grid_;
  for (std::size_t i = 0; i < a.slots.size(); ++i) {
    const std::int32_t sa = a.slots[i], sb = b.slots[i];
    if (sa < 0 || sb < 0) {
      if (sa != sb) return false;
      continue;
    }
    if (std::memcmp(a.blocks.data() + static_cast<std::size_t>(sa) * kBlockVoxels,
                    b.blocks.data() + static_cast<std::size_t>(sb) * kBlockVoxels,
                    kBlockVoxels * sizeof(float)) != 0) {
      return false;
    }
  }
  return true;
}

double Esdf::Reach() const { return ReachOf(voxel_m_, truncation_m_); }

VoxelBox Esdf::BoxAround(const Aabb& region_W, double margin_m) const {
  return VoxelsAround(region_W, margin_m, origin_W_, voxel_m_, dims_);
}

VoxelBox Esdf::BlocksOf(const VoxelBox& voxels) const { return BlocksOfVoxels(voxels); }

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
  // The eight corners usually lie in one block (7 in 8 per axis); a block
  // not allocated is constant.
  const Grid& grid = *grid_;
  const std::array<int, 3> i1{std::min(i0[0] + 1, dims_[0] - 1), std::min(i0[1] + 1, dims_[1] - 1),
                              std::min(i0[2] + 1, dims_[2] - 1)};
  const float* block = nullptr;
  if (i0[0] / kBlock == i1[0] / kBlock && i0[1] / kBlock == i1[1] / kBlock &&
      i0[2] / kBlock == i1[2] / kBlock) {
    const std::int32_t slot =
        grid.slots[BlockIndex(i0[0] / kBlock, i0[1] / kBlock, i0[2] / kBlock)];
    if (slot < 0) {
      if (gradient_W != nullptr) *gradient_W = Vec3::Zero();
      const float value = static_cast<float>(slot == kFree ? truncation_m_ : -truncation_m_);
      return static_cast<double>(value);
    }
    block = grid.blocks.data() + static_cast<std::size_t>(slot) * kBlockVoxels;
  }
  auto at = [&](int di, int dj, int dk) {
    const int i = di ? i1[0] : i0[0], j = dj ? i1[1] : i0[1], k = dk ? i1[2] : i0[2];
    if (block != nullptr) {
      return static_cast<double>(
          block[(i % kBlock) + kBlock * ((j % kBlock) + kBlock * (k % kBlock))]);
    }
    return static_cast<double>(Value(i, j, k));
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

// FNV-1a over the values (a code for each block not allocated): a key for
// the pool's table, never trusted alone (equal keys are compared in full).
std::uint64_t HashValues(const std::vector<std::int32_t>& slots, const std::vector<float>& blocks) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&](std::uint32_t bits) { h = (h ^ bits) * 1099511628211ull; };
  ForEachBlock(slots, blocks, [&](const float* block, std::int32_t code) {
    if (block == nullptr) {
      mix(static_cast<std::uint32_t>(code));
      return;
    }
    for (int v = 0; v < Esdf::kBlockVoxels; ++v) {
      std::uint32_t bits;
      std::memcpy(&bits, block + v, sizeof bits);
      mix(bits);
    }
  });
  return h;
}

}  // namespace

bool EsdfPool::Share(Esdf& esdf) {
  {
    // A clone of a pooled grid (a mission copied from the server's world
    // cache) is pooled already: no need to hash its megabytes again.
    absl::MutexLock lock(&mu_);
    for (const auto& [key, e] : grids_) {
      if (e.grid.lock() == esdf.grid_) return false;
    }
  }
  const std::uint64_t key = HashValues(esdf.grid_->slots, esdf.grid_->blocks);
  absl::MutexLock lock(&mu_);
  // Expired entries are dropped as they are met.
  auto [first, last] = grids_.equal_range(key);
  for (auto it = first; it != last;) {
    std::shared_ptr<Esdf::Grid> held = it->second.grid.lock();
    if (held == nullptr) {
      it = grids_.erase(it);
      continue;
    }
    const Entry& e = it->second;
    if (held == esdf.grid_) return false;  // already the pooled grid
    if (e.dims == esdf.dims_ && e.origin_W == esdf.origin_W_ && e.voxel_m == esdf.voxel_m_ &&
        e.truncation_m == esdf.truncation_m_) {
      Esdf probe = esdf.Clone();
      probe.grid_ = held;
      if (probe.SameValues(esdf)) {
        esdf.grid_ = std::move(held);
        return true;
      }
    }
    ++it;
  }
  grids_.emplace(key,
                 Entry{esdf.dims_, esdf.origin_W_, esdf.voxel_m_, esdf.truncation_m_, esdf.grid_});
  return false;
}

int EsdfPool::size() const {
  absl::MutexLock lock(&mu_);
  int alive = 0;
  for (const auto& [key, e] : grids_) alive += e.grid.expired() ? 0 : 1;
  return alive;
}

}  // namespace oaipp

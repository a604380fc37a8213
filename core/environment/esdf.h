// Euclidean signed distance field (ESDF) on a voxel grid (docs/method.md §2).
//
// The grid covers the flight volume padded by the truncation distance, so
// that obstacles just outside the volume still shape the field inside it.
// Values are signed distances to the nearest obstacle surface (negative
// inside), clamped to [-truncation_m, truncation_m] as in Voxblox, whose
// default 2 m truncation this follows: planning only asks "is this pose
// within r_uav / 2 of an obstacle", so far-field values are not needed, and
// truncation is what makes obstacle updates local.
//
// How it is built: voxels whose centre lies within half a voxel diagonal of a
// surface ("surface voxels") store their exact signed distance; every other
// voxel gets the exact Euclidean distance to the nearest surface-voxel centre
// from the separable distance transform of Felzenszwalb & Huttenlocher
// ("Distance Transforms of Sampled Functions", 2012), signed by an exact
// inside test. The nearest surface point always lies within half a diagonal
// of some surface-voxel centre, so every voxel value is within half a voxel
// diagonal of the true (clamped) signed distance.
//
//   OAIPP_ASSIGN_OR_RETURN(Esdf esdf, Esdf::Create(volume, EsdfConfig{}));
//   esdf.Rebuild(shapes);
//   double d_m = esdf.Distance(p_W);              // trilinear interpolation
//   esdf.Update(shapes, changed_region_W);        // after an obstacle change
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "core/common/geometry.h"
#include "core/environment/obstacle.h"

namespace oaipp {

struct EsdfConfig {
  // Edge length of a voxel, metres. Valid: (0, 10].
  double voxel_size_m = 0.2;
  // Values are clamped to +-truncation_m. Valid: >= voxel_size_m.
  double truncation_m = 2.0;
  // Refuse grids larger than this many voxels (memory: 4 bytes each).
  std::int64_t max_voxels = 200'000'000;
};

// Half-open voxel index box [lo, hi).
struct VoxelBox {
  std::array<int, 3> lo{0, 0, 0};
  std::array<int, 3> hi{0, 0, 0};
  [[nodiscard]] std::int64_t Count() const {
    std::int64_t n = 1;
    for (int a = 0; a < 3; ++a) n *= std::max(0, hi[a] - lo[a]);
    return n;
  }
};

class Esdf {
 public:
  // Creates the grid over `volume` (padded by config.truncation_m) with every
  // value at +truncation (an empty world). InvalidArgument on bad config or
  // volume, ResourceExhausted when the grid would exceed config.max_voxels.
  [[nodiscard]] static absl::StatusOr<Esdf> Create(const Aabb& volume, const EsdfConfig& config);

  // The voxels Create would allocate for `volume` and `config`, counted
  // before allocating anything (memory admission, size guards); int64 max
  // when Create would refuse an axis as too long or the voxel size is not
  // positive.
  [[nodiscard]] static std::int64_t VoxelCount(const Aabb& volume, const EsdfConfig& config);

  Esdf(Esdf&&) = default;
  Esdf& operator=(Esdf&&) = default;
  // The grid holds megabytes: copies are explicit, and a clone shares the
  // values until either is changed (copy on write).
  Esdf(const Esdf&) = delete;
  Esdf& operator=(const Esdf&) = delete;
  [[nodiscard]] Esdf Clone() const;

  // Recomputes every voxel from `shapes` (which must be valid).
  void Rebuild(std::span<const Shape* const> shapes);

  // Recomputes only the voxels whose value can change when the obstacle
  // geometry inside `changed_W` changed (the union of the bounding boxes of
  // removed and added shapes). `shapes` is the new complete set. The result
  // equals Rebuild(shapes) voxel for voxel. Falls back to a full rebuild
  // when the affected region is most of the grid.
  void Update(std::span<const Shape* const> shapes, const Aabb& changed_W);

  // Signed distance at p_W, metres, trilinearly interpolated between voxel
  // centres; points outside the grid are clamped onto it.
  [[nodiscard]] double Distance(const Vec3& p_W) const;
  // As Distance, and the gradient of the interpolant in *gradient_W.
  [[nodiscard]] double DistanceAndGradient(const Vec3& p_W, Vec3* gradient_W) const;

  [[nodiscard]] const std::array<int, 3>& dims() const { return dims_; }
  [[nodiscard]] double voxel_size_m() const { return voxel_m_; }
  [[nodiscard]] double truncation_m() const { return truncation_m_; }
  [[nodiscard]] const Vec3& origin_W() const { return origin_W_; }
  [[nodiscard]] Vec3 VoxelCentre(int i, int j, int k) const {
    return origin_W_ + voxel_m_ * Vec3(i + 0.5, j + 0.5, k + 0.5);
  }
  [[nodiscard]] float Value(int i, int j, int k) const { return (*values_)[Index(i, j, k)]; }
  [[nodiscard]] std::span<const float> values() const { return *values_; }
  // Voxels recomputed by the last Rebuild or Update (for statistics).
  [[nodiscard]] std::int64_t last_recomputed_voxels() const { return last_recomputed_; }
  // Bytes held by the grid (shared or not).
  [[nodiscard]] std::size_t MemoryBytes() const { return values_->capacity() * sizeof(float); }
  // How many Esdf objects hold this grid's values (1: not shared). Clones
  // share their values until one of them changes (copy on write), and
  // EsdfPool makes equal grids share.
  [[nodiscard]] long SharedBy() const { return values_.use_count(); }

 private:
  Esdf() = default;

  [[nodiscard]] std::int64_t Index(int i, int j, int k) const {
    return i + static_cast<std::int64_t>(dims_[0]) * (j + static_cast<std::int64_t>(dims_[1]) * k);
  }
  [[nodiscard]] VoxelBox BoxAround(const Aabb& region_W, double margin_m) const;
  void Recompute(std::span<const Shape* const> shapes, const VoxelBox& out);

  std::array<int, 3> dims_{0, 0, 0};
  Vec3 origin_W_ = Vec3::Zero();
  double voxel_m_ = 0.2;
  double truncation_m_ = 2.0;
  // The values to write: copied first when another Esdf shares them.
  [[nodiscard]] std::vector<float>& Writable();

  friend class EsdfPool;
  // Never written while shared (Writable copies first).
  std::shared_ptr<std::vector<float>> values_;
  std::int64_t last_recomputed_ = 0;
};

// Equal grids held once: a server's missions over the same obstacles (a
// fleet flying one site) each build their ESDF, then Share makes it point at
// an equal grid already held by another mission, so the values (16 MB for
// the paper's volume at 0.2 m) exist once however many missions use them.
// Grids are compared in full (dims, origin, voxel size, truncation and every
// value, bit for bit), never by hash alone. The pool holds no grid itself: a
// grid is freed when its last Esdf is, and its entry then expires. A grid
// that is changed later (an obstacle added) is copied first (Esdf's copy on
// write), so sharing never changes what a mission sees.
//
// Thread-safe.
//
//   EsdfPool pool;
//   pool.Share(env_a_esdf);  // first of its kind: remembered
//   pool.Share(env_b_esdf);  // equal to a's: now holds a's values
class EsdfPool {
 public:
  // Makes `esdf` share the values of an equal grid in the pool, or adds its
  // grid to the pool. Returns true when it now shares another's values.
  bool Share(Esdf& esdf);
  // Distinct grids alive in the pool.
  [[nodiscard]] int size() const;

 private:
  struct Entry {
    std::array<int, 3> dims;
    Vec3 origin_W;
    double voxel_m;
    double truncation_m;
    std::weak_ptr<std::vector<float>> values;
  };
  mutable absl::Mutex mu_;
  std::unordered_multimap<std::uint64_t, Entry> grids_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp

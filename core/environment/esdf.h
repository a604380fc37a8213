// Euclidean signed distance field (ESDF) on a voxel grid (docs/method.md §2.3).
//
// The grid covers the flight volume padded by the truncation distance, so
// that obstacles just outside the volume still shape the field inside it.
// Values are signed distances to the nearest obstacle surface (negative
// inside), clamped to [-truncation_m, truncation_m] as in Voxblox, whose
// default 2 m truncation this follows: planning only asks "is this pose
// within r_uav / 2 of an obstacle", so far-field values are not needed, and
// truncation is what makes obstacle updates local.
//
// Storage is block-sparse, as in Voxblox: the volume is cut into blocks of
// 8 x 8 x 8 voxels, and only blocks that hold a value other than +-truncation
// are allocated; the rest read as +truncation (free space) or -truncation
// (deep inside an obstacle). Memory therefore follows the obstacles'
// surroundings, not the volume: a square kilometre with hundreds of
// buildings fits at the default 0.2 m voxel.
//
// How it is built: voxels whose centre lies within half a voxel diagonal of a
// surface ("surface voxels") store their exact signed distance; every other
// voxel gets the exact Euclidean distance to the nearest surface-voxel centre
// from the separable distance transform of Felzenszwalb & Huttenlocher
// ("Distance Transforms of Sampled Functions", 2012), signed by an exact
// inside test. The nearest surface point always lies within half a diagonal
// of some surface-voxel centre, so every voxel value is within half a voxel
// diagonal of the true (clamped) signed distance. The transform runs tile by
// tile (64 voxels on a side, padded by the truncation), only where some
// obstacle is near.
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
  // The most voxels the grid may hold in memory (4 bytes each): its
  // allocated blocks, and one voxel's worth for each entry of its block
  // table. Create refuses a table over it; Environment::Apply refuses an
  // obstacle set whose surroundings could need more.
  std::int64_t max_voxels = 400'000'000;
  // Threads that build the grid (tiles in parallel); the values do not
  // depend on it. Valid: >= 1.
  int build_threads = 2;
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

// The voxels two boxes share (empty when none).
[[nodiscard]] inline VoxelBox Intersect(const VoxelBox& a, const VoxelBox& b) {
  VoxelBox c;
  for (int i = 0; i < 3; ++i) {
    c.lo[i] = std::max(a.lo[i], b.lo[i]);
    c.hi[i] = std::max(c.lo[i], std::min(a.hi[i], b.hi[i]));
  }
  return c;
}

class Esdf {
 public:
  // Voxels along a block's edge.
  static constexpr int kBlock = 8;
  static constexpr int kBlockVoxels = kBlock * kBlock * kBlock;

  // Creates the grid over `volume` (padded by config.truncation_m) with every
  // value at +truncation (an empty world). InvalidArgument on bad config or
  // volume, ResourceExhausted when its block table alone would exceed
  // config.max_voxels.
  [[nodiscard]] static absl::StatusOr<Esdf> Create(const Aabb& volume, const EsdfConfig& config);

  // The voxels the grid spans over `volume` (allocated or not), counted
  // before allocating anything; int64 max when Create would refuse an axis
  // as too long or the voxel size is not positive.
  [[nodiscard]] static std::int64_t VoxelCount(const Aabb& volume, const EsdfConfig& config);
  // An upper bound on the voxels a grid over `volume` holds for `shapes`
  // (valid): its block table, and every block near a shape's surface (one
  // distance at each block's centre). For memory admission before a mission
  // exists; int64 max when Create would refuse.
  [[nodiscard]] static std::int64_t HeldVoxelBound(const Aabb& volume, const EsdfConfig& config,
                                                   std::span<const Shape* const> shapes);

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
  // equals Rebuild(shapes) voxel for voxel.
  void Update(std::span<const Shape* const> shapes, const Aabb& changed_W);

  // As HeldVoxelBound, for this grid.
  [[nodiscard]] std::int64_t HeldVoxelBound(std::span<const Shape* const> shapes) const;
  [[nodiscard]] std::int64_t max_voxels() const { return max_voxels_; }

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
  [[nodiscard]] float Value(int i, int j, int k) const;
  // Every value, x fastest, then y, then z (for tests and small grids).
  [[nodiscard]] std::vector<float> DenseValues() const;
  // True when both grids cover the same voxels and hold the same value at
  // every one, bit for bit.
  [[nodiscard]] bool SameValues(const Esdf& other) const;
  // Identifies the values held (equal for grids that share them).
  [[nodiscard]] const void* grid_id() const { return grid_.get(); }
  // Voxels recomputed by the last Rebuild or Update (for statistics).
  [[nodiscard]] std::int64_t last_recomputed_voxels() const { return last_recomputed_; }
  // Blocks allocated (the rest read as +-truncation).
  [[nodiscard]] std::int64_t allocated_blocks() const;
  // Bytes held by the grid (shared or not): its block table and blocks.
  [[nodiscard]] std::size_t MemoryBytes() const;
  // How many Esdf objects hold this grid's values (1: not shared). Clones
  // share their values until one of them changes (copy on write), and
  // EsdfPool makes equal grids share.
  [[nodiscard]] long SharedBy() const { return grid_.use_count(); }

 private:
  // A block slot's codes for the blocks not allocated.
  static constexpr std::int32_t kFree = -1;    // every voxel +truncation
  static constexpr std::int32_t kInside = -2;  // every voxel -truncation
  struct Grid {
    std::vector<std::int32_t> slots;   // per block: a block's index, or a code
    std::vector<float> blocks;         // kBlockVoxels values per allocated block
    std::vector<std::int32_t> unused;  // indices of freed blocks, for reuse
  };

  Esdf() = default;

  [[nodiscard]] std::int64_t BlockIndex(int bi, int bj, int bk) const {
    return bi +
           static_cast<std::int64_t>(bdims_[0]) * (bj + static_cast<std::int64_t>(bdims_[1]) * bk);
  }
  [[nodiscard]] VoxelBox BoxAround(const Aabb& region_W, double margin_m) const;
  // The blocks (in block indices) holding the voxels of `voxels`.
  [[nodiscard]] VoxelBox BlocksOf(const VoxelBox& voxels) const;
  // How far an obstacle reaches into the grid's values: half a diagonal, the
  // truncation and a voxel.
  [[nodiscard]] double Reach() const;
  // What each block of `blocks` (block indices) is for `shapes`: kNearBlock
  // (computed), kDeepBlock (inside a shape by more than the truncation) or kFarBlock
  // (free space). Shapes reaching into `blocks` are added to *reaching.
  static constexpr std::uint8_t kFarBlock = 0, kNearBlock = 1, kDeepBlock = 2;
  [[nodiscard]] std::vector<std::uint8_t> Classify(std::span<const Shape* const> shapes,
                                                   const VoxelBox& blocks,
                                                   std::vector<const Shape*>* reaching) const;
  // Recomputes every block of `blocks` (block indices).
  void Recompute(std::span<const Shape* const> shapes, const VoxelBox& blocks);
  // Buffers Compute reuses from box to box.
  struct Scratch;
  // The values of the voxels of `out` from `shapes`, x fastest, into
  // scratch's `values`.
  void Compute(std::span<const Shape* const> shapes, const VoxelBox& out, Scratch& scratch) const;
  // Stores block (bi, bj, bk) from `values` over the voxel box `box`, or its
  // code when every voxel holds +-truncation.
  void StoreBlock(Grid& grid, int bi, int bj, int bk, const std::vector<float>& values,
                  const VoxelBox& box) const;
  static void SetSlot(Grid& grid, std::int64_t b, std::int32_t code);

  std::array<int, 3> dims_{0, 0, 0};
  std::array<int, 3> bdims_{0, 0, 0};
  Vec3 origin_W_ = Vec3::Zero();
  double voxel_m_ = 0.2;
  double truncation_m_ = 2.0;
  std::int64_t max_voxels_ = 0;
  int build_threads_ = 1;
  // The values to write: copied first when another Esdf shares them.
  [[nodiscard]] Grid& Writable();

  friend class EsdfPool;
  // Never written while shared (Writable copies first).
  std::shared_ptr<Grid> grid_;
  std::int64_t last_recomputed_ = 0;
};

// Equal grids held once: a server's missions over the same obstacles (a
// fleet flying one site) each build their ESDF, then Share makes it point at
// an equal grid already held by another mission, so the values exist once
// however many missions use them. Grids are compared in full (dims, origin,
// voxel size, truncation and every value, bit for bit), never by hash alone.
// The pool holds no grid itself: a grid is freed when its last Esdf is, and
// its entry then expires. A grid that is changed later (an obstacle added) is
// copied first (Esdf's copy on write), so sharing never changes what a
// mission sees.
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
    std::weak_ptr<Esdf::Grid> grid;
  };
  mutable absl::Mutex mu_;
  std::unordered_multimap<std::uint64_t, Entry> grids_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp

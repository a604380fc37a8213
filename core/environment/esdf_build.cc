// The ESDF's construction: which blocks are near an obstacle, the tiles
// they are computed in, and the distance transform (docs/method.md §2.3).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <system_error>
#include <thread>

#include "absl/synchronization/mutex.h"
#include "core/environment/esdf.h"

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

std::vector<std::uint8_t> Esdf::Classify(std::span<const Shape* const> shapes,
                                         const VoxelBox& blocks,
                                         std::vector<const Shape*>* reaching) const {
  const std::array<int, 3> nb{blocks.hi[0] - blocks.lo[0], blocks.hi[1] - blocks.lo[1],
                              blocks.hi[2] - blocks.lo[2]};
  std::vector<std::uint8_t> kinds(static_cast<std::size_t>(blocks.Count()), kFarBlock);
  // Signed distance is 1-Lipschitz: its value at a block's centre bounds
  // every voxel of the block within the block's half diagonal.
  const double block_radius = 0.5 * std::sqrt(3.0) * kBlock * voxel_m_;
  const double margin = 0.01 * voxel_m_;
  for (const Shape* shape : shapes) {
    const VoxelBox b = Intersect(BlocksOf(BoxAround(BoundingBox(*shape), Reach())), blocks);
    if (b.Count() == 0) continue;
    if (reaching != nullptr) reaching->push_back(shape);
    const ShapeDistance distance(*shape);
    for (int k = b.lo[2]; k < b.hi[2]; ++k) {
      for (int j = b.lo[1]; j < b.hi[1]; ++j) {
        for (int i = b.lo[0]; i < b.hi[0]; ++i) {
          std::uint8_t& kind =
              kinds[(i - blocks.lo[0]) + static_cast<std::size_t>(nb[0]) *
                                             ((j - blocks.lo[1]) + static_cast<std::size_t>(nb[1]) *
                                                                       (k - blocks.lo[2]))];
          if (kind == kDeepBlock) continue;
          const Vec3 centre = origin_W_ + kBlock * voxel_m_ * Vec3(i + 0.5, j + 0.5, k + 0.5);
          const double d = distance(centre);
          if (d < -(truncation_m_ + block_radius + margin)) {
            kind = kDeepBlock;  // every voxel below -truncation, whatever else is near
          } else if (d < Reach() + block_radius + margin) {
            kind = kNearBlock;
          }
        }
      }
    }
  }
  return kinds;
}

void Esdf::Rebuild(std::span<const Shape* const> shapes) {
  VoxelBox all;
  all.hi = bdims_;
  Recompute(shapes, all);
}

void Esdf::Update(std::span<const Shape* const> shapes, const Aabb& changed_W) {
  // Surface voxels can change within half a diagonal of the changed
  // geometry, and a clamped value depends only on surface voxels within the
  // truncation distance.
  Recompute(shapes, BlocksOf(BoxAround(changed_W, Reach())));
}

void Esdf::SetSlot(Grid& grid, std::int64_t b, std::int32_t code) {
  std::int32_t& slot = grid.slots[b];
  if (slot >= 0) grid.unused.push_back(slot);
  slot = code;
}

void Esdf::StoreBlock(Grid& grid, int bi, int bj, int bk, const std::vector<float>& values,
                      const VoxelBox& box) const {
  const float trunc = static_cast<float>(truncation_m_);
  std::array<float, kBlockVoxels> block;
  block.fill(trunc);  // voxels past the grid's edge: never read
  bool all_free = true, all_inside = true;
  const std::array<int, 3> n{box.hi[0] - box.lo[0], box.hi[1] - box.lo[1], box.hi[2] - box.lo[2]};
  for (int z = 0; z < kBlock; ++z) {
    const int k = bk * kBlock + z;
    if (k >= dims_[2]) break;
    for (int y = 0; y < kBlock; ++y) {
      const int j = bj * kBlock + y;
      if (j >= dims_[1]) break;
      for (int x = 0; x < kBlock; ++x) {
        const int i = bi * kBlock + x;
        if (i >= dims_[0]) break;
        const float v =
            values[(i - box.lo[0]) +
                   static_cast<std::size_t>(n[0]) *
                       ((j - box.lo[1]) + static_cast<std::size_t>(n[1]) * (k - box.lo[2]))];
        block[x + kBlock * (y + kBlock * z)] = v;
        all_free &= v == trunc;
        all_inside &= v == -trunc;
      }
    }
  }
  const std::int64_t b = BlockIndex(bi, bj, bk);
  if (all_free || all_inside) {
    SetSlot(grid, b, all_free ? kFree : kInside);
    return;
  }
  std::int32_t& slot = grid.slots[b];
  if (slot < 0) {
    if (!grid.unused.empty()) {
      slot = grid.unused.back();
      grid.unused.pop_back();
    } else {
      slot = static_cast<std::int32_t>(grid.blocks.size() / kBlockVoxels);
      grid.blocks.resize(grid.blocks.size() + kBlockVoxels);
    }
  }
  std::copy(block.begin(), block.end(),
            grid.blocks.begin() + static_cast<std::ptrdiff_t>(slot) * kBlockVoxels);
}

struct Esdf::Scratch {
  std::vector<float> exact, d2, line_in, line_out, values;
  std::vector<int> v;
  std::vector<double> z;
};

void Esdf::Recompute(std::span<const Shape* const> shapes, const VoxelBox& blocks) {
  last_recomputed_ = 0;
  if (blocks.Count() == 0) return;
  Grid& grid = Writable();
  const std::array<int, 3> nb{blocks.hi[0] - blocks.lo[0], blocks.hi[1] - blocks.lo[1],
                              blocks.hi[2] - blocks.lo[2]};
  auto local = [&](int bi, int bj, int bk) {
    return (bi - blocks.lo[0]) +
           static_cast<std::size_t>(nb[0]) *
               ((bj - blocks.lo[1]) + static_cast<std::size_t>(nb[1]) * (bk - blocks.lo[2]));
  };
  // Blocks near some shape's surface are computed; the rest are free space
  // or deep inside a shape.
  std::vector<const Shape*> reaching;
  const std::vector<std::uint8_t> kinds = Classify(shapes, blocks, &reaching);
  std::vector<VoxelBox> reach_boxes;
  for (const Shape* shape : reaching) {
    reach_boxes.push_back(Intersect(BlocksOf(BoxAround(BoundingBox(*shape), Reach())), blocks));
  }
  for (int k = blocks.lo[2]; k < blocks.hi[2]; ++k) {
    for (int j = blocks.lo[1]; j < blocks.hi[1]; ++j) {
      for (int i = blocks.lo[0]; i < blocks.hi[0]; ++i) {
        const std::uint8_t kind = kinds[local(i, j, k)];
        if (kind != kNearBlock)
          SetSlot(grid, BlockIndex(i, j, k), kind == kDeepBlock ? kInside : kFree);
      }
    }
  }
  // Shapes whose reach overlaps are computed together: clusters of
  // overlapping reach boxes, each cut into tiles of at most kTile blocks on
  // a side (one padded dense box each). A block is computed once, by the
  // first tile that holds it.
  std::vector<int> parent(reach_boxes.size());
  for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<int>(i);
  auto root = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t i = 0; i < reach_boxes.size(); ++i) {
    for (std::size_t j = i + 1; j < reach_boxes.size(); ++j) {
      if (Intersect(reach_boxes[i], reach_boxes[j]).Count() > 0) {
        parent[root(static_cast<int>(i))] = root(static_cast<int>(j));
      }
    }
  }
  std::map<int, VoxelBox> clusters;  // by root: deterministic order
  for (std::size_t i = 0; i < reach_boxes.size(); ++i) {
    const VoxelBox& b = reach_boxes[i];
    auto [it, fresh] = clusters.try_emplace(root(static_cast<int>(i)), b);
    for (int a = 0; a < 3; ++a) {
      it->second.lo[a] = std::min(it->second.lo[a], b.lo[a]);
      it->second.hi[a] = std::max(it->second.hi[a], b.hi[a]);
    }
  }
  constexpr int kTile = 16;
  struct Tile {
    VoxelBox blocks;  // the bounding box of the blocks it computes
    VoxelBox voxels;  // its voxels
  };
  std::vector<Tile> tiles;
  std::vector<std::int32_t> owner(kinds.size(), -1);  // the tile that computes a block
  std::int64_t new_blocks = 0;                        // near blocks not held yet
  for (const auto& [id, cluster] : clusters) {
    for (int tk = cluster.lo[2]; tk < cluster.hi[2]; tk += kTile) {
      for (int tj = cluster.lo[1]; tj < cluster.hi[1]; tj += kTile) {
        for (int ti = cluster.lo[0]; ti < cluster.hi[0]; ti += kTile) {
          const VoxelBox tile =
              Intersect({{ti, tj, tk}, {ti + kTile, tj + kTile, tk + kTile}}, cluster);
          VoxelBox used{tile.hi, tile.lo};
          for (int k = tile.lo[2]; k < tile.hi[2]; ++k) {
            for (int j = tile.lo[1]; j < tile.hi[1]; ++j) {
              for (int i = tile.lo[0]; i < tile.hi[0]; ++i) {
                const std::size_t l = local(i, j, k);
                if (kinds[l] != kNearBlock || owner[l] >= 0) continue;
                owner[l] = static_cast<std::int32_t>(tiles.size());
                if (grid.slots[BlockIndex(i, j, k)] < 0) ++new_blocks;
                const std::array<int, 3> at{i, j, k};
                for (int a = 0; a < 3; ++a) {
                  used.lo[a] = std::min(used.lo[a], at[a]);
                  used.hi[a] = std::max(used.hi[a], at[a] + 1);
                }
              }
            }
          }
          if (used.Count() == 0) continue;
          VoxelBox voxels;
          for (int a = 0; a < 3; ++a) {
            voxels.lo[a] = used.lo[a] * kBlock;
            voxels.hi[a] = std::min(dims_[a], used.hi[a] * kBlock);
          }
          tiles.push_back({used, voxels});
          last_recomputed_ += voxels.Count();
        }
      }
    }
  }
  // Room for the blocks the freed ones cannot take, at once: the pool grows
  // by one move at most, never by doubling.
  const std::int64_t shortfall = new_blocks - static_cast<std::int64_t>(grid.unused.size());
  if (shortfall > 0) {
    grid.blocks.reserve(grid.blocks.size() + static_cast<std::size_t>(shortfall) * kBlockVoxels);
  }

  // Tiles are independent: computed by build_threads workers, stored one at
  // a time. The values do not depend on the order.
  // A worker that fails (out of memory) stops the others; the failure is
  // thrown once every thread has joined.
  absl::Mutex store_mu;
  std::exception_ptr failure;
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    try {
      Scratch scratch;
      for (std::size_t t = next++; t < tiles.size(); t = next++) {
        const Tile& tile = tiles[t];
        Compute(reaching, tile.voxels, scratch);
        absl::MutexLock lock(&store_mu);
        for (int k = tile.blocks.lo[2]; k < tile.blocks.hi[2]; ++k) {
          for (int j = tile.blocks.lo[1]; j < tile.blocks.hi[1]; ++j) {
            for (int i = tile.blocks.lo[0]; i < tile.blocks.hi[0]; ++i) {
              if (owner[local(i, j, k)] == static_cast<std::int32_t>(t)) {
                StoreBlock(grid, i, j, k, scratch.values, tile.voxels);
              }
            }
          }
        }
      }
    } catch (...) {
      next = tiles.size();
      absl::MutexLock lock(&store_mu);
      if (failure == nullptr) failure = std::current_exception();
    }
  };
  const int helpers = static_cast<int>(std::min<std::size_t>(
                          static_cast<std::size_t>(std::max(1, build_threads_)), tiles.size())) -
                      1;
  std::vector<std::thread> threads;
  try {
    for (int h = 0; h < helpers; ++h) threads.emplace_back(work);
  } catch (const std::system_error&) {
    // No more threads to be had: the ones started and this one do it all.
  }
  work();
  for (std::thread& t : threads) t.join();
  if (failure != nullptr) std::rethrow_exception(failure);
}

void Esdf::Compute(std::span<const Shape* const> shapes, const VoxelBox& out,
                   Scratch& scratch) const {
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
  auto local = [&](int i, int j, int k) {
    return (i - in.lo[0]) + static_cast<std::int64_t>(n[0]) *
                                ((j - in.lo[1]) + static_cast<std::int64_t>(n[1]) * (k - in.lo[2]));
  };

  // 1. Exact signed distance near each shape (inside its box grown by half a
  //    diagonal): enough to know every surface voxel and every inside voxel.
  //    Signed distance is 1-Lipschitz, so one value at the centre of a run
  //    of 4 x 4 x 4 voxels bounds them all: runs wholly beyond the
  //    truncation outside are left out (a far shape changes no value), runs
  //    wholly beyond it inside get a value below -truncation (all that step
  //    3 needs of them). The values are those of evaluating every voxel.
  std::vector<float>& exact = scratch.exact;
  exact.assign(static_cast<std::size_t>(count), kFar);
  const float deep = -static_cast<float>(truncation_m_ + voxel_m_);
  constexpr int kRun = 4;
  for (const Shape* shape : shapes) {
    const VoxelBox b = Intersect(BoxAround(BoundingBox(*shape), half_diag), in);
    if (b.Count() == 0) continue;
    const ShapeDistance distance(*shape);
    for (int k0 = b.lo[2]; k0 < b.hi[2]; k0 += kRun) {
      const int k1 = std::min(k0 + kRun, b.hi[2]);
      for (int j0 = b.lo[1]; j0 < b.hi[1]; j0 += kRun) {
        const int j1 = std::min(j0 + kRun, b.hi[1]);
        for (int i0 = b.lo[0]; i0 < b.hi[0]; i0 += kRun) {
          const int i1 = std::min(i0 + kRun, b.hi[0]);
          const Vec3 centre = 0.5 * (VoxelCentre(i0, j0, k0) + VoxelCentre(i1 - 1, j1 - 1, k1 - 1));
          const double radius = 0.5 * voxel_m_ * Vec3(i1 - 1 - i0, j1 - 1 - j0, k1 - 1 - k0).norm();
          const double d = distance(centre);
          const double beyond = radius + truncation_m_ + 0.01 * voxel_m_;
          if (d > beyond) continue;
          for (int j = j0; j < j1; ++j) {
            for (int i = i0; i < i1; ++i) {
              const Vec3 bottom = VoxelCentre(i, j, k0);
              const double column = d < -beyond ? 0.0 : distance.Column(bottom.head<2>());
              for (int k = k0; k < k1; ++k) {
                float& e = exact[local(i, j, k)];
                e = std::min(e, d < -beyond ? deep
                                            : static_cast<float>(
                                                  distance.AtHeight(column, VoxelCentre(i, j, k))));
              }
            }
          }
        }
      }
    }
  }

  // 2. Squared distance (in voxels^2) to the nearest surface voxel centre,
  //    one axis at a time.
  std::vector<float>& d2 = scratch.d2;
  d2.resize(static_cast<std::size_t>(count));
  for (std::int64_t idx = 0; idx < count; ++idx) {
    d2[idx] = std::abs(exact[idx]) <= half_diag ? 0.0f : kFar;
  }
  const int longest = std::max({n[0], n[1], n[2]});
  std::vector<float>& line_in = scratch.line_in;
  std::vector<float>& line_out = scratch.line_out;
  std::vector<int>& v = scratch.v;
  std::vector<double>& z = scratch.z;
  line_in.resize(longest);
  line_out.resize(longest);
  v.resize(longest);
  z.resize(longest + 1);
  const std::array<std::int64_t, 3> stride{1, n[0], static_cast<std::int64_t>(n[0]) * n[1]};
  const float beyond2 = static_cast<float>(std::pow(truncation_m_ / voxel_m_ + 1.0, 2));
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
        // Beyond the truncation (and a voxel) a distance is clamped however
        // the later axes add to it: dropped, so that lines holding only such
        // values are skipped.
        for (int q = 0; q < n[axis]; ++q) {
          d2[base + q * s] = line_out[q] > beyond2 ? kFar : line_out[q];
        }
      }
    }
  }

  // 3. The output box: exact values on surface voxels, the transform
  //    elsewhere (within half a diagonal of the truth), signed by the exact
  //    inside test, clamped.
  const float trunc = static_cast<float>(truncation_m_);
  std::vector<float>& values = scratch.values;
  values.clear();
  values.reserve(static_cast<std::size_t>(out.Count()));
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
        values.push_back(std::clamp(value, -trunc, trunc));
      }
    }
  }
}

}  // namespace oaipp

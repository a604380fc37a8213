// A mission's field map, dense or sparse, and the map each plan works on:
// the whole dense map, or a sparse map's window around the UAV
// (docs/method.md §3.10-3.11).
//
// It keeps no lock of its own: the mission's state lock (Mission::mu_)
// guards every member here, held for writing while a change is put in place
// and for reading to take what a plan or a reader needs. The heavy parts then
// run off that lock: a dense map is shared copy-on-write (a change copies it
// while a plan still reads it), and a sparse map's window and whole-map reads
// are computed by LargeFieldMap (thread-safe) from a Target taken under it.
//
//   MissionMap map(grid, dense, nullptr);
//   OAIPP_RETURN_IF_ERROR(map.Fuse(observations, /*defer=*/true));   // mu_ for writing
//   MissionMap::ForPlan shared = map.ShareDense();                  // mu_ for writing
#pragma once

#include <cstdint>
#include <memory>
#include <set>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "api/mission_config.h"
#include "core/mapping/gp_map.h"
#include "core/planning/conditioning_chain.h"
#include "server/large_field_map.h"
#include "server/site_caches.h"

namespace oaipp::server {

class MissionMap {
 public:
  // Exactly one of `dense` and `sparse` is set. `grid` outlives the map.
  MissionMap(const FieldGrid& grid, std::shared_ptr<GpMap> dense,
             std::unique_ptr<LargeFieldMap> sparse);

  [[nodiscard]] bool sparse() const { return large_ != nullptr; }
  // The sparse map's posterior, thread-safe and read off the lock (nullptr
  // for a dense map).
  [[nodiscard]] LargeFieldMap* large() const { return large_.get(); }
  // The dense map as it is (nullptr for a sparse map).
  [[nodiscard]] const std::shared_ptr<GpMap>& dense() const { return dense_; }
  // Bytes the map holds: a dense map's mean and covariance; a sparse map's
  // factor and workspace, and its additions with a reader's copy.
  [[nodiscard]] std::int64_t bytes() const;

  // Writers (the lock held for writing).
  // The dense map, to change: copied first when a plan still reads it; the
  // shared start map's conditionings are no longer this mission's.
  GpMap& MutableDense();
  // Fuses into the map, dense or sparse (the dense one's downdate deferred
  // when `defer`).
  absl::Status Fuse(std::span<const CellObservation> observations, bool defer);
  // Fuses, once, the cells of `under` (the ground under obstacles now) not
  // fused before as near-certain zeros.
  absl::Status FuseCovered(const std::vector<int>& under);
  // The shared starting map this mission began from, and the cells it fused.
  void AdoptStartMap(std::shared_ptr<const StartMap> start);
  // Recovery: the cells fused as covered, and a sparse map's additions.
  void Restore(const std::vector<int>& covered, SparseGpMap::Additions* additions);

  // Readers (the lock held for reading).
  [[nodiscard]] LargeFieldMap::Target SparseTarget(std::int64_t measurements_fused) const;
  [[nodiscard]] std::vector<int> CoveredCells() const { return {covered_.begin(), covered_.end()}; }
  [[nodiscard]] const SparseGpMap::Additions& additions() const { return *added_; }

  // The map a plan works on.
  struct ForPlan {
    std::shared_ptr<const GpMap> map;
    // The shared start map's conditioned covariances, while the map is it.
    std::shared_ptr<ConditionedCache> conditioned;
    const FieldGrid* field = nullptr;  // the whole field, when map is a window
    // With a search area the window holds none of: core's TransitArea, the
    // area's stand-in for this plan (a field mask); empty otherwise.
    std::vector<std::uint8_t> transit;
    // What map's covariance is, for the team's conditioning chain: the
    // version it was read at and the block of the field's cells it covers.
    CovarianceKey key;
  };
  // A dense map, settled and shared (the lock held for writing, so that no
  // measurement leaves it pending in between).
  [[nodiscard]] ForPlan ShareDense();
  // A sparse map's window around `centre_W` as of `target`, off the lock:
  // core's window (LargeFieldPlanning::ForField, with OA-IPP's lead towards
  // the most uncertain square when its neighbourhood is spent).
  [[nodiscard]] absl::StatusOr<ForPlan> Window(const LargeFieldMap::Target& target,
                                               const Vec2& centre_W,
                                               const api::MissionConfig& config) const;

 private:
  const FieldGrid& grid_;
  const std::int64_t dense_bytes_;
  std::shared_ptr<GpMap> dense_;
  // A dense map's changes (MutableDense), naming its covariance for the
  // team's conditioning chain.
  std::int64_t dense_version_ = 0;
  // The shared map this mission started from, until its map changes: plans
  // share its conditioned covariances.
  std::shared_ptr<const StartMap> start_map_;
  const std::unique_ptr<LargeFieldMap> large_;
  // Sparse: what was fused (copied before a change while a reader holds
  // it) and the count of fusions.
  std::shared_ptr<SparseGpMap::Additions> added_;
  std::int64_t version_ = 0;
  std::set<int> covered_;
};

}  // namespace oaipp::server

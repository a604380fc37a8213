// How a mission holds its map, dense or sparse (MissionMap: fusion, the map
// a plan reads, memory), and the Mission calls that read it whole.
#include "server/mission_map.h"

#include <algorithm>
#include <cstdint>
#include <span>
#include <utility>

#include "core/common/status_macros.h"
#include "server/mission.h"

namespace oaipp::server {

MissionMap::MissionMap(const FieldGrid& grid, std::shared_ptr<GpMap> dense,
                       std::unique_ptr<LargeFieldMap> sparse)
    : grid_(grid),
      dense_bytes_(dense == nullptr ? 0
                                    : 8 * static_cast<std::int64_t>(dense->num_cells()) *
                                          (static_cast<std::int64_t>(dense->num_cells()) + 1)),
      dense_(std::move(dense)),
      large_(std::move(sparse)) {
  if (large_ != nullptr) {
    added_ = std::make_shared<SparseGpMap::Additions>(SparseGpMap::NoAdditions(grid_.num_cells()));
  }
}

std::int64_t MissionMap::bytes() const {
  // A sparse map: its factor and workspace, and the additions (16 bytes a
  // cell) with a reader's copy.
  return large_ == nullptr ? dense_bytes_ : large_->bytes() + 32 * std::int64_t{grid_.num_cells()};
}

GpMap& MissionMap::MutableDense() {
  // Only holders of the mission's lock copy dense_, and this one holds it
  // for writing: a count of 1 cannot grow under us. A plan that lets go
  // meanwhile costs one needless copy, no harm.
  // The shared start map and its conditionings are no longer this
  // mission's (a plan in progress keeps what it holds).
  start_map_.reset();
  ++dense_version_;
  if (dense_.use_count() > 1) dense_ = std::make_shared<GpMap>(dense_->Clone());
  return *dense_;
}

absl::Status MissionMap::Fuse(std::span<const CellObservation> observations, bool defer) {
  if (large_ == nullptr) {
    GpMap& map = MutableDense();
    return defer ? map.UpdateDeferred(observations) : map.Update(observations);
  }
  // Into a copy when a reader still holds the additions (as MutableDense).
  SparseGpMap::Additions next;
  SparseGpMap::Additions* added = added_.get();
  if (added_.use_count() > 1) {
    next = *added_;
    added = &next;
  }
  OAIPP_RETURN_IF_ERROR(SparseGpMap::Accumulate(observations, *added));
  if (added == &next) added_ = std::make_shared<SparseGpMap::Additions>(std::move(next));
  ++version_;
  return absl::OkStatus();
}

absl::Status MissionMap::FuseCovered(const std::vector<int>& under) {
  std::vector<int> fresh;
  for (int c : under) {
    if (!covered_.contains(c)) fresh.push_back(c);
  }
  if (fresh.empty()) return absl::OkStatus();
  if (large_ != nullptr) {
    OAIPP_RETURN_IF_ERROR(Fuse(SparseGpMap::NearCertainZeros(fresh), /*defer=*/false));
  } else {
    OAIPP_RETURN_IF_ERROR(MutableDense().FuseNearCertainZeros(fresh));
  }
  covered_.insert(fresh.begin(), fresh.end());
  return absl::OkStatus();
}

void MissionMap::AdoptStartMap(std::shared_ptr<const StartMap> start) {
  covered_.insert(start->covered_cells.begin(), start->covered_cells.end());
  start_map_ = std::move(start);
}

void MissionMap::Restore(const std::vector<int>& covered, SparseGpMap::Additions* additions) {
  covered_.insert(covered.begin(), covered.end());
  if (large_ != nullptr && additions != nullptr) {
    added_ = std::make_shared<SparseGpMap::Additions>(std::move(*additions));
    // Any version past the prior's: versions only order one copy's maps.
    version_ = 1;
  }
}

LargeFieldMap::Target MissionMap::SparseTarget(std::int64_t measurements_fused) const {
  return {.added = added_, .version = version_, .measurements_fused = measurements_fused};
}

MissionMap::ForPlan MissionMap::ShareDense() {
  dense_->Settle();
  ForPlan plan;
  plan.map = dense_;
  plan.key = {.map_version = dense_version_, .rows = grid_.ny(), .cols = grid_.nx()};
  // MutableDense lets go of start_map_ at the map's first change.
  if (start_map_ != nullptr && start_map_->map == dense_)
    plan.conditioned = start_map_->conditioned;
  return plan;
}

absl::StatusOr<MissionMap::ForPlan> MissionMap::Window(const LargeFieldMap::Target& target,
                                                       const Vec2& centre_W,
                                                       const api::MissionConfig& config) const {
  const bool oaipp = config.planner.kind == PlannerKind::kOaIpp ||
                     config.planner.kind == PlannerKind::kOaIppNonAdaptive ||
                     config.planner.kind == PlannerKind::kOaIppDetection;
  const LargeFieldPlanning options =
      LargeFieldPlanning::ForField(grid_, oaipp, config.planner.common.information.dense_backend);
  OAIPP_ASSIGN_OR_RETURN(
      const FieldWindow window,
      PlanningWindow(grid_, target.added == nullptr ? nullptr : &target.added->precision,
                     large_->prior_variance(), centre_W, options, config.SearchMask()));
  OAIPP_ASSIGN_OR_RETURN(GpMap local, large_->Window(target, window, options));
  ForPlan plan;
  plan.key = {.map_version = target.version,
              .first_row = window.first_row,
              .first_col = window.first_col,
              .rows = window.grid.ny(),
              .cols = window.grid.nx()};
  plan.map = std::make_shared<const GpMap>(std::move(local));
  plan.field = &grid_;
  if (options.lead_fraction > 0.0) {
    plan.transit =
        TransitArea(grid_, window, config.SearchMask(), centre_W, 0.25 * options.half_width_m);
  }
  return plan;
}

std::int64_t Mission::MemoryBytes() const {
  const std::shared_ptr<const Environment> env = summary_.Get().env;
  const std::int64_t map_bytes = map_.bytes() + (map_.sparse() ? 0 : planning_.chain_bytes());
  if (env == nullptr) return map_bytes;
  const Esdf& esdf = env->esdf();
  std::int64_t users = esdf.SharedBy();
  if (worlds_ != nullptr && worlds_->HoldsGrid(esdf.grid_id())) --users;
  return map_bytes +
         static_cast<std::int64_t>(esdf.MemoryBytes()) / std::max<std::int64_t>(1, users);
}

absl::StatusOr<Mission::PlanMap> Mission::MapForPlan(const Vec2& centre_W,
                                                     std::shared_ptr<const Environment>* env) {
  PlanMap plan;
  if (!map_.sparse()) {
    // Settled and taken under one lock, so no measurement leaves it pending
    // in between.
    absl::MutexLock lock(&mu_);
    *env = env_;
    plan.shared = map_.ShareDense();
    plan.fused_shots = fused_shots_;
    plan.mission_time_s = mission_time_s_;
    return plan;
  }
  LargeFieldMap::Target target;
  {
    absl::ReaderMutexLock lock(&mu_);
    *env = env_;
    target = map_.SparseTarget(measurements_fused_);
    plan.fused_shots = fused_shots_;
    plan.mission_time_s = mission_time_s_;
  }
  OAIPP_ASSIGN_OR_RETURN(plan.shared, map_.Window(target, centre_W, config_));
  return plan;
}

void Mission::ReadMap(const std::function<void(const GpMap&)>& reader) const {
  if (map_.sparse()) return;
  SettleMap();
  {
    absl::ReaderMutexLock lock(&mu_);
    if (map_.dense()->settled()) {
      reader(*map_.dense());
      return;
    }
  }
  // A measurement came in between: settle and read under one lock, so that
  // a steady stream of them cannot keep the reader waiting.
  absl::MutexLock lock(&mu_);
  map_.dense()->Settle();
  reader(*map_.dense());
}

absl::Status Mission::ReadMapView(const std::function<void(const api::MapView&)>& reader) const {
  if (!map_.sparse()) {
    ReadMap([&](const GpMap& map) {
      const Eigen::VectorXd variances = map.Variances();
      reader(api::MapView{
          .grid = &grid_, .mean = &map.Mean(), .variances = &variances, .trace = map.Trace()});
    });
    return absl::OkStatus();
  }
  LargeFieldMap::Target target;
  {
    absl::ReaderMutexLock lock(&mu_);
    target = map_.SparseTarget(measurements_fused_);
  }
  OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<const LargeFieldMap::Reading> reading,
                         map_.large()->Read(target));
  reader(api::MapView{.grid = &grid_,
                      .mean = &reading->mean,
                      .variances = &reading->variances,
                      .trace = reading->trace});
  return absl::OkStatus();
}

void Mission::SettleMap() const {
  if (!map_.sparse()) {
    absl::MutexLock lock(&mu_);
    // Settling changes how the map is stored, not what it holds: no reader
    // holds a map with a downdate pending (they settle it first), so this
    // is the only copy.
    map_.dense()->Settle();
    return;
  }
  LargeFieldMap::Target target;
  {
    absl::ReaderMutexLock lock(&mu_);
    target = map_.SparseTarget(measurements_fused_);
  }
  absl::StatusOr<std::shared_ptr<const LargeFieldMap::Reading>> reading =
      map_.large()->Read(target);
  // A failure leaves the last trace in place; GetMap reports the error.
  if (!reading.ok()) return;
  summary_.SetNewerTrace((*reading)->trace, (*reading)->measurements_fused, (*reading)->version);
}

}  // namespace oaipp::server

// How a mission holds its map, dense or sparse: copies for readers, fusion,
// the map a plan works on, whole-map reads and what they cost in memory.
#include <algorithm>
#include <utility>

#include "core/common/status_macros.h"
#include "server/mission.h"

namespace oaipp::server {

std::int64_t Mission::MemoryBytes() const {
  std::shared_ptr<const Environment> env;
  {
    absl::MutexLock lock(&summary_mu_);
    env = summary_.env;
  }
  // A sparse map: its factor and workspace, and the additions (16 bytes a
  // cell) with a reader's copy.
  const std::int64_t map_bytes = large_ == nullptr
                                     ? map_bytes_ + team_chain_.bytes()
                                     : large_->bytes() + 32 * std::int64_t{grid_.num_cells()};
  if (env == nullptr) return map_bytes;
  const Esdf& esdf = env->esdf();
  std::int64_t users = esdf.SharedBy();
  if (worlds_ != nullptr && worlds_->HoldsGrid(esdf.values().data())) --users;
  return map_bytes +
         static_cast<std::int64_t>(esdf.MemoryBytes()) / std::max<std::int64_t>(1, users);
}

GpMap& Mission::MutableMap() {
  // Only holders of mu_ copy map_, and this one holds it for writing: a
  // count of 1 cannot grow under us. A plan that lets go meanwhile costs
  // one needless copy, no harm.
  // The shared start map and its conditionings are no longer this
  // mission's (a plan in progress keeps what it holds).
  start_map_.reset();
  ++dense_version_;
  if (map_.use_count() > 1) map_ = std::make_shared<GpMap>(map_->Clone());
  return *map_;
}

LargeFieldMap::Target Mission::SparseTarget() const {
  return {.added = added_, .version = map_version_, .measurements_fused = measurements_fused_};
}

absl::Status Mission::FuseIntoMap(std::span<const CellObservation> observations, bool defer) {
  if (large_ == nullptr) {
    GpMap& map = MutableMap();
    return defer ? map.UpdateDeferred(observations) : map.Update(observations);
  }
  // Into a copy when a reader still holds the additions (as MutableMap).
  SparseGpMap::Additions next;
  SparseGpMap::Additions* added = added_.get();
  if (added_.use_count() > 1) {
    next = *added_;
    added = &next;
  }
  OAIPP_RETURN_IF_ERROR(SparseGpMap::Accumulate(observations, *added));
  if (added == &next) added_ = std::make_shared<SparseGpMap::Additions>(std::move(next));
  ++map_version_;
  return absl::OkStatus();
}

absl::StatusOr<Mission::PlanMap> Mission::MapForPlan(const Vec2& centre_W,
                                                     std::shared_ptr<const Environment>* env) {
  PlanMap plan;
  if (large_ == nullptr) {
    // Settled and taken under one lock, so no measurement leaves it pending
    // in between.
    absl::MutexLock lock(&mu_);
    map_->Settle();
    *env = env_;
    plan.map = map_;
    plan.key = {.map_version = dense_version_, .rows = grid_.ny(), .cols = grid_.nx()};
    plan.fused_shots = fused_shots_;
    plan.mission_time_s = mission_time_s_;
    // MutableMap lets go of start_map_ at the map's first change.
    if (start_map_ != nullptr && start_map_->map == map_)
      plan.conditioned = start_map_->conditioned;
    return plan;
  }
  LargeFieldMap::Target target;
  {
    absl::ReaderMutexLock lock(&mu_);
    *env = env_;
    target = SparseTarget();
    plan.fused_shots = fused_shots_;
    plan.mission_time_s = mission_time_s_;
  }
  // The planner's window (docs/method.md §3.10): core's, with the settings
  // core's tests check (LargeFieldPlanning::ForField). OA-IPP's leads
  // towards the field's most uncertain square when its neighbourhood is
  // spent.
  const bool oaipp = config_.planner.kind == PlannerKind::kOaIpp ||
                     config_.planner.kind == PlannerKind::kOaIppNonAdaptive;
  const LargeFieldPlanning options =
      LargeFieldPlanning::ForField(grid_, oaipp, config_.planner.common.information.dense_backend);
  OAIPP_ASSIGN_OR_RETURN(
      const FieldWindow window,
      PlanningWindow(grid_, target.added == nullptr ? nullptr : &target.added->precision,
                     large_->prior_variance(), centre_W, options));
  OAIPP_ASSIGN_OR_RETURN(GpMap local, large_->Window(target, window, options));
  plan.key = {.map_version = target.version,
              .first_row = window.first_row,
              .first_col = window.first_col,
              .rows = window.grid.ny(),
              .cols = window.grid.nx()};
  plan.map = std::make_shared<const GpMap>(std::move(local));
  plan.field = &grid_;
  return plan;
}

void Mission::ReadMap(const std::function<void(const GpMap&)>& reader) const {
  if (large_ != nullptr) return;
  SettleMap();
  {
    absl::ReaderMutexLock lock(&mu_);
    if (map_->settled()) {
      reader(*map_);
      return;
    }
  }
  // A measurement came in between: settle and read under one lock, so that
  // a steady stream of them cannot keep the reader waiting.
  absl::MutexLock lock(&mu_);
  map_->Settle();
  reader(*map_);
}

absl::Status Mission::ReadMapView(const std::function<void(const api::MapView&)>& reader) const {
  if (large_ == nullptr) {
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
    target = SparseTarget();
  }
  OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<const LargeFieldMap::Reading> reading,
                         large_->Read(target));
  reader(api::MapView{.grid = &grid_,
                      .mean = &reading->mean,
                      .variances = &reading->variances,
                      .trace = reading->trace});
  return absl::OkStatus();
}

void Mission::SettleMap() const {
  if (large_ == nullptr) {
    absl::MutexLock lock(&mu_);
    // Settling changes how the map is stored, not what it holds: no reader
    // holds a map with a downdate pending (they settle it first), so this
    // is the only copy.
    map_->Settle();
    return;
  }
  LargeFieldMap::Target target;
  {
    absl::ReaderMutexLock lock(&mu_);
    target = SparseTarget();
  }
  absl::StatusOr<std::shared_ptr<const LargeFieldMap::Reading>> reading = large_->Read(target);
  // A failure leaves the last trace in place; GetMap reports the error.
  if (!reading.ok()) return;
  absl::MutexLock lock(&summary_mu_);
  if ((*reading)->version > summary_.trace_version) {
    summary_.trace = (*reading)->trace;
    summary_.trace_measurements_fused = (*reading)->measurements_fused;
    summary_.trace_version = (*reading)->version;
  }
}

}  // namespace oaipp::server

// How a mission records itself: each applied change gets the next log
// sequence as it is persisted (Persist, PersistPlan; MissionLog), and
// snapshots are asked for by the snapshot policy and captured whole
// (CaptureState).
#include <functional>
#include <utility>

#include "core/common/status_macros.h"
#include "server/mission.h"

namespace oaipp::server {

absl::Status Mission::Persist(const PersistFn& persist, const MeasurementResult* answer) {
  OAIPP_RETURN_IF_ERROR(
      log_.Write(persist ? [&](std::int64_t sequence) { return persist(sequence, answer); }
                         : std::function<absl::Status(std::int64_t)>()));
  last_change_unix_us_ = absl::ToUnixMicros(absl::Now());
  return absl::OkStatus();
}

MissionState Mission::CaptureState() const {
  // The locks every change takes (a plan holds planning_'s, a mutation
  // mutation_mu_), so that nothing changes while the state is copied.
  MissionPlanning::Held planning(planning_);
  absl::MutexLock order(&mutation_mu_);
  SettleMap();  // nothing can leave it pending again while order is held
  absl::ReaderMutexLock lock(&mu_);
  MissionState state;
  state.sequence = next_sequence() - 1;
  for (const auto& [id, o] : env_->obstacles()) state.obstacles.push_back(o);
  state.covered_cells = map_.CoveredCells();
  if (map_.sparse()) {
    state.added_precision = map_.additions().precision;
    state.added_information = map_.additions().information;
    const PublishedSummary::Summary summary = summary_.Get();
    state.trace = summary.trace;
    state.trace_measurements_fused = summary.trace_measurements_fused;
  } else {
    state.mean = map_.dense()->Mean();
    state.covariance = map_.dense()->Covariance();
  }
  state.measurements_fused = measurements_fused_;
  state.mission_time_s = mission_time_s_;
  state.fused_shot_s = fused_shots_.Times();
  // The latest alone too, which is what builds before the times were kept
  // read.
  for (const auto& [uav_id, times] : state.fused_shot_s) {
    state.last_shot_s[uav_id] = fused_shots_.Latest(uav_id);
  }
  state.paths_planned = paths_planned_.load();
  state.planner_state = planning.planner().SaveState();
  answers_.ForEach([&](const std::string& request_id, const RememberedAnswer& answer) {
    state.answers.emplace_back(request_id, answer);
  });
  state.committed = planning.timelines().All();
  state.removed_uav_ids = roster_.removed();
  state.landed_uav_ids = roster_.landed();
  return state;
}

void Mission::SetSnapshotPolicy(int every, std::function<void()> wanted) {
  snapshots_.Set(every, std::move(wanted));
}

void Mission::SnapshotDone(bool stored, std::int64_t sequence, std::int64_t measurements_fused) {
  snapshots_.Done(stored, sequence, measurements_fused);
  // Changes made while it was written may already call for the next one
  // (after a failure, the next change asks again).
  if (stored) MaybeWantSnapshot();
}

void Mission::MaybeWantSnapshot() {
  snapshots_.MaybeWant([this] {
    SnapshotPolicy::Progress progress;
    progress.measurements_fused = summary_.Get().measurements_fused;
    progress.last_sequence = next_sequence() - 1;
    return progress;
  });
}

absl::Status Mission::PersistPlan(const PersistPlanFn& persist, const PlannedPath& path,
                                  const std::string& planner_state) {
  if (!persist) return Persist(nullptr);
  return Persist([&](std::int64_t sequence, const MeasurementResult*) {
    return persist(sequence, path, planner_state);
  });
}

}  // namespace oaipp::server

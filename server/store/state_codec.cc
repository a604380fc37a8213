#include "server/store/state_codec.h"

#include <bit>
#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "api/geometry.h"
#include "api/plan.h"
#include "core/common/status_macros.h"
#include "core/mapping/gmrf_prior.h"
#include "oaipp/store/mission_state.pb.h"

namespace oaipp::server {
namespace {

static_assert(std::endian::native == std::endian::little,
              "snapshots store doubles as little-endian bytes");

void AppendDoubles(const double* values, std::size_t count, std::string* out) {
  out->append(reinterpret_cast<const char*>(values), count * sizeof(double));
}

absl::Status Corrupt(absl::string_view what) {
  return absl::DataLossError(absl::StrCat("snapshot: ", what));
}

// The dense map of `in` (sizes checked) into state.mean and covariance.
void DecodeDenseMap(const store::MissionState& in, std::int64_t n, MissionState& state) {
  state.mean.resize(n);
  std::memcpy(state.mean.data(), in.mean().data(), in.mean().size());
  state.covariance.resize(n, n);
  const char* lower = in.covariance_lower().data();
  for (std::int64_t j = 0; j < n; ++j) {
    const std::size_t count = static_cast<std::size_t>(n - j);
    std::memcpy(state.covariance.data() + j * n + j, lower, count * sizeof(double));
    lower += count * sizeof(double);
    for (std::int64_t i = j + 1; i < n; ++i) state.covariance(j, i) = state.covariance(i, j);
  }
}

}  // namespace

std::string EncodeMissionState(const MissionState& state) {
  store::MissionState out;
  out.set_sequence(state.sequence);
  for (const Obstacle& o : state.obstacles) *out.add_obstacles() = api::ObstacleToProto(o);
  for (int c : state.covered_cells) out.add_covered_cells(c);
  if (state.added_precision.size() > 0) {
    // A sparse map: its additions only.
    const auto n = static_cast<std::size_t>(state.added_precision.size());
    out.set_num_cells(static_cast<int>(n));
    AppendDoubles(state.added_precision.data(), n, out.mutable_added_precision());
    AppendDoubles(state.added_information.data(), n, out.mutable_added_information());
    if (state.trace.has_value()) {
      out.set_fitted_trace(*state.trace);
      out.set_trace_measurements_fused(state.trace_measurements_fused);
      out.set_trace_prior_fit(kGmrfFitVersion);
    }
  }
  const auto n = static_cast<std::size_t>(state.mean.size());
  if (n > 0) out.set_num_cells(static_cast<int>(n));
  AppendDoubles(state.mean.data(), n, out.mutable_mean());
  std::string* lower = out.mutable_covariance_lower();
  lower->reserve(n * (n + 1) / 2 * sizeof(double));
  // Column-major storage: column j from row j down is contiguous.
  for (std::size_t j = 0; j < n; ++j) {
    AppendDoubles(state.covariance.data() + j * n + j, n - j, lower);
  }
  out.set_measurements_fused(state.measurements_fused);
  out.set_mission_time_s(state.mission_time_s);
  out.set_paths_planned(state.paths_planned);
  out.set_planner_state(state.planner_state);
  for (const PlannedPath& path : state.committed) {
    api::PlannedPathToProto(path, out.add_committed());
  }
  for (const auto& [request_id, answer] : state.answers) {
    const RequestResult& result = answer.result;
    store::Answer* a = out.add_answers();
    a->set_request_id(request_id);
    a->set_fingerprint(answer.fingerprint);
    if (const auto* o = std::get_if<ObstacleResult>(&result)) {
      a->mutable_obstacles()->set_obstacle_count(o->obstacle_count);
      a->mutable_obstacles()->set_esdf_voxels_recomputed(o->esdf_voxels_recomputed);
    } else if (const auto* m = std::get_if<MeasurementResult>(&result)) {
      a->mutable_measurement()->set_cells_fused(m->cells_fused);
      a->mutable_measurement()->set_trace(m->trace);
      a->mutable_measurement()->set_measurements_fused(m->measurements_fused);
      a->mutable_measurement()->set_trace_measurements_fused(m->trace_measurements_fused);
    } else if (const auto* t = std::get_if<TeamResult>(&result)) {
      for (const std::string& id : t->flying_uav_ids) a->mutable_team()->add_flying_uav_ids(id);
    } else {
      api::PlannedPathToProto(std::get<PlannedPath>(result), a->mutable_plan());
    }
  }
  for (const std::string& id : state.removed_uav_ids) out.add_removed_uav_ids(id);
  for (const std::string& id : state.landed_uav_ids) out.add_landed_uav_ids(id);
  out.mutable_last_shot_s()->insert(state.last_shot_s.begin(), state.last_shot_s.end());
  for (const auto& [uav_id, times] : state.fused_shot_s) {
    (*out.mutable_fused_shot_s())[uav_id].mutable_mission_time_s()->Add(times.begin(), times.end());
  }
  return out.SerializeAsString();
}

absl::StatusOr<MissionState> DecodeMissionState(const std::string& bytes) {
  store::MissionState in;
  if (!in.ParseFromString(bytes)) return Corrupt("does not parse");
  const std::int64_t n = in.num_cells();
  const auto bytes_of = [](std::int64_t count) { return static_cast<std::size_t>(count) * 8; };
  const bool sparse = !in.added_precision().empty();
  const bool sizes_agree =
      n > 0 && (sparse ? bytes_of(n) == in.added_precision().size() &&
                             bytes_of(n) == in.added_information().size() && in.mean().empty() &&
                             in.covariance_lower().empty()
                       : bytes_of(n) == in.mean().size() &&
                             bytes_of(n * (n + 1) / 2) == in.covariance_lower().size() &&
                             in.added_information().empty());
  if (!sizes_agree) return Corrupt(absl::StrCat("the map's sizes disagree with its ", n, " cells"));
  MissionState state;
  state.sequence = in.sequence();
  for (int i = 0; i < in.obstacles_size(); ++i) {
    absl::StatusOr<Obstacle> o =
        api::ObstacleFromProto(in.obstacles(i), absl::StrCat("obstacles[", i, "]"));
    if (!o.ok()) return Corrupt(o.status().message());
    state.obstacles.push_back(*std::move(o));
  }
  state.covered_cells.assign(in.covered_cells().begin(), in.covered_cells().end());
  if (sparse) {
    state.added_precision.resize(n);
    state.added_information.resize(n);
    std::memcpy(state.added_precision.data(), in.added_precision().data(), bytes_of(n));
    std::memcpy(state.added_information.data(), in.added_information().data(), bytes_of(n));
    if (in.has_fitted_trace()) {
      if (!std::isfinite(in.fitted_trace()) || in.fitted_trace() < 0.0 ||
          in.trace_measurements_fused() < 0 ||
          in.trace_measurements_fused() > in.measurements_fused()) {
        return Corrupt(
            "the sparse map's trace is negative, not finite or ahead of its measurements");
      }
      // A trace of another build's prior is not this map's.
      if (in.trace_prior_fit() == kGmrfFitVersion) {
        state.trace = in.fitted_trace();
        state.trace_measurements_fused = in.trace_measurements_fused();
      }
    }
  } else {
    DecodeDenseMap(in, n, state);
  }
  state.measurements_fused = in.measurements_fused();
  state.mission_time_s = in.mission_time_s();
  state.paths_planned = in.paths_planned();
  state.planner_state = in.planner_state();
  for (const store::Answer& a : in.answers()) {
    switch (a.result_case()) {
      case store::Answer::kObstacles:
        state.answers.emplace_back(
            a.request_id(),
            RememberedAnswer{
                a.fingerprint(),
                ObstacleResult{.obstacle_count = a.obstacles().obstacle_count(),
                               .esdf_voxels_recomputed = a.obstacles().esdf_voxels_recomputed()}});
        break;
      case store::Answer::kMeasurement:
        state.answers.emplace_back(
            a.request_id(),
            RememberedAnswer{
                a.fingerprint(),
                MeasurementResult{.cells_fused = a.measurement().cells_fused(),
                                  .trace = a.measurement().trace(),
                                  .measurements_fused = a.measurement().measurements_fused(),
                                  // 0 on a dense map: written before the field existed, and a
                                  // dense map's trace is current. On a sparse one 0 is a
                                  // trace that includes no measurement yet.
                                  .trace_measurements_fused =
                                      sparse || a.measurement().trace_measurements_fused() > 0
                                          ? a.measurement().trace_measurements_fused()
                                          : a.measurement().measurements_fused()}});
        break;
      case store::Answer::kPlan: {
        absl::StatusOr<PlannedPath> path = api::PlannedPathFromProto(a.plan());
        if (!path.ok()) return Corrupt(absl::StrCat("answers: ", path.status().message()));
        state.answers.emplace_back(a.request_id(),
                                   RememberedAnswer{a.fingerprint(), *std::move(path)});
        break;
      }
      case store::Answer::kTeam:
        state.answers.emplace_back(
            a.request_id(),
            RememberedAnswer{a.fingerprint(),
                             TeamResult{.flying_uav_ids = {a.team().flying_uav_ids().begin(),
                                                           a.team().flying_uav_ids().end()}}});
        break;
      case store::Answer::RESULT_NOT_SET:
        return Corrupt("an answer without a result");
    }
  }
  for (const v1::PlanPathResponse& committed : in.committed()) {
    absl::StatusOr<PlannedPath> path = api::PlannedPathFromProto(committed);
    if (!path.ok()) return Corrupt(absl::StrCat("committed: ", path.status().message()));
    if (path->team.uav_id.empty()) return Corrupt("committed: a trajectory without its uav_id");
    state.committed.push_back(*std::move(path));
  }
  state.removed_uav_ids.assign(in.removed_uav_ids().begin(), in.removed_uav_ids().end());
  state.landed_uav_ids.assign(in.landed_uav_ids().begin(), in.landed_uav_ids().end());
  for (const auto& [uav_id, time_s] : in.last_shot_s()) {
    if (!std::isfinite(time_s)) return Corrupt("last_shot_s: a time that is not finite");
    state.last_shot_s.emplace(uav_id, time_s);
  }
  for (const auto& [uav_id, times] : in.fused_shot_s()) {
    for (double t : times.mission_time_s()) {
      if (!std::isfinite(t)) return Corrupt("fused_shot_s: a time that is not finite");
    }
    state.fused_shot_s.emplace(
        uav_id, std::vector<double>(times.mission_time_s().begin(), times.mission_time_s().end()));
  }
  return state;
}

}  // namespace oaipp::server

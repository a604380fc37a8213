#include "server/mission.h"

#include <algorithm>
#include <cmath>
#include <variant>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "api/limits.h"
#include "core/common/status_macros.h"
#include "core/mapping/camera.h"
#include "core/planning/planners.h"
#include "core/trajectory/polynomial_trajectory.h"
#include "server/team_timelines.h"

namespace oaipp::server {

namespace {

// The field's cells whose ground is inside an obstacle, in the grid's order.
std::vector<int> CellsUnder(const FieldGrid& grid, const Environment& env) {
  return grid.CellsUnderObstacles([&](const Vec3& p_W) { return env.IsInsideObstacle(p_W); });
}

// `env` ready to share between readers, its ESDF pooled with equal ones.
std::shared_ptr<const Environment> Shared(Environment env, EsdfPool* esdfs) {
  if (esdfs != nullptr) env.ShareEsdf(*esdfs);
  return std::make_shared<const Environment>(std::move(env));
}

// Bytes one log entry holds: the entry and what its vectors and strings own.
std::int64_t LogEntryBytes(const LogEntry& entry) {
  std::int64_t bytes = sizeof(LogEntry);
  if (const auto* input = std::get_if<MeasurementInput>(&entry)) {
    if (input->labels.has_value()) {
      bytes += static_cast<std::int64_t>(input->labels->cells.size() * sizeof(int) +
                                         input->labels->labels.size() * sizeof(double));
    }
    if (input->detections.has_value()) {
      bytes += static_cast<std::int64_t>(input->detections->boxes.size() *
                                         sizeof(input->detections->boxes[0]));
    }
  } else if (const auto* change = std::get_if<ObstacleChange>(&entry)) {
    bytes +=
        static_cast<std::int64_t>((change->add.size() + change->replace.size()) * sizeof(Obstacle));
    for (const Obstacle& o : change->add) bytes += static_cast<std::int64_t>(o.id.size());
    for (const Obstacle& o : change->replace) bytes += static_cast<std::int64_t>(o.id.size());
    for (const std::string& id : change->remove) {
      bytes += static_cast<std::int64_t>(sizeof(std::string) + id.size());
    }
  }
  return bytes;
}

// The longest time between two shots of any of the mission's cameras, s.
double LongestShotPeriod(const MissionConfig& config) {
  double period = 1.0 / config.camera.rate_hz;
  for (const api::TeamMember& member : config.team) {
    period = std::max(period, 1.0 / member.kit.camera.rate_hz);
  }
  return period;
}

}  // namespace

Mission::Mission(std::string id, MissionConfig config, FieldGrid grid, Environment env,
                 std::shared_ptr<GpMap> map, std::unique_ptr<LargeFieldMap> large,
                 std::unique_ptr<Planner> planner, const SiteCaches& caches)
    : id_(std::move(id)),
      config_(std::move(config)),
      grid_(std::move(grid)),
      create_time_(absl::FromUnixMicros(absl::ToUnixMicros(absl::Now()))),  // as stored
      esdfs_(caches.esdfs),
      worlds_(caches.worlds),
      env_(Shared(std::move(env), caches.esdfs)),
      map_(grid_, std::move(map), std::move(large)),
      planning_(config_, std::move(planner)) {}

absl::StatusOr<Environment> Mission::BuildWorld(const MissionConfig& config,
                                                const std::string& world_key,
                                                const SiteCaches& caches) {
  if (caches.worlds == nullptr) return config.MakeEnvironment();
  // A world built for the cache joins the ESDF pool as it is built, once:
  // its clones then find their grid in the pool by identity, instead of
  // each hashing 16 MB when a fleet's missions are created at once.
  return caches.worlds->Get(world_key, [&]() -> absl::StatusOr<Environment> {
    OAIPP_ASSIGN_OR_RETURN(Environment built, config.MakeEnvironment());
    if (caches.esdfs != nullptr) built.ShareEsdf(*caches.esdfs);
    return built;
  });
}

namespace {

// OK when `p_W` keeps `needed` from every obstacle, the fence and every
// no-fly zone (exact distance); else InvalidArgument naming `field` and
// saying what is nearest.
absl::Status CheckClear(const Environment& env, const Vec3& p_W, double needed,
                        absl::string_view field, const char* rule) {
  const double clearance = env.SignedDistance(p_W);
  if (clearance >= needed) return absl::OkStatus();
  const bool fence = env.airspace().FenceSignedDistance(p_W.head<2>()) <= clearance;
  const bool zone = !fence && env.airspace().SignedDistance(p_W) <= clearance;
  const char* what = fence ? "the fence" : zone ? "a no-fly zone" : "an obstacle";
  const std::string where = clearance >= 0 ? absl::StrFormat("%.3g m from %s", clearance, what)
                            : fence        ? std::string("outside the fence")
                                           : absl::StrCat("inside ", what);
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s.position_m: (%.3g, %.3g, %.3g) is %s; the UAV needs %.3g m of clearance (%s)", field,
      p_W.x(), p_W.y(), p_W.z(), where, needed, rule));
}

// A home the UAV can land at and reach (MissionSpec.home): clear by its
// clearance, with a clear column down to the ground, and a way home from
// the start.
absl::Status CheckHome(const MissionConfig& config, const Environment& env) {
  if (!config.planner.home.has_value()) return absl::OkStatus();
  const Vec3& home = config.planner.home->home_W;
  const PlannerLimits& limits = config.planner.common.limits;
  const double needed = limits.ObstacleClearance();
  OAIPP_RETURN_IF_ERROR(CheckClear(env, home, needed, "spec.home", ClearanceRuleName(limits)));
  if (!env.IsSegmentClear(home, Vec3(home.x(), home.y(), 0.0), needed)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "spec.home.position_m: the landing from (%.3g, %.3g, %.3g) straight down to the ground "
        "passes closer than %.3g m (%s) to an obstacle or a no-fly zone",
        home.x(), home.y(), home.z(), needed, ClearanceRuleName(limits)));
  }
  if (absl::Status way = PlanWayHome(env, config.start, home, limits).status(); !way.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.home.position_m: unreachable from spec.start: ", way.message()));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::shared_ptr<Mission>> Mission::Create(std::string id, MissionConfig config,
                                                         const SiteCaches& caches) {
  std::string world_key;
  if (caches.worlds != nullptr || caches.start_maps != nullptr) world_key = WorldKey(config);
  OAIPP_ASSIGN_OR_RETURN(Environment env, BuildWorld(config, world_key, caches));
  // Every UAV must start where it may fly: clear of every obstacle, the
  // fence and every no-fly zone by half its radius, as PlanPath asks of
  // every state (exact distance).
  struct Start {
    std::string field;
    Vec3 position_W;
    double needed;
  };
  std::vector<Start> starts;
  if (config.team.empty()) {
    starts.push_back(
        {"spec.start", config.start.position_W, config.planner.common.limits.ObstacleClearance()});
  }
  for (std::size_t i = 0; i < config.team.size(); ++i) {
    starts.push_back({absl::StrCat("spec.team[", i, "].start"), config.team[i].start.position_W,
                      config.team[i].kit.limits.ObstacleClearance()});
  }
  for (const auto& [field, start, needed] : starts) {
    OAIPP_RETURN_IF_ERROR(
        CheckClear(env, start, needed, field, ClearanceRuleName(config.planner.common.limits)));
  }
  OAIPP_RETURN_IF_ERROR(CheckHome(config, env));
  OAIPP_ASSIGN_OR_RETURN(FieldGrid grid, config.MakeGrid());
  OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<Planner> planner, MakePlanner(config.planner));
  if (config.ResolveMapBackend() == api::MapBackend::kSparse) {
    // The site's prior (each mission factorises its own map).
    OAIPP_ASSIGN_OR_RETURN(
        std::unique_ptr<LargeFieldMap> large,
        LargeFieldMap::Create(grid, config.gp, caches.gmrf_priors, config.prior_map.get()));
    std::shared_ptr<Mission> mission(new Mission(std::move(id), std::move(config), grid,
                                                 std::move(env), nullptr, std::move(large),
                                                 std::move(planner), caches));
    LargeFieldMap::Target first;
    {
      absl::MutexLock lock(&mission->mu_);
      OAIPP_RETURN_IF_ERROR(mission->FuseCoveredCells());
      mission->mission_time_s_ = mission->config_.start.mission_time_s;
      first = mission->map_.SparseTarget(mission->measurements_fused_);
    }
    // The first variance map, so that the mission reports its trace.
    OAIPP_RETURN_IF_ERROR(mission->map_.large()->Read(first).status());
    absl::MutexLock lock(&mission->mu_);
    mission->Publish();
    return mission;
  }
  // The map's updates run on the backend the objective's products run on
  // (the server's --dense_backend).
  auto prior = [&]() -> absl::StatusOr<GpMap> {
    Eigen::VectorXd mean = config.PriorMean(grid.num_cells());
    absl::StatusOr<GpMap> made;
    if (caches.priors != nullptr) {
      made = caches.priors->NewMap(grid, config.gp, std::move(mean));
    } else {
      OAIPP_ASSIGN_OR_RETURN(Eigen::MatrixXd p0, PriorCovariance(grid, config.gp));
      made = GpMap::FromPrior(grid, std::move(mean), std::move(p0));
    }
    OAIPP_ASSIGN_OR_RETURN(GpMap map, std::move(made));
    map.set_dense_backend(config.planner.common.information.dense_backend);
    return map;
  };
  std::shared_ptr<GpMap> map;
  std::shared_ptr<const StartMap> start_map;
  if (caches.start_maps != nullptr) {
    // The same prior and the same fusion, in the same cell order, as
    // FuseCoveredCells below would do: the shared map is equal bit for bit
    // to the mission's own. MutableMap copies it before the first change.
    OAIPP_ASSIGN_OR_RETURN(
        std::shared_ptr<const StartMap> shared,
        caches.start_maps->Get(StartMapKey(world_key, config), [&]() -> absl::StatusOr<StartMap> {
          OAIPP_ASSIGN_OR_RETURN(GpMap fused, prior());
          std::vector<int> cells = CellsUnder(fused.grid(), env);
          OAIPP_RETURN_IF_ERROR(fused.FuseNearCertainZeros(cells));
          return StartMap{std::make_shared<GpMap>(std::move(fused)), std::move(cells)};
        }));
    map = shared->map;
    start_map = std::move(shared);
  } else {
    OAIPP_ASSIGN_OR_RETURN(GpMap fresh, prior());
    map = std::make_shared<GpMap>(std::move(fresh));
  }
  std::shared_ptr<Mission> mission(new Mission(std::move(id), std::move(config), std::move(grid),
                                               std::move(env), std::move(map), nullptr,
                                               std::move(planner), caches));
  absl::MutexLock lock(&mission->mu_);
  if (start_map != nullptr) mission->map_.AdoptStartMap(std::move(start_map));
  OAIPP_RETURN_IF_ERROR(mission->FuseCoveredCells());
  mission->mission_time_s_ = mission->config_.start.mission_time_s;
  mission->Publish();
  return mission;
}

absl::Status Mission::FuseCoveredCells() { return map_.FuseCovered(CellsUnder(grid_, *env_)); }

void Mission::Publish(bool obstacles_changed) {
  PublishedSummary::Summary next;
  if (obstacles_changed) {
    auto obstacles = std::make_shared<std::vector<Obstacle>>();
    for (const auto& [id, o] : env_->obstacles()) obstacles->push_back(o);
    next.obstacles = std::move(obstacles);
  } else {
    next.obstacles = summary_.Get().obstacles;  // shared, not copied
  }
  next.env = env_;
  if (const std::shared_ptr<const LargeFieldMap::Reading> reading =
          map_.sparse() ? map_.large()->latest() : nullptr;
      reading != nullptr) {
    // The newest variance map; SettleMap brings it up to date.
    next.trace = reading->trace;
    next.trace_measurements_fused = reading->measurements_fused;
    next.trace_version = reading->version;
  } else if (map_.sparse()) {
    // None yet (a mission read back from its snapshot): the snapshot's
    // trace stands.
    const PublishedSummary::Summary last = summary_.Get();
    next.trace = last.trace;
    next.trace_measurements_fused = last.trace_measurements_fused;
    next.trace_version = last.trace_version;
  } else {
    next.trace = map_.dense()->Trace();
    next.trace_measurements_fused = measurements_fused_;
  }
  next.measurements_fused = measurements_fused_;
  next.mission_time_s = mission_time_s_;
  // A background refresh may have published a newer variance map.
  summary_.Replace(std::move(next), map_.sparse());
}

absl::StatusOr<ObstacleResult> Mission::UpdateObstacles(const ObstacleChange& change,
                                                        const RequestKey& request,
                                                        const PersistFn& persist) {
  ObstacleResult result;
  {
    absl::MutexLock order(&mutation_mu_);
    if (auto done = answers_.Recall<ObstacleResult>(request)) return *std::move(done);
    // Applied to a copy first, so that neither a refused change nor a failed
    // write touches the mission; the ESDF is recomputed while readers and
    // plans go on with the current world (only mutations change it, and
    // they wait for this one).
    std::shared_ptr<const Environment> current;
    {
      absl::ReaderMutexLock lock(&mu_);
      current = env_;
    }
    Environment next = current->Clone();
    current.reset();
    OAIPP_RETURN_IF_ERROR(next.Apply(change));
    if (next.obstacles().size() > static_cast<std::size_t>(api::kMaxObstacles)) {
      return absl::InvalidArgumentError(absl::StrCat("add: the mission would hold ",
                                                     next.obstacles().size(),
                                                     " obstacles; at most ", api::kMaxObstacles));
    }
    const std::int64_t entry_bytes = LogEntryBytes(change);
    OAIPP_RETURN_IF_ERROR(log_.CheckRoom(entry_bytes, answers_.bytes()));
    OAIPP_RETURN_IF_ERROR(Persist(persist));
    absl::MutexLock lock(&mu_);
    env_ = Shared(std::move(next), esdfs_);
    // Ground newly under a building holds no targets. (Ground uncovered by a
    // removal keeps what was fused: the map cannot forget a measurement.)
    OAIPP_RETURN_IF_ERROR(FuseCoveredCells());
    log_.Append(change, entry_bytes);
    result.obstacle_count = static_cast<int>(env_->obstacles().size());
    result.esdf_voxels_recomputed = env_->esdf().last_recomputed_voxels();
    Publish();
    answers_.Remember(request, result);
  }
  events_.Emit(MissionEventData::ObstaclesChanged{result.obstacle_count});
  MaybeWantSnapshot();
  return result;
}

absl::StatusOr<std::vector<CellObservation>> Mission::PrepareMeasurement(
    const MeasurementInput& input) const {
  const FieldGrid& grid = grid_;
  const Vec3& p = input.pose.p_WC;
  if (!env_->flight_volume().Contains(p, 1e-6)) {
    return absl::InvalidArgumentError(absl::StrCat("camera_position_m: (", p.x(), ", ", p.y(), ", ",
                                                   p.z(), ") lies outside the flight volume"));
  }
  CellLabels labels;
  if (input.labels.has_value()) {
    labels = *input.labels;
    for (std::size_t i = 0; i < labels.cells.size(); ++i) {
      if (!grid.IsValidCell(labels.cells[i])) {
        return absl::InvalidArgumentError(absl::StrCat("labels.cells[", i, "]: ", labels.cells[i],
                                                       " is not a cell of the ", grid.nx(), " x ",
                                                       grid.ny(), " field"));
      }
    }
  } else if (input.detections.has_value()) {
    CameraIntrinsics intrinsics;
    if (input.detections->intrinsics.has_value()) {
      intrinsics = *input.detections->intrinsics;
    } else {
      OAIPP_ASSIGN_OR_RETURN(intrinsics, config_.DefaultIntrinsics(input.uav_id));
    }
    absl::StatusOr<CellLabels> projected =
        DetectionsToLabels(grid, intrinsics, input.pose, input.detections->boxes,
                           input.detections->min_confidence, env_.get());
    if (!projected.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("detections.", projected.status().message()));
    }
    labels = std::move(projected).value();
  } else {
    return absl::InvalidArgumentError("data: set labels or detections");
  }
  return LabelsToObservations(grid, config_.KitOf(input.uav_id).noise, p.z(), labels.cells,
                              labels.labels);
}

absl::StatusOr<MeasurementResult> Mission::AddMeasurement(const MeasurementInput& input,
                                                          const RequestKey& request,
                                                          const PersistFn& persist,
                                                          const MeasurementResult* recorded) {
  MeasurementResult result;
  std::vector<CellObservation> observations;
  {
    absl::MutexLock order(&mutation_mu_);
    if (auto done = answers_.Recall<MeasurementResult>(request)) return *std::move(done);
    OAIPP_RETURN_IF_ERROR(config_.CheckUavId(input.uav_id, "uav_id"));
    // A sparse map's answer is known before the measurement is fused: its
    // trace is the newest variance map's, which this measurement does not
    // change (SettleMap refreshes it later). It is stored with the record.
    std::optional<MeasurementResult> known;
    {
      absl::ReaderMutexLock lock(&mu_);
      OAIPP_ASSIGN_OR_RETURN(observations, PrepareMeasurement(input));
      if (map_.sparse()) {
        const PublishedSummary::Summary summary = summary_.Get();
        known = MeasurementResult{.cells_fused = static_cast<int>(observations.size()),
                                  .trace = summary.trace,
                                  .measurements_fused = measurements_fused_ + 1,
                                  .trace_measurements_fused = summary.trace_measurements_fused};
      }
    }
    if (recorded != nullptr) known = *recorded;
    const std::int64_t entry_bytes = LogEntryBytes(input);
    OAIPP_RETURN_IF_ERROR(log_.CheckRoom(entry_bytes, answers_.bytes()));
    // Durable first: a failed write leaves the mission as it was.
    OAIPP_RETURN_IF_ERROR(Persist(persist, map_.sparse() ? &*known : nullptr));
    absl::MutexLock lock(&mu_);
    OAIPP_RETURN_IF_ERROR(map_.Fuse(observations, /*defer=*/true));
    ++measurements_fused_;
    mission_time_s_ = std::max(mission_time_s_, input.mission_time_s);
    fused_shots_.Add(input.uav_id, input.mission_time_s);
    // No plan starts more than TeamTimelines::kMaxLag_s behind the newest
    // time, so none asks about a shot more than a camera period before that.
    fused_shots_.Prune(mission_time_s_ - TeamTimelines::kMaxLag_s - LongestShotPeriod(config_));
    log_.Append(input, entry_bytes);
    Publish(/*obstacles_changed=*/false);
    if (known.has_value()) {
      result = *known;
    } else {
      const PublishedSummary::Summary summary = summary_.Get();
      result = MeasurementResult{.cells_fused = static_cast<int>(observations.size()),
                                 .trace = summary.trace,
                                 .measurements_fused = measurements_fused_,
                                 .trace_measurements_fused = summary.trace_measurements_fused};
    }
    answers_.Remember(request, result);
  }
  std::vector<int> detected;
  for (const CellObservation& o : observations) {
    if (o.value >= kDetectedLabel) detected.push_back(o.cell);
  }
  std::sort(detected.begin(), detected.end());
  detected.erase(std::unique(detected.begin(), detected.end()), detected.end());
  track_.Add(input.uav_id, input.pose.p_WC, detected, nullptr);
  events_.Emit(MissionEventData::MeasurementFused{
      input.mission_time_s, result.cells_fused, result.trace, input.pose.p_WC, std::move(detected),
      result.trace_measurements_fused, input.uav_id});
  MaybeWantSnapshot();
  return result;
}

absl::StatusOr<PlannedPath> Mission::Plan(const UavState& state,
                                          std::optional<double> next_shot_mission_s,
                                          const RequestKey& request, const PlanCall& call) {
  MissionPlanning::Held planning(planning_);
  if (auto done = answers_.Recall<PlannedPath>(request)) return *std::move(done);
  OAIPP_RETURN_IF_ERROR(CheckPlanningUav(call.uav_id));
  const double elapsed = state.mission_time_s - config_.start.mission_time_s;
  if (elapsed >= config_.budget_s) {
    return absl::FailedPreconditionError(absl::StrCat("state.mission_time_s: the flight budget of ",
                                                      config_.budget_s, " s is spent"));
  }
  // The UAV's own camera, noise and limits (a team member's may differ).
  const api::UavKit kit = config_.KitOf(call.uav_id);
  OAIPP_ASSIGN_OR_RETURN(Planner * planner, planning.PlannerOf(call.uav_id));
  double next_shot;
  if (next_shot_mission_s.has_value()) {
    next_shot = *next_shot_mission_s;
  } else {
    // The camera fires every 1 / rate seconds on the mission clock.
    const double period = 1.0 / kit.camera.rate_hz;
    next_shot = period * std::ceil(state.mission_time_s / period - 1e-9);
  }
  const std::string state_before = planner->SaveState();
  // The world and map as they are now; changes made while planning go to
  // copies (MutableMap) and count from the next plan.
  std::shared_ptr<const Environment> env;
  OAIPP_ASSIGN_OR_RETURN(PlanMap plan_map, MapForPlan(state.position_W.head<2>(), &env));
  if (!config_.team.empty()) {
    OAIPP_RETURN_IF_ERROR(planning.timelines().CheckStart(call.uav_id, state.mission_time_s,
                                                          plan_map.mission_time_s));
  }
  std::shared_ptr<const GpMap> map = std::move(plan_map.shared.map);
  std::shared_ptr<ConditionedCache> conditioned = std::move(plan_map.shared.conditioned);
  const FieldGrid* field = plan_map.shared.field;
  // The planning budget counts from here: a caller that queued the plan
  // calls this once a planner is free, and neither waiting nor settling the
  // last measurement's downdate is planning.
  const absl::Time deadline = call.budget == absl::InfiniteDuration()
                                  ? call.deadline
                                  : std::min(call.deadline, absl::Now() + call.budget);
  std::vector<std::pair<std::string, std::int64_t>> versions;
  const std::vector<Teammate> teammates =
      planning.TeammatesOf(call.uav_id, state.mission_time_s, plan_map.mission_time_s,
                           plan_map.fused_shots, roster_, &versions);
  const PlanningContext context{
      .environment = env.get(),
      .map = map.get(),
      .camera = kit.camera,
      .noise = kit.noise,
      .next_shot_mission_s = next_shot,
      .remaining_budget_s = config_.budget_s - elapsed,
      .cancelled = call.cancelled,
      .search_fraction = call.search_fraction,
      .conditioned = conditioned.get(),
      .chain = config_.team.size() >= 2 ? ChainedPrefix{&planning.chain(), plan_map.shared.key}
                                        : ChainedPrefix{},
      .teammates = teammates,
      .min_separation_m = config_.min_separation_m,
      .field = field,
      .search_area = plan_map.shared.transit.empty()
                         ? config_.SearchMask()
                         : std::span<const std::uint8_t>(plan_map.shared.transit)};
  absl::StatusOr<PlannedPath> path = planner->Plan(context, state, deadline);
  if (!path.ok() && !call.uav_id.empty())
    path = planning_.NamedForMember(path.status(), call.uav_id);
  env.reset();
  map.reset();
  conditioned.reset();
  if (absl::IsDeadlineExceeded(path.status()) && deadline < call.deadline) {
    // The budget ended planning, not the call's deadline: DeadlineExceeded
    // is kept for the latter (proto: PlanPathRequest.planning_budget_s).
    if (call.budget_is_servers) {
      // The server's load cut it short: the caller cannot fix that by
      // asking differently, only by asking again.
      return absl::UnavailableError(absl::StrCat(
          "PlanPath: the server is loaded: after ", absl::ToDoubleSeconds(call.queued),
          " s waiting for a planner, its plan latency bound left ",
          absl::ToDoubleSeconds(call.budget), " s, and no collision-free path was found in it (",
          path.status().message(), "); retry"));
    }
    return absl::FailedPreconditionError(absl::StrCat(
        "planning_budget_s: no collision-free path was found within the planning budget of ",
        absl::ToDoubleSeconds(call.budget), " s (", path.status().message(),
        "); a larger budget may find one"));
  }
  if (!path.ok()) return path.status();
  path->stats.queued_s = absl::ToDoubleSeconds(call.queued);
  path->stats.search_budget_s =
      call.budget == absl::InfiniteDuration() ? 0.0 : absl::ToDoubleSeconds(call.budget);
  if (!config_.team.empty()) {
    // Plans are made one at a time (planning holds their lock), so the
    // count is this one's version.
    path->team = {.uav_id = call.uav_id,
                  .plan_version = paths_planned_.load() + 1,
                  .start_mission_s = state.mission_time_s,
                  .checked_against = std::move(versions)};
    for (const Teammate& mate : teammates) {
      if (!mate.pending_shots_W.empty()) {
        path->team.shots_counted[mate.uav_id] = static_cast<int>(mate.pending_shots_W.size());
      }
    }
  }
  // Answered only once durable; a failed write takes the planner back to
  // where it was, so the mission stays as the store has it.
  const std::string state_after = planner->SaveState();
  if (absl::Status written = PersistPlan(call.persist, *path, state_after); !written.ok()) {
    (void)planner->RestoreState(state_before);
    return written;
  }
  ++paths_planned_;
  if (!config_.team.empty()) {
    planning.timelines().Commit(*path, std::max(plan_map.mission_time_s, state.mission_time_s));
  }
  // The remembered answer counts against the mission's memory until newer
  // ids push it out (IdempotencyMemo::bytes).
  answers_.Remember(request, *path);
  {
    absl::MutexLock lock(&mu_);
    mission_time_s_ = std::max(mission_time_s_, state.mission_time_s);
    Publish(/*obstacles_changed=*/false);
  }
  std::vector<Vec3> planned;
  if (absl::StatusOr<std::vector<TimedPosition>> samples = SampleTrajectory(path->trajectory, 10.0);
      samples.ok()) {
    for (const TimedPosition& s : *samples) planned.push_back(s.position_W);
  }
  track_.Add(call.uav_id, state.position_W, {}, &planned);
  events_.Emit(MissionEventData::PathPlanned{
      state.mission_time_s, path->trajectory.Duration(), path->objective, path->control_waypoints_W,
      state.position_W, path->team.uav_id, path->team.plan_version});
  MaybeWantSnapshot();
  return path;
}

absl::Time Mission::last_change_time() const {
  const std::int64_t us = last_change_unix_us_.load();
  return us == 0 ? create_time_ : absl::FromUnixMicros(us);
}

void Mission::set_last_change_time(absl::Time time) {
  last_change_unix_us_ = absl::ToUnixMicros(time);
}

bool Mission::finished() const {
  return summary_.Get().mission_time_s - config_.start.mission_time_s >= config_.budget_s;
}

MissionSnapshot Mission::Snapshot() const {
  MissionSnapshot s;
  s.id = id_;
  s.config = config_;
  s.create_time = create_time_;
  {
    const PublishedSummary::Summary summary = summary_.Get();
    s.obstacles = *summary.obstacles;
    s.trace = summary.trace;
    s.trace_measurements_fused = summary.trace_measurements_fused;
    s.measurements_fused = summary.measurements_fused;
    s.mission_time_s = summary.mission_time_s;
  }
  s.removed_uav_ids = roster_.removed();
  s.landed_uav_ids = roster_.landed();
  s.memory_bytes = MemoryBytes();
  s.paths_planned = paths_planned_.load();
  return s;
}

}  // namespace oaipp::server

#include "server/mission.h"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "api/limits.h"
#include "api/spec.h"
#include "api/status.h"
#include "core/common/status_macros.h"
#include "core/mapping/camera.h"
#include "core/trajectory/polynomial_trajectory.h"

namespace oaipp::server {

namespace {

// Everything a mission's world is built from (MakeEnvironment): the field,
// the flight settings (altitudes, ESDF voxel and truncation), the ESDF's
// voxel limit and the obstacles, as bytes.
std::string WorldKey(const MissionConfig& config) {
  const v1::MissionSpec spec = api::ConfigToMissionSpec(config);
  v1::MissionSpec world;
  *world.mutable_field() = spec.field();
  *world.mutable_flight() = spec.flight();
  *world.mutable_obstacles() = spec.obstacles();
  return absl::StrCat(world.SerializeAsString(), "|", config.esdf.max_voxels, "|",
                      config.esdf.voxel_size_m, "|", config.esdf.truncation_m);
}

// The key of a site's StartMap: its world's key and the GP parameters,
// exactly (hexadecimal floats).
std::string StartMapKey(const std::string& world_key, const GpParams& gp) {
  return absl::StrFormat("%s|%a|%a|%a|%a", world_key, gp.length_scale_m, gp.signal_var,
                         gp.noise_var, gp.prior_mean);
}

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

}  // namespace
void EventQueue::Push(MissionEventData event) {
  std::function<void()> listener;
  {
    absl::MutexLock lock(&mu_);
    if (closed_) return;
    if (events_.size() >= capacity_) {
      events_.pop_front();
      ++dropped_;
    }
    events_.push_back(std::move(event));
    listener = listener_;
  }
  if (listener) listener();
}

std::optional<MissionEventData> EventQueue::TryPop() {
  absl::MutexLock lock(&mu_);
  if (events_.empty()) return std::nullopt;
  MissionEventData event = std::move(events_.front());
  events_.pop_front();
  return event;
}

void EventQueue::SetListener(std::function<void()> listener) {
  absl::MutexLock lock(&mu_);
  listener_ = std::move(listener);
}

std::optional<MissionEventData> EventQueue::Pop(absl::Time until) {
  absl::MutexLock lock(&mu_);
  auto ready = [this]() ABSL_SHARED_LOCKS_REQUIRED(mu_) { return !events_.empty() || closed_; };
  mu_.AwaitWithDeadline(absl::Condition(&ready), until);
  if (events_.empty()) return std::nullopt;
  MissionEventData event = std::move(events_.front());
  events_.pop_front();
  return event;
}

void EventQueue::Close(absl::Status reason) {
  std::function<void()> listener;
  {
    absl::MutexLock lock(&mu_);
    if (!closed_) close_reason_ = std::move(reason);
    closed_ = true;
    listener = listener_;
  }
  if (listener) listener();
}

bool EventQueue::closed() const {
  absl::MutexLock lock(&mu_);
  return closed_ && events_.empty();
}

absl::Status EventQueue::close_reason() const {
  absl::MutexLock lock(&mu_);
  return close_reason_;
}

std::int64_t EventQueue::dropped() const {
  absl::MutexLock lock(&mu_);
  return dropped_;
}

template <typename T>
std::optional<absl::StatusOr<T>> Mission::Recall(const RequestKey& request) {
  if (request.request_id.empty()) return std::nullopt;
  absl::MutexLock lock(&idempotency_mu_);
  const RememberedAnswer* done = done_.Find(request.request_id);
  if (done == nullptr) return std::nullopt;
  if (!request.fingerprint.empty() && !done->fingerprint.empty() &&
      request.fingerprint != done->fingerprint) {
    return absl::StatusOr<T>(absl::InvalidArgumentError(absl::StrCat(
        "request_id: ", api::EchoInput(request.request_id),
        " was first used for a different request; a retry must repeat the request exactly, "
        "a new request needs a new request_id")));
  }
  if (const T* result = std::get_if<T>(&done->result)) return absl::StatusOr<T>(*result);
  return absl::StatusOr<T>(absl::InvalidArgumentError(absl::StrCat(
      "request_id: ", api::EchoInput(request.request_id), " was used by another kind of call")));
}

void Mission::Remember(const RequestKey& request, Result result) {
  absl::MutexLock lock(&idempotency_mu_);
  done_.Remember(request.request_id, {request.fingerprint, std::move(result)});
}

Mission::Mission(std::string id, MissionConfig config, Environment env, std::shared_ptr<GpMap> map,
                 std::unique_ptr<Planner> planner, const SiteCaches& caches)
    : id_(std::move(id)),
      config_(std::move(config)),
      create_time_(absl::FromUnixMicros(absl::ToUnixMicros(absl::Now()))),  // as stored
      map_bytes_(8 * static_cast<std::int64_t>(map->num_cells()) *
                 (static_cast<std::int64_t>(map->num_cells()) + 1)),
      esdfs_(caches.esdfs),
      worlds_(caches.worlds),
      env_(Shared(std::move(env), caches.esdfs)),
      map_(std::move(map)),
      planner_(std::move(planner)) {}

absl::StatusOr<std::shared_ptr<Mission>> Mission::Create(std::string id, MissionConfig config,
                                                         const SiteCaches& caches) {
  std::string world_key;
  if (caches.worlds != nullptr || caches.start_maps != nullptr) world_key = WorldKey(config);
  // A world built for the cache joins the ESDF pool as it is built, once:
  // its clones then find their grid in the pool by identity, instead of
  // each hashing 16 MB when a fleet's missions are created at once.
  auto build = [&]() -> absl::StatusOr<Environment> {
    OAIPP_ASSIGN_OR_RETURN(Environment built, config.MakeEnvironment());
    if (caches.esdfs != nullptr) built.ShareEsdf(*caches.esdfs);
    return built;
  };
  OAIPP_ASSIGN_OR_RETURN(Environment env, caches.worlds != nullptr
                                              ? caches.worlds->Get(world_key, build)
                                              : config.MakeEnvironment());
  // The UAV must start where it may fly: clear of every obstacle by half
  // its radius, as PlanPath asks of every state (exact distance).
  const Vec3& start = config.start.position_W;
  const double clearance = env.SignedDistance(start);
  const double needed = 0.5 * config.planner.common.limits.uav_radius_m;
  if (clearance < needed) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "spec.start.position_m: (%.3g, %.3g, %.3g) is %s; the UAV needs %.3g m of clearance "
        "(uav_radius_m / 2)",
        start.x(), start.y(), start.z(),
        clearance < 0 ? "inside an obstacle"
                      : absl::StrFormat("%.3g m from an obstacle", clearance),
        needed));
  }
  OAIPP_ASSIGN_OR_RETURN(FieldGrid grid, config.MakeGrid());
  auto prior = [&]() -> absl::StatusOr<GpMap> {
    return caches.priors != nullptr ? caches.priors->NewMap(grid, config.gp)
                                    : GpMap::Create(grid, config.gp);
  };
  std::shared_ptr<GpMap> map;
  std::shared_ptr<const StartMap> start_map;
  std::vector<int> covered;
  if (caches.start_maps != nullptr) {
    // The same prior and the same fusion, in the same cell order, as
    // FuseCoveredCells below would do: the shared map is equal bit for bit
    // to the mission's own. MutableMap copies it before the first change.
    OAIPP_ASSIGN_OR_RETURN(
        std::shared_ptr<const StartMap> shared,
        caches.start_maps->Get(
            StartMapKey(world_key, config.gp), [&]() -> absl::StatusOr<StartMap> {
              OAIPP_ASSIGN_OR_RETURN(GpMap fused, prior());
              std::vector<int> cells = CellsUnder(fused.grid(), env);
              OAIPP_RETURN_IF_ERROR(fused.FuseNearCertainZeros(cells));
              return StartMap{std::make_shared<GpMap>(std::move(fused)), std::move(cells)};
            }));
    map = shared->map;
    covered = shared->covered_cells;
    start_map = std::move(shared);
  } else {
    OAIPP_ASSIGN_OR_RETURN(GpMap fresh, prior());
    map = std::make_shared<GpMap>(std::move(fresh));
  }
  OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<Planner> planner, MakePlanner(config.planner));
  std::shared_ptr<Mission> mission(new Mission(std::move(id), std::move(config), std::move(env),
                                               std::move(map), std::move(planner), caches));
  absl::MutexLock lock(&mission->mu_);
  mission->start_map_ = std::move(start_map);
  mission->covered_cells_.insert(covered.begin(), covered.end());
  OAIPP_RETURN_IF_ERROR(mission->FuseCoveredCells());
  mission->mission_time_s_ = mission->config_.start.mission_time_s;
  mission->Publish();
  return mission;
}

absl::StatusOr<std::shared_ptr<Mission>> Mission::Restore(std::string id, MissionConfig config,
                                                          MissionState state,
                                                          const SiteCaches& caches) {
  OAIPP_ASSIGN_OR_RETURN(Environment env, Environment::Create(config.FlightVolume(), config.esdf));
  OAIPP_RETURN_IF_ERROR(env.Apply({.add = state.obstacles}));
  OAIPP_ASSIGN_OR_RETURN(FieldGrid grid, config.MakeGrid());
  if (state.mean.size() != grid.num_cells() || state.covariance.rows() != grid.num_cells() ||
      state.covariance.cols() != grid.num_cells()) {
    return absl::InvalidArgumentError(absl::StrCat("state: a map of ", state.mean.size(),
                                                   " cells does not fit the ", grid.num_cells(),
                                                   "-cell field of the spec"));
  }
  for (int cell : state.covered_cells) {
    if (!grid.IsValidCell(cell)) {
      return absl::InvalidArgumentError(
          absl::StrCat("state: covered cell ", cell, " is outside the field"));
    }
  }
  OAIPP_ASSIGN_OR_RETURN(
      GpMap map, GpMap::FromPrior(grid, std::move(state.mean), std::move(state.covariance)));
  OAIPP_ASSIGN_OR_RETURN(std::unique_ptr<Planner> planner, MakePlanner(config.planner));
  OAIPP_RETURN_IF_ERROR(planner->RestoreState(state.planner_state));
  std::shared_ptr<Mission> mission(new Mission(std::move(id), std::move(config), std::move(env),
                                               std::make_shared<GpMap>(std::move(map)),
                                               std::move(planner), caches));
  {
    absl::MutexLock lock(&mission->mu_);
    mission->covered_cells_.insert(state.covered_cells.begin(), state.covered_cells.end());
    mission->measurements_fused_ = state.measurements_fused;
    mission->mission_time_s_ = state.mission_time_s;
    mission->Publish();
  }
  {
    absl::MutexLock lock(&mission->sequence_mu_);
    mission->next_sequence_ = state.sequence + 1;
  }
  {
    absl::MutexLock lock(&mission->idempotency_mu_);
    for (auto& [request_id, answer] : state.answers) {
      mission->done_.Remember(request_id, std::move(answer));
    }
  }
  mission->paths_planned_ = state.paths_planned;
  mission->snapshot_sequence_ = state.sequence;
  mission->snapshot_measurements_ = state.measurements_fused;
  return mission;
}

absl::StatusOr<std::shared_ptr<Mission>> Mission::Replay(std::string id, MissionConfig config,
                                                         const std::vector<LogEntry>& log) {
  OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                         Create(std::move(id), std::move(config)));
  for (const LogEntry& entry : log) {
    if (const auto* change = std::get_if<ObstacleChange>(&entry)) {
      OAIPP_RETURN_IF_ERROR(mission->UpdateObstacles(*change, "").status());
    } else {
      OAIPP_RETURN_IF_ERROR(
          mission->AddMeasurement(std::get<MeasurementInput>(entry), "").status());
    }
  }
  return mission;
}

absl::Status Mission::FuseCoveredCells() {
  std::vector<int> fresh;
  for (int c : CellsUnder(map_->grid(), *env_)) {
    if (!covered_cells_.contains(c)) fresh.push_back(c);
  }
  if (fresh.empty()) return absl::OkStatus();
  OAIPP_RETURN_IF_ERROR(MutableMap().FuseNearCertainZeros(fresh));
  covered_cells_.insert(fresh.begin(), fresh.end());
  return absl::OkStatus();
}

std::int64_t Mission::MemoryBytes() const {
  std::shared_ptr<const Environment> env;
  {
    absl::MutexLock lock(&summary_mu_);
    env = summary_.env;
  }
  if (env == nullptr) return map_bytes_;
  const Esdf& esdf = env->esdf();
  std::int64_t users = esdf.SharedBy();
  if (worlds_ != nullptr && worlds_->HoldsGrid(esdf.values().data())) --users;
  return map_bytes_ +
         static_cast<std::int64_t>(esdf.MemoryBytes()) / std::max<std::int64_t>(1, users);
}

GpMap& Mission::MutableMap() {
  // Only holders of mu_ copy map_, and this one holds it for writing: a
  // count of 1 cannot grow under us. A plan that lets go meanwhile costs
  // one needless copy, no harm.
  // The shared start map and its conditionings are no longer this
  // mission's (a plan in progress keeps what it holds).
  start_map_.reset();
  if (map_.use_count() > 1) map_ = std::make_shared<GpMap>(map_->Clone());
  return *map_;
}

void Mission::Publish(bool obstacles_changed) {
  Summary next;
  if (obstacles_changed) {
    auto obstacles = std::make_shared<std::vector<Obstacle>>();
    for (const auto& [id, o] : env_->obstacles()) obstacles->push_back(o);
    next.obstacles = std::move(obstacles);
  } else {
    absl::MutexLock lock(&summary_mu_);
    next.obstacles = summary_.obstacles;  // shared, not copied
  }
  next.env = env_;
  next.trace = map_->Trace();
  next.measurements_fused = measurements_fused_;
  next.mission_time_s = mission_time_s_;
  absl::MutexLock lock(&summary_mu_);
  summary_ = std::move(next);
}

absl::StatusOr<ObstacleResult> Mission::UpdateObstacles(const ObstacleChange& change,
                                                        const RequestKey& request,
                                                        const PersistFn& persist) {
  ObstacleResult result;
  {
    absl::MutexLock order(&mutation_mu_);
    if (auto done = Recall<ObstacleResult>(request)) return *std::move(done);
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
    OAIPP_RETURN_IF_ERROR(CheckLogRoom(entry_bytes));
    OAIPP_RETURN_IF_ERROR(Persist(persist));
    absl::MutexLock lock(&mu_);
    env_ = Shared(std::move(next), esdfs_);
    // Ground newly under a building holds no targets. (Ground uncovered by a
    // removal keeps what was fused: the map cannot forget a measurement.)
    OAIPP_RETURN_IF_ERROR(FuseCoveredCells());
    log_.push_back(change);
    log_bytes_ += entry_bytes;
    result.obstacle_count = static_cast<int>(env_->obstacles().size());
    result.esdf_voxels_recomputed = env_->esdf().last_recomputed_voxels();
    Publish();
    Remember(request, result);
  }
  Emit(MissionEventData::ObstaclesChanged{result.obstacle_count});
  MaybeWantSnapshot();
  return result;
}

absl::StatusOr<std::vector<CellObservation>> Mission::PrepareMeasurement(
    const MeasurementInput& input) const {
  const FieldGrid& grid = map_->grid();
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
      OAIPP_ASSIGN_OR_RETURN(intrinsics, config_.DefaultIntrinsics());
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
  return LabelsToObservations(grid, config_.noise, p.z(), labels.cells, labels.labels);
}

absl::StatusOr<MeasurementResult> Mission::AddMeasurement(const MeasurementInput& input,
                                                          const RequestKey& request,
                                                          const PersistFn& persist) {
  MeasurementResult result;
  std::vector<CellObservation> observations;
  {
    absl::MutexLock order(&mutation_mu_);
    if (auto done = Recall<MeasurementResult>(request)) return *std::move(done);
    {
      absl::ReaderMutexLock lock(&mu_);
      OAIPP_ASSIGN_OR_RETURN(observations, PrepareMeasurement(input));
    }
    const std::int64_t entry_bytes = LogEntryBytes(input);
    OAIPP_RETURN_IF_ERROR(CheckLogRoom(entry_bytes));
    // Durable first: a failed write leaves the mission as it was.
    OAIPP_RETURN_IF_ERROR(Persist(persist));
    absl::MutexLock lock(&mu_);
    GpMap& map = MutableMap();
    OAIPP_RETURN_IF_ERROR(map.UpdateDeferred(observations));
    ++measurements_fused_;
    mission_time_s_ = std::max(mission_time_s_, input.mission_time_s);
    result =
        MeasurementResult{static_cast<int>(observations.size()), map.Trace(), measurements_fused_};
    log_.push_back(input);
    log_bytes_ += entry_bytes;
    Publish(/*obstacles_changed=*/false);
    Remember(request, result);
  }
  std::vector<int> detected;
  for (const CellObservation& o : observations) {
    if (o.value >= kDetectedLabel) detected.push_back(o.cell);
  }
  std::sort(detected.begin(), detected.end());
  detected.erase(std::unique(detected.begin(), detected.end()), detected.end());
  AddToTrack(input.pose.p_WC, detected, nullptr);
  Emit(MissionEventData::MeasurementFused{input.mission_time_s, result.cells_fused, result.trace,
                                          input.pose.p_WC, std::move(detected)});
  MaybeWantSnapshot();
  return result;
}

absl::StatusOr<PlannedPath> Mission::Plan(const UavState& state,
                                          std::optional<double> next_shot_mission_s,
                                          const RequestKey& request, const PlanCall& call) {
  absl::MutexLock planner_lock(&planner_mu_);
  if (auto done = Recall<PlannedPath>(request)) return *std::move(done);
  const double elapsed = state.mission_time_s - config_.start.mission_time_s;
  if (elapsed >= config_.budget_s) {
    return absl::FailedPreconditionError(absl::StrCat("state.mission_time_s: the flight budget of ",
                                                      config_.budget_s, " s is spent"));
  }
  double next_shot;
  if (next_shot_mission_s.has_value()) {
    next_shot = *next_shot_mission_s;
  } else {
    // The camera fires every 1 / rate seconds on the mission clock.
    const double period = 1.0 / config_.sensor_rate_hz();
    next_shot = period * std::ceil(state.mission_time_s / period - 1e-9);
  }
  const std::string state_before = planner_->SaveState();
  // The world and map as they are now; changes made while planning go to
  // copies (MutableMap) and count from the next plan.
  std::shared_ptr<const Environment> env;
  std::shared_ptr<const GpMap> map;
  std::shared_ptr<ConditionedCache> conditioned;
  {
    // Settled and taken under one lock, so no measurement leaves it pending
    // in between.
    absl::MutexLock lock(&mu_);
    map_->Settle();
    env = env_;
    map = map_;
    // MutableMap lets go of start_map_ at the map's first change.
    if (start_map_ != nullptr && start_map_->map == map_) conditioned = start_map_->conditioned;
  }
  // The planning budget counts from here: a caller that queued the plan
  // calls this once a planner is free, and neither waiting nor settling the
  // last measurement's downdate is planning.
  const absl::Time deadline = call.budget == absl::InfiniteDuration()
                                  ? call.deadline
                                  : std::min(call.deadline, absl::Now() + call.budget);
  const PlanningContext context{.environment = env.get(),
                                .map = map.get(),
                                .camera = config_.camera,
                                .noise = config_.noise,
                                .next_shot_mission_s = next_shot,
                                .remaining_budget_s = config_.budget_s - elapsed,
                                .cancelled = call.cancelled,
                                .search_fraction = call.search_fraction,
                                .conditioned = conditioned.get()};
  absl::StatusOr<PlannedPath> path = planner_->Plan(context, state, deadline);
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
  // Answered only once durable; a failed write takes the planner back to
  // where it was, so the mission stays as the store has it.
  const std::string state_after = planner_->SaveState();
  if (absl::Status written = PersistPlan(call.persist, *path, state_after); !written.ok()) {
    (void)planner_->RestoreState(state_before);
    return written;
  }
  ++paths_planned_;
  Remember(request, *path);
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
  AddToTrack(state.position_W, {}, &planned);
  Emit(MissionEventData::PathPlanned{state.mission_time_s, path->trajectory.Duration(),
                                     path->objective, path->control_waypoints_W, state.position_W});
  MaybeWantSnapshot();
  return path;
}

absl::Status Mission::Persist(const PersistFn& persist) {
  absl::MutexLock lock(&sequence_mu_);
  if (persist) OAIPP_RETURN_IF_ERROR(persist(next_sequence_));
  ++next_sequence_;
  last_change_unix_us_ = absl::ToUnixMicros(absl::Now());
  return absl::OkStatus();
}

MissionState Mission::CaptureState() const {
  // The locks every change takes (a plan holds planner_mu_, a mutation
  // mutation_mu_),
  // so that nothing changes while the state is copied.
  absl::MutexLock planner_lock(&planner_mu_);
  absl::MutexLock order(&mutation_mu_);
  SettleMap();  // nothing can leave it pending again while order is held
  absl::ReaderMutexLock lock(&mu_);
  MissionState state;
  state.sequence = next_sequence() - 1;
  for (const auto& [id, o] : env_->obstacles()) state.obstacles.push_back(o);
  state.covered_cells.assign(covered_cells_.begin(), covered_cells_.end());
  state.mean = map_->Mean();
  state.covariance = map_->Covariance();
  state.measurements_fused = measurements_fused_;
  state.mission_time_s = mission_time_s_;
  state.paths_planned = paths_planned_.load();
  state.planner_state = planner_->SaveState();
  absl::MutexLock memo_lock(&idempotency_mu_);
  done_.ForEach([&](const std::string& request_id, const RememberedAnswer& answer) {
    state.answers.emplace_back(request_id, answer);
  });
  return state;
}

void Mission::SetSnapshotPolicy(int every, std::function<void()> wanted) {
  snapshot_every_ = every;
  snapshot_wanted_ = std::move(wanted);
}

void Mission::SnapshotDone(bool stored, std::int64_t sequence, std::int64_t measurements_fused) {
  if (stored && sequence > snapshot_sequence_.load()) {
    snapshot_sequence_ = sequence;
    snapshot_measurements_ = measurements_fused;
  }
  snapshot_pending_ = false;
  // Changes made while it was written may already call for the next one
  // (after a failure, the next change asks again).
  if (stored) MaybeWantSnapshot();
}

void Mission::MaybeWantSnapshot() {
  if (snapshot_every_ <= 0 || !snapshot_wanted_ || snapshot_pending_.load()) return;
  std::int64_t measurements;
  {
    absl::MutexLock lock(&summary_mu_);
    measurements = summary_.measurements_fused;
  }
  const std::int64_t records = next_sequence() - 1 - snapshot_sequence_.load();
  if (measurements - snapshot_measurements_.load() < snapshot_every_ &&
      records < 4 * static_cast<std::int64_t>(snapshot_every_)) {
    return;
  }
  if (snapshot_pending_.exchange(true)) return;
  snapshot_wanted_();
}

absl::Time Mission::last_change_time() const {
  const std::int64_t us = last_change_unix_us_.load();
  return us == 0 ? create_time_ : absl::FromUnixMicros(us);
}

void Mission::set_last_change_time(absl::Time time) {
  last_change_unix_us_ = absl::ToUnixMicros(time);
}

bool Mission::finished() const {
  absl::MutexLock lock(&summary_mu_);
  return summary_.mission_time_s - config_.start.mission_time_s >= config_.budget_s;
}

absl::Status Mission::PersistPlan(const PersistPlanFn& persist, const PlannedPath& path,
                                  const std::string& planner_state) {
  if (!persist) return Persist(nullptr);
  return Persist([&](std::int64_t sequence) { return persist(sequence, path, planner_state); });
}

absl::Status Mission::RestorePlan(const RequestKey& request, PlannedPath path,
                                  const std::string& planner_state) {
  absl::MutexLock planner_lock(&planner_mu_);
  OAIPP_RETURN_IF_ERROR(planner_->RestoreState(planner_state));
  OAIPP_RETURN_IF_ERROR(PersistPlan(nullptr, path, planner_state));
  ++paths_planned_;
  Remember(request, std::move(path));
  return absl::OkStatus();
}

std::int64_t Mission::next_sequence() const {
  absl::MutexLock lock(&sequence_mu_);
  return next_sequence_;
}

MissionSnapshot Mission::Snapshot() const {
  MissionSnapshot s;
  s.id = id_;
  s.config = config_;
  s.create_time = create_time_;
  {
    absl::MutexLock lock(&summary_mu_);
    s.obstacles = *summary_.obstacles;
    s.trace = summary_.trace;
    s.measurements_fused = summary_.measurements_fused;
    s.mission_time_s = summary_.mission_time_s;
  }
  s.memory_bytes = MemoryBytes();
  s.paths_planned = paths_planned_.load();
  return s;
}

void Mission::ReadMap(const std::function<void(const GpMap&)>& reader) const {
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

void Mission::SettleMap() const {
  absl::MutexLock lock(&mu_);
  // Settling changes how the map is stored, not what it holds: no reader
  // holds a map with a downdate pending (they settle it first), so this is
  // the only copy.
  map_->Settle();
}

absl::Status Mission::CheckLogRoom(std::int64_t bytes) const {
  const std::int64_t held = log_bytes_.load();
  if (bytes <= log_limit_.load() - held) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrFormat(
      "name: the mission's log of applied changes holds %.1f MB, all that this server's "
      "per-mission memory limit leaves beside its map and ESDF; continue in a new mission",
      static_cast<double>(held) / 1e6));
}

std::vector<LogEntry> Mission::Log() const {
  absl::ReaderMutexLock lock(&mu_);
  return log_;
}

std::shared_ptr<EventQueue> Mission::Subscribe() {
  auto queue = std::make_shared<EventQueue>(1024);
  absl::MutexLock lock(&events_mu_);
  watchers_.push_back(queue);
  return queue;
}

void Mission::Unsubscribe(const std::shared_ptr<EventQueue>& queue) {
  absl::MutexLock lock(&events_mu_);
  std::erase(watchers_, queue);
}

void Mission::HandWatchersTo(Mission& successor) {
  std::vector<std::shared_ptr<EventQueue>> watchers;
  std::int64_t sequence;
  {
    absl::MutexLock lock(&events_mu_);
    watchers.swap(watchers_);
    sequence = sequence_;
  }
  absl::MutexLock lock(&successor.events_mu_);
  successor.sequence_ = std::max(successor.sequence_, sequence);
  for (auto& w : watchers) successor.watchers_.push_back(std::move(w));
}

void Mission::MarkDeleted() {
  Emit(MissionEventData::Deleted{});
  absl::MutexLock lock(&events_mu_);
  for (const auto& w : watchers_) w->Close();
  watchers_.clear();
}

void Mission::MarkMoved(const absl::Status& reason) {
  absl::MutexLock lock(&events_mu_);
  for (const auto& w : watchers_) w->Close(reason);
  watchers_.clear();
}

void Mission::AddToTrack(const Vec3& p_W, const std::vector<int>& detected,
                         const std::vector<Vec3>* planned_W) {
  absl::MutexLock lock(&track_mu_);
  MissionTrack& t = track_;
  if (t.flown_W.size() >= MissionTrack::kMaxFlown) {
    t.flown_W.erase(t.flown_W.begin(), t.flown_W.begin() + MissionTrack::kMaxFlown / 4);
  }
  t.flown_W.push_back(p_W);
  if (planned_W != nullptr) t.planned_W = *planned_W;
  if (!detected.empty() && t.detected_cells.size() < MissionTrack::kMaxDetected) {
    std::vector<int> merged;
    std::set_union(t.detected_cells.begin(), t.detected_cells.end(), detected.begin(),
                   detected.end(), std::back_inserter(merged));
    if (merged.size() > MissionTrack::kMaxDetected) merged.resize(MissionTrack::kMaxDetected);
    t.detected_cells = std::move(merged);
  }
}

MissionTrack Mission::Track() const {
  absl::MutexLock lock(&track_mu_);
  return track_;
}

std::int64_t Mission::last_event_sequence() const {
  absl::MutexLock lock(&events_mu_);
  return sequence_;
}

void Mission::Emit(decltype(MissionEventData::event) event) {
  absl::MutexLock lock(&events_mu_);
  MissionEventData data{++sequence_, absl::Now(), std::move(event)};
  // Streams that ended close their queue; they go here.
  std::erase_if(watchers_, [](const std::shared_ptr<EventQueue>& w) { return w->closed(); });
  for (const auto& w : watchers_) w->Push(data);
}

}  // namespace oaipp::server

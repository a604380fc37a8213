// One mission's state: its world (obstacles + ESDF), field map, planner,
// the ordered log of what was applied to it, and its event subscribers.
//
// Mutations (obstacle changes, measurements) are applied one at a time in
// arrival order; each is validated completely before it touches anything:
// on error nothing changes. A mutation that carries a request_id is applied
// at most once; a retry gets the first result back.
//
// A plan works on the world and map as they were when it started: the two
// are shared, copy-on-write, so a measurement that arrives during a long
// plan is fused at once (into a copy, if the plan still holds the map)
// instead of waiting for the plan. Reading a mission's summary
// (Snapshot(), for GetMission and ListMissions) never waits for a mutation
// or a plan.
//
// Mission coordinates mutations and plans and holds its world and map. Its
// parts are in files of their own, each with its own lock or none: its
// plans' planners, timelines and chain (mission_planning.h, the outermost
// lock), its summary (mission_summary.h), log and sequence numbers
// (mission_log.h), who left the team (team_roster.h), the fused shots'
// times (fused_shots.h), watchers and events (mission_events.h), the live
// view's track (flight_track.h), the first answers to request_ids
// (idempotency_memo.h), when to ask for a snapshot (snapshot_policy.h), its
// standing on this server (mission_lease.h), what a snapshot holds
// (mission_state.h), what its calls take and give (mission_types.h) and
// what missions over one site share (site_caches.h). Its map is in
// mission_map.cc, removing a team member in mission_team.cc, recording in
// mission_persist.cc, coming back from the store in mission_restore.cc.
//
//   OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> m, Mission::Create("m1", config));
//   OAIPP_ASSIGN_OR_RETURN(MeasurementResult r, m->AddMeasurement(input, "req-17"));
//   OAIPP_ASSIGN_OR_RETURN(PlannedPath path, m->Plan(state, std::nullopt, "req-18", {}));
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "api/map.h"
#include "api/mission_config.h"
#include "core/environment/environment.h"
#include "core/environment/world_cache.h"
#include "core/mapping/gp_map.h"
#include "server/flight_track.h"
#include "server/fused_shots.h"
#include "server/idempotency_memo.h"
#include "server/large_field_map.h"
#include "server/mission_events.h"
#include "server/mission_lease.h"
#include "server/mission_log.h"
#include "server/mission_map.h"
#include "server/mission_planning.h"
#include "server/mission_state.h"
#include "server/mission_summary.h"
#include "server/mission_types.h"
#include "server/site_caches.h"
#include "server/snapshot_policy.h"
#include "server/team_roster.h"

namespace oaipp::server {

using api::MeasurementInput;
using api::MissionConfig;

class Mission {
 public:
  // Builds the world, the prior map (ground under obstacles fused as
  // near-certain zeros) and the planner. Errors: InvalidArgument for a
  // config the core refuses, ResourceExhausted for grids too large.
  // caches: what missions over the same site share instead of computing it
  // again (SiteCaches); the default computes everything.
  [[nodiscard]] static absl::StatusOr<std::shared_ptr<Mission>> Create(
      std::string id, MissionConfig config, const SiteCaches& caches = {});
  // The mission as it was in `state` (a snapshot read back): the same
  // obstacles, map, counters, planner state and request_id answers; its log
  // goes on at state.sequence + 1. InvalidArgument when the state does not
  // fit the config (another grid, a planner state the planner refuses).
  // Of the caches only esdfs, worlds and gmrf_priors are used (the world of
  // the state's obstacles, cloned when missions over the same world built it
  // already, as on a replica taking over a site's missions; a sparse map's
  // prior; the map is the state's).
  [[nodiscard]] static absl::StatusOr<std::shared_ptr<Mission>> Restore(
      std::string id, MissionConfig config, MissionState state, const SiteCaches& caches = {});
  // A fresh mission with `log` applied in order (what persistence would do).
  [[nodiscard]] static absl::StatusOr<std::shared_ptr<Mission>> Replay(
      std::string id, MissionConfig config, const std::vector<LogEntry>& log);

  Mission(const Mission&) = delete;
  Mission& operator=(const Mission&) = delete;

  // Mutations: validated completely, then written by `persist` (when set;
  // every applied change takes the next sequence number of the log), then
  // applied. A refused change or a failed write changes nothing.
  [[nodiscard]] absl::StatusOr<ObstacleResult> UpdateObstacles(const ObstacleChange& change,
                                                               const RequestKey& request,
                                                               const PersistFn& persist = nullptr);
  // `recorded`: recovery's stored answer (PersistFn's), remembered for the
  // request instead of the one computed again.
  [[nodiscard]] absl::StatusOr<MeasurementResult> AddMeasurement(
      const MeasurementInput& input, const RequestKey& request, const PersistFn& persist = nullptr,
      const MeasurementResult* recorded = nullptr);
  // Plans from `state` (validated by the planner). next_shot: the sensor
  // phase; unset, the next multiple of 1 / rate at or after the state's
  // mission time. FailedPrecondition when the budget is spent.
  // Planning stops at call.deadline or call.budget after this call,
  // whichever comes first, and when call.cancelled (asked between CMA-ES
  // generations) says so. Plans of one mission run one at a time; callers
  // that queue plans (PlanningPool) keep one mission's plans in order.
  using PlanCall = MissionPlanCall;
  [[nodiscard]] absl::StatusOr<PlannedPath> Plan(const UavState& state,
                                                 std::optional<double> next_shot_mission_s,
                                                 const RequestKey& request, const PlanCall& call);
  // Recovery: a plan read back from storage, in log order. The planner takes
  // `planner_state`, the plan takes the next sequence number, a retry of
  // `request_id` is answered with `path`, and a team's path (its
  // PlannedPath::team) joins its UAV's timeline again.
  [[nodiscard]] absl::Status RestorePlan(const RequestKey& request, PlannedPath path,
                                         const std::string& planner_state);
  // OK when `uav_id` may ask for a plan: CheckUavId's rule for the request
  // field `uav_id`, and NotFound for a UAV removed from the team.
  [[nodiscard]] absl::Status CheckPlanningUav(const std::string& uav_id) const;
  // Takes `uav_id` out of the team (proto RemoveTeamMember), written by
  // `persist` first as a mutation is: it may not plan again (NotFound),
  // later plans of its teammates no longer count its shots, and its
  // measurements, late ones included, are still fused. A UAV that `landed`
  // is forgotten; one still in the air stays an obstacle for its teammates
  // (its timeline, then wherever it may have drifted since). A landed
  // removal of a UAV removed before in the air completes it.
  // FailedPrecondition without a team, for a UAV removed already (landed,
  // or in the air and not landed now) and for the last one flying; else as
  // CheckUavId.
  [[nodiscard]] absl::StatusOr<TeamResult> RemoveMember(const std::string& uav_id, bool landed,
                                                        const RequestKey& request,
                                                        const PersistFn& persist = nullptr);
  // The sequence number the next change of the log takes (1 when new).
  [[nodiscard]] std::int64_t next_sequence() const { return log_.next_sequence(); }

  // The state after the last record of the log (for a snapshot). Waits for
  // a plan in progress, so that planner state and map agree.
  [[nodiscard]] MissionState CaptureState() const;
  // Asks for a snapshot through `wanted` once `every` measurements (or 4 x
  // `every` records of any kind) were applied since the last stored one.
  // Set once, before the mission is shared.
  void SetSnapshotPolicy(int every, std::function<void()> wanted);
  // Asks for a snapshot if the policy says one is due (called after every
  // change, and by recovery for a mission read back with a long tail).
  void MaybeWantSnapshot();
  // The snapshot taken by CaptureState at `sequence` is durable (stored) or
  // failed (the mission asks again after its next change).
  void SnapshotDone(bool stored, std::int64_t sequence, std::int64_t measurements_fused);
  // When the mission last changed (creation, a mutation or a plan).
  [[nodiscard]] absl::Time last_change_time() const;
  void set_last_change_time(absl::Time time);
  // Recovery: the time the mission was first created (before it is shared).
  void set_create_time(absl::Time time) { create_time_ = time; }
  // Flight budget spent: a measurement or plan at or past start + budget_s.
  [[nodiscard]] bool finished() const;

  // The summary as of the last finished change (waits for no change or plan).
  [[nodiscard]] MissionSnapshot Snapshot() const;
  // Memory held by the map and this mission's share of its ESDF (an ESDF
  // shared by k missions over the same obstacles counts 1/k in each). Waits
  // for no mutation and no plan (the server reports it after every call).
  [[nodiscard]] std::int64_t MemoryBytes() const;
  // Bytes held by the log of applied changes (Log(); it grows with every
  // measurement and obstacle change) and by the remembered answers to
  // request_ids (bounded: the oldest go first); read without a lock.
  [[nodiscard]] std::int64_t LogBytes() const { return log_.bytes() + answers_.bytes(); }
  // Set by the registry before the mission is published: the memory it was
  // admitted with (EstimateMissionBytes, worked out once), and the log's
  // limit: changes that would take LogBytes() past it are refused with
  // RESOURCE_EXHAUSTED before anything is applied or stored (none unset).
  void set_memory_budget(std::int64_t estimate, std::int64_t log_limit) {
    estimate_ = estimate;
    log_.set_limit(log_limit);
  }
  [[nodiscard]] std::int64_t memory_estimate() const { return estimate_; }
  // Reads a dense map under the reader lock (settled first, see
  // SettleMap); on a sparse map (config().map_backend) it calls nothing.
  void ReadMap(const std::function<void(const GpMap&)>& reader) const;
  // Reads the whole map as it is now, dense or sparse: a sparse map's mean
  // and variances are computed when not current (seconds on a large field;
  // its changes do not wait for it). Internal: the factorisation failed.
  [[nodiscard]] absl::Status ReadMapView(
      const std::function<void(const api::MapView&)>& reader) const;
  // Applies early, off the caller's path (the server calls it right after
  // answering), the covariance's rank-m downdate that AddMeasurement leaves
  // pending (GpMap::UpdateDeferred; most of a small shot's work): what reads
  // the covariance (a plan, ReadMap, a snapshot, the next update) settles
  // it first, so no reader sees the difference. On a sparse map it computes
  // the variance map as of now, for the trace reported (nothing when current).
  void SettleMap() const;
  [[nodiscard]] std::vector<LogEntry> Log() const { return log_.Entries(); }
  [[nodiscard]] const std::string& id() const { return id_; }
  [[nodiscard]] const MissionConfig& config() const { return config_; }
  [[nodiscard]] const FieldGrid& grid() const { return grid_; }

  // The live view's track (a copy).
  [[nodiscard]] MissionTrack Track() const { return track_.Copy(); }
  // Its watchers and their events (a copy read back from the store takes
  // them over: events().HandTo(successor.events())).
  [[nodiscard]] MissionEvents& events() { return events_; }
  [[nodiscard]] const MissionEvents& events() const { return events_; }

  // Its standing on this server: ownership epoch, lease, take-off pacing.
  [[nodiscard]] MissionLease& lease() { return lease_; }
  [[nodiscard]] const MissionLease& lease() const { return lease_; }

 private:
  // Exactly one of `map` (dense) and `large` (sparse) is set.
  Mission(std::string id, MissionConfig config, FieldGrid grid, Environment env,
          std::shared_ptr<GpMap> map, std::unique_ptr<LargeFieldMap> large,
          std::unique_ptr<Planner> planner, const SiteCaches& caches);
  // For a plan: the dense map, or a sparse map's window around
  // `centre_W`, as of now (the latter built without holding mu_).
  struct PlanMap {
    MissionMap::ForPlan shared;
    FusedShots fused_shots;       // fused_shots_ as the map holds it (same lock)
    double mission_time_s = 0.0;  // the newest the mission has seen (mission_time_s_)
  };
  absl::StatusOr<PlanMap> MapForPlan(const Vec2& centre_W, std::shared_ptr<const Environment>* env);
  // config.MakeEnvironment(), or a clone of the world cache's copy under
  // `world_key` (WorldKey(config)) when the caches have a world cache.
  static absl::StatusOr<Environment> BuildWorld(const MissionConfig& config,
                                                const std::string& world_key,
                                                const SiteCaches& caches);
  // Fuses, once, the cells under obstacles that were not fused before.
  absl::Status FuseCoveredCells() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Publishes the summary Snapshot() reads (after every change); the
  // obstacle list is rebuilt only when obstacles changed.
  void Publish(bool obstacles_changed = true) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Everything a measurement needs checked and computed before it is
  // written and fused: the observations of its cells.
  absl::StatusOr<std::vector<CellObservation>> PrepareMeasurement(
      const MeasurementInput& input) const ABSL_SHARED_LOCKS_REQUIRED(mu_);
  // Runs `persist` with the next sequence number and takes it on success.
  absl::Status Persist(const PersistFn& persist, const MeasurementResult* answer = nullptr);
  absl::Status PersistPlan(const PersistPlanFn& persist, const PlannedPath& path,
                           const std::string& planner_state);

  const std::string id_;
  const MissionConfig config_;
  const FieldGrid grid_;
  absl::Time create_time_;  // set by the constructor, or by recovery before the mission is shared
  // Where equal ESDFs are shared (nullptr: not shared), and the worlds a
  // new mission clones (their hold on a grid is not a mission's share).
  EsdfPool* const esdfs_;
  WorldCache* const worlds_;

  // Locks, outermost first: planning_'s (held for a whole plan),
  // mutation_mu_ (orders mutations, held for a whole one), mu_ (guards the
  // state; held for writing only while a change is put in place), then the
  // leaf locks: those of summary_, log_, roster_, answers_, events_, track_.
  mutable absl::Mutex mutation_mu_;
  mutable absl::Mutex mu_;
  // Shared with plans in progress: replaced, never changed in place.
  std::shared_ptr<const Environment> env_ ABSL_GUARDED_BY(mu_);
  // Dense or sparse, under mu_ (mission_map.h says which parts run off it).
  MissionMap map_;
  std::int64_t measurements_fused_ ABSL_GUARDED_BY(mu_) = 0;
  double mission_time_s_ ABSL_GUARDED_BY(mu_) = 0.0;
  // When each UAV's fused measurements were taken (by uav_id; "" without a
  // team): which of a teammate's planned shots are in the map (TeammatesOf),
  // and when it last reported.
  FusedShots fused_shots_ ABSL_GUARDED_BY(mu_);
  // request_id -> first result. Read and written with the lock of the
  // operation held, so that check and apply are one step.
  IdempotencyMemo answers_;

  // Planners, timelines and the chain, under their own lock (one plan at a
  // time); mutable: CaptureState holds it.
  mutable MissionPlanning planning_;
  // What Snapshot() reports, published at the end of every change; mutable:
  // SettleMap sets a sparse trace.
  mutable PublishedSummary summary_;
  // Members taken out of the team (RemoveMember), with its own leaf lock.
  TeamRoster roster_;
  // Not under planning_'s lock: that is held for a whole plan, and
  // Snapshot must not wait for one.
  std::atomic<std::int64_t> paths_planned_{0};

  // The log: sequence numbers (its leaf lock is held while a record is
  // written, so mutations under mu_ and plans under planning_'s lock share
  // one order) and the applied changes.
  MissionLog log_;
  std::int64_t estimate_ = 0;  // set once, before the mission is published

  // When to ask for the next snapshot.
  SnapshotPolicy snapshots_;
  std::atomic<std::int64_t> last_change_unix_us_{0};
  MissionLease lease_;

  MissionEvents events_;
  // The live view reads it without waiting for a change in progress.
  FlightTrack track_;
};

}  // namespace oaipp::server

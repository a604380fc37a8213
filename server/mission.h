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
// Mission holds mutation and plan coordination, its world and its map; the
// parts it holds are in files of their own, each with its own leaf lock or
// none: the log and its sequence numbers (mission_log.h), who left the team
// (team_roster.h), the team's timelines (team_timelines.h), the fused shots'
// times (fused_shots.h), the watchers and their events (mission_events.h),
// the live view's track (flight_track.h), the first answers to request_ids
// (idempotency_memo.h), when to ask for a snapshot (snapshot_policy.h), its
// standing on this server (mission_lease.h), what a snapshot holds
// (mission_state.h), what its calls take and give (mission_types.h) and what
// missions over one site share (site_caches.h). mission_restore.cc brings a
// mission back from the store.
//
//   OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> m, Mission::Create("m1", config));
//   OAIPP_ASSIGN_OR_RETURN(MeasurementResult r, m->AddMeasurement(input, "req-17"));
//   OAIPP_ASSIGN_OR_RETURN(PlannedPath path, m->Plan(state, std::nullopt, "req-18", {}));
#pragma once

#include <atomic>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <variant>
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
#include "core/planning/conditioning_chain.h"
#include "core/planning/planners.h"
#include "server/flight_track.h"
#include "server/fused_shots.h"
#include "server/idempotency_memo.h"
#include "server/large_field_map.h"
#include "server/mission_events.h"
#include "server/mission_lease.h"
#include "server/mission_log.h"
#include "server/mission_map.h"
#include "server/mission_state.h"
#include "server/mission_types.h"
#include "server/site_caches.h"
#include "server/snapshot_policy.h"
#include "server/team_roster.h"
#include "server/team_timelines.h"

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
  // The sequence number the next change of the log will take (1 for a new
  // mission).
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
  // True once the flight budget is spent (a measurement or plan at or past
  // start + budget_s).
  [[nodiscard]] bool finished() const;

  // The summary as of the last finished change: waits for no mutation and
  // no plan.
  [[nodiscard]] MissionSnapshot Snapshot() const;
  // Memory held by the map and this mission's share of its ESDF (an ESDF
  // shared by k missions over the same obstacles counts 1/k in each). Waits
  // for no mutation and no plan (the server reports it after every call).
  [[nodiscard]] std::int64_t MemoryBytes() const;
  // Bytes held by the log of applied changes (Log()), which grows with
  // every measurement and obstacle change, and by the remembered answers to
  // request_ids (bounded: the oldest go first); read without the mission's
  // lock.
  [[nodiscard]] std::int64_t LogBytes() const { return log_.bytes() + answers_.bytes(); }
  // Changes that would take LogBytes() past `bytes` are refused with
  // RESOURCE_EXHAUSTED before anything is applied or stored. The registry
  // sets it from the mission's memory budget; no limit until then.
  void set_log_limit(std::int64_t bytes) { log_.set_limit(bytes); }
  // Reads a dense map under the reader lock (settled first, see
  // SettleMap); on a sparse map (config().map_backend) it calls nothing.
  void ReadMap(const std::function<void(const GpMap&)>& reader) const;
  // Reads the whole map as it is now, dense or sparse: for a sparse map
  // its mean and variances, computed when they are not current (seconds on
  // a large field; the mission's changes do not wait for it). Errors:
  // Internal when the sparse map's factorisation fails.
  [[nodiscard]] absl::Status ReadMapView(
      const std::function<void(const api::MapView&)>& reader) const;
  // AddMeasurement answers once the measurement is durable and fused into
  // the map's mean and trace; the covariance's rank-m downdate, most of a
  // small shot's work, is left pending (GpMap::UpdateDeferred). Everything
  // that reads the covariance (a plan, ReadMap, a snapshot, the next update)
  // settles it first, so no reader sees the difference; this applies it
  // early, off the caller's path (the server calls it right after
  // answering). On a sparse map it computes the variance map of the
  // mission as it is now, for the trace the mission reports (nothing when
  // that is current).
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
    // fused_shots_ as the map holds it (taken under the same lock).
    FusedShots fused_shots;
    // The newest mission time the mission has seen (mission_time_s_).
    double mission_time_s = 0.0;
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
  // The planner that plans for `uav_id`: the mission's for one UAV, a
  // member's own (its limits) for a team.
  absl::StatusOr<Planner*> PlannerOf(const std::string& uav_id)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(planner_mu_);
  // `status` (a plan's error for team member `uav_id`) naming the member's
  // own limits, from the fields it carries as data (api::WithApiFieldNames).
  [[nodiscard]] absl::Status NamedForMember(const absl::Status& status,
                                            const std::string& uav_id) const;
  // A team's other UAVs in the air as the plan for `uav_id` at mission time
  // `now_s` must keep clear of them (docs/teams.md "The guarantee"): each
  // one's timeline (or, before its first plan, its start, held) and the
  // distance the pair keeps (PairDistance); one removed in the air, or
  // silent for more than silent_after_s before `newest_s`, may drift at
  // its max speed from when it should be hovering. With them, the shots
  // still to come of those flying: at or after now_s, on the plan in force
  // when taken, and not yet in the plan's map (`fused`, FusedShots's rule).
  // Also their plan versions (0: none yet), in uav_id order.
  std::vector<Teammate> TeammatesOf(
      const std::string& uav_id, double now_s, double newest_s, const FusedShots& fused,
      std::vector<std::pair<std::string, std::int64_t>>* versions) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(planner_mu_);

  const std::string id_;
  const MissionConfig config_;
  const FieldGrid grid_;
  absl::Time create_time_;  // set by the constructor, or by recovery before the mission is shared
  // Where equal ESDFs are shared (nullptr: not shared), and the worlds a
  // new mission clones (their hold on a grid is not a mission's share).
  EsdfPool* const esdfs_;
  WorldCache* const worlds_;

  // Locks, outermost first: planner_mu_, mutation_mu_, mu_, then the leaf
  // locks (summary_mu_, and those of log_, roster_, answers_, events_ and
  // track_).
  // mutation_mu_ orders mutations and is held for a whole one; mu_ guards
  // the state and is held for writing only while a change is put in place.
  mutable absl::Mutex mutation_mu_;
  mutable absl::Mutex mu_;
  // Shared with plans in progress; replaced, never changed in place, while
  // a plan holds them.
  std::shared_ptr<const Environment> env_ ABSL_GUARDED_BY(mu_);
  // The map, dense or sparse, under mu_ (mission_map.h says which parts
  // run off it).
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

  // The planner keeps state (lawnmower pattern): one plan at a time.
  mutable absl::Mutex planner_mu_;
  // A team's plans condition the map (or a large field's window) on each
  // other's pending shots from the last plan's conditioning when it was
  // made from the same covariance (PlanMap::key; docs/method.md §7.8).
  ConditioningChain team_chain_;
  // What Snapshot() reports, published at the end of every change.
  struct Summary {
    std::shared_ptr<const std::vector<Obstacle>> obstacles;
    // The world as of this summary, for its ESDF's share of the memory.
    std::shared_ptr<const Environment> env;
    double trace = 0.0;
    std::int64_t trace_measurements_fused = 0;
    std::int64_t trace_version = 0;  // a sparse map's version of `trace`
    std::int64_t measurements_fused = 0;
    double mission_time_s = 0.0;
  };
  mutable absl::Mutex summary_mu_;
  mutable Summary summary_ ABSL_GUARDED_BY(summary_mu_);  // SettleMap sets a sparse trace
  std::unique_ptr<Planner> planner_ ABSL_GUARDED_BY(planner_mu_);
  // Members taken out of the team (RemoveMember), with its own leaf lock.
  TeamRoster roster_;
  // A team's planners, each with its member's limits (PlannerOf).
  std::map<std::string, std::unique_ptr<Planner>> member_planners_ ABSL_GUARDED_BY(planner_mu_);
  // A team's committed plans, a timeline per UAV.
  TeamTimelines timelines_ ABSL_GUARDED_BY(planner_mu_);
  // Not under planner_mu_: that is held for a whole plan, and Snapshot
  // must not wait for one.
  std::atomic<std::int64_t> paths_planned_{0};

  // The log: sequence numbers (its leaf lock is held while a record is
  // written, so mutations under mu_ and plans under planner_mu_ share one
  // order) and the applied changes.
  MissionLog log_;

  // When to ask for the next snapshot.
  SnapshotPolicy snapshots_;
  std::atomic<std::int64_t> last_change_unix_us_{0};
  MissionLease lease_;

  MissionEvents events_;
  // The live view reads the track without waiting for a change in
  // progress.
  FlightTrack track_;
};

}  // namespace oaipp::server

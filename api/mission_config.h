// A mission described in core terms: what CreateMission's spec becomes once
// every default is filled in and every field is validated (api/spec.h does
// that). The member initialisers below are the API's defaults, the paper's
// values; the spec conversion, the server and the simulation all read them
// from here. Nothing here knows about protobuf.
//
//   OAIPP_ASSIGN_OR_RETURN(MissionConfig config, MissionSpecToConfig(request.spec()));
//   OAIPP_ASSIGN_OR_RETURN(Environment env, config.MakeEnvironment());
//   Aabb volume = config.FlightVolume();
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "api/search_area.h"
#include "core/environment/environment.h"
#include "core/mapping/camera.h"
#include "core/mapping/detection_projection.h"
#include "core/mapping/field_grid.h"
#include "core/mapping/gp_params.h"
#include "core/planning/planners.h"

namespace oaipp::api {

// A point on the WGS84 ellipsoid (api/geodetic.h converts it).
struct GeoPoint {
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
  double altitude_m = 0.0;  // above mean sea level
  friend bool operator==(const GeoPoint&, const GeoPoint&) = default;
};

// How a mission holds its map (proto MapBackend).
enum class MapBackend {
  kAuto,    // the server chooses by the field's size (ResolveMapBackend)
  kDense,   // GpMap: the covariance, 8 n^2 bytes
  kSparse,  // SparseGpMap: a sparse precision, a few KB a cell
};

// What the values of a prior map are (proto PriorMapUnits). Both set the
// prior mean of a cell's label to the value itself (docs/method.md §3.3);
// the units decide only what is checked and how the spec says it.
enum class PriorMapUnits {
  kLabelMean,    // finite, in [0, kMaxPriorMapValue]
  kProbability,  // each in [0, 1], their sum at most 1 (one person)
};

// What one UAV flies with: its camera (footprint and shot rate), the noise
// its detector's labels are fused with, and its flight limits.
struct UavKit {
  DownwardCamera camera;
  SensorNoise noise;
  PlannerLimits limits;
};

// One UAV of a mission's team (proto TeamMember).
struct TeamMember {
  std::string uav_id;  // [a-z0-9-]{1,32}
  UavState start;
  // The mission's camera, noise and limits but for what spec.team[i].sensor
  // and spec.team[i].flight set.
  UavKit kit;
};

struct MissionConfig {
  // Fields of up to this many cells get a dense map unless they ask
  // otherwise (the server's --max_dense_cells, by default).
  static constexpr std::int64_t kDefaultMaxDenseCells = 4096;

  // Altitude of the default start (over the field's centre, at rest), m.
  static constexpr double kDefaultStartAltitude_m = 10.0;
  // Image size assumed for detections sent without intrinsics, pixels.
  static constexpr int kDefaultImageWidthPx = 480;
  static constexpr int kDefaultImageHeightPx = 640;

  std::string preset;  // "" or "paper"
  // Field rectangle on the ground and its cells.
  Vec2 field_min_W = Vec2(-15, -15);
  Vec2 field_max_W = Vec2(15, 15);
  double resolution_m = 0.75;
  MapBackend map_backend = MapBackend::kAuto;
  GpParams gp = GpParams::PaperPreset(0.75);
  // The prior mean of each cell's label in the grid's order (row-major,
  // row along y): GpSpec.prior_map. Null: gp.prior_mean everywhere; set:
  // gp.prior_mean is the map's average. Shared and never changed, so that a
  // copy of a config stays cheap.
  std::shared_ptr<const Eigen::VectorXd> prior_map;
  PriorMapUnits prior_map_units = PriorMapUnits::kLabelMean;
  // The search area (MissionSpec.search_areas, api/search_area.h); null:
  // the whole field. Shared and never changed, as prior_map.
  std::shared_ptr<const SearchArea> search_area;
  // The closed airspace: MissionSpec.fence and .no_fly_zones (empty: none).
  Airspace airspace;
  // Its mask as core's planners take it (PlanningContext::search_area):
  // empty without an area.
  [[nodiscard]] std::span<const std::uint8_t> SearchMask() const {
    return search_area != nullptr ? std::span<const std::uint8_t>(search_area->mask)
                                  : std::span<const std::uint8_t>{};
  }
  DownwardCamera camera;
  SensorNoise noise;
  // Flight altitudes over the field.
  double min_altitude_m = 2.0;
  double max_altitude_m = 26.0;
  EsdfConfig esdf;
  // The planner: its kind, the settings every kind shares (flight limits,
  // objective, seed) and the kind's own settings.
  PlannerConfig planner;
  std::vector<Obstacle> obstacles;
  // Where the UAV starts; with a team, the first member's start (the
  // mission clock and budget count from its mission_time_s, which every
  // member shares).
  UavState start;
  // Several UAVs over the one map (proto MissionSpec.team); empty: one UAV,
  // uav_id "", at `start`.
  std::vector<TeamMember> team;
  // Centre to centre, m, between any two members at every instant (a pair
  // whose bodies need more keeps PairDistance).
  double min_separation_m = 4.0;
  // Mission seconds without a report after which a member counts as silent
  // (MissionSpec field of the same name).
  double silent_after_s = 20.0;
  // A plan counts teammates' pending shots as taken (MissionSpec field of
  // the same name).
  bool count_teammate_shots = true;
  double budget_s = 150.0;
  // Where W is on Earth (W is East-North-Up there); unset: local metres only.
  std::optional<GeoPoint> geo_origin;

  [[nodiscard]] Aabb FlightVolume() const {
    return {{field_min_W.x(), field_min_W.y(), min_altitude_m},
            {field_max_W.x(), field_max_W.y(), max_altitude_m}};
  }
  [[nodiscard]] double sensor_rate_hz() const { return camera.rate_hz; }
  // The member named `uav_id`, or nullptr.
  [[nodiscard]] const TeamMember* FindMember(absl::string_view uav_id) const {
    for (const TeamMember& m : team) {
      if (m.uav_id == uav_id) return &m;
    }
    return nullptr;
  }
  // What `uav_id` flies with: a member's own kit, or the mission's (camera,
  // noise, planner.common.limits) for "" and for a name not in the team.
  [[nodiscard]] UavKit KitOf(absl::string_view uav_id) const;
  // How far apart the centres of members a and b stay: min_separation_m,
  // or their radii and tracking errors added up when that is more
  // (docs/teams.md "The guarantee").
  [[nodiscard]] double PairDistance(absl::string_view a, absl::string_view b) const;
  // The planner's settings for `uav_id`: the mission's, with its limits.
  [[nodiscard]] PlannerConfig PlannerFor(absl::string_view uav_id) const;
  // OK when `uav_id` (a request's `field`) names one of the mission's UAVs:
  // a member of the team, or "" without one. Else NotFound naming the field
  // (InvalidArgument for "" with a team: the call must say which UAV).
  [[nodiscard]] absl::Status CheckUavId(absl::string_view uav_id, absl::string_view field) const;
  // The prior mean of each of the field's `num_cells` cells: prior_map, or
  // gp.prior_mean everywhere.
  [[nodiscard]] Eigen::VectorXd PriorMean(int num_cells) const;
  // The field's cells. Errors as FieldGrid::FromBounds.
  [[nodiscard]] absl::StatusOr<FieldGrid> MakeGrid() const;
  // The field's number of cells, from the corners and resolution (as the
  // grid would count them; for limits checked before a grid is made).
  [[nodiscard]] double CellCount() const;
  // map_backend, or for kAuto: dense up to max_dense_cells, sparse above.
  [[nodiscard]] MapBackend ResolveMapBackend(
      std::int64_t max_dense_cells = kDefaultMaxDenseCells) const;
  // The flight volume with the mission's obstacles and its ESDF, and its
  // airspace. Errors as Environment::Create and Environment::Apply.
  [[nodiscard]] absl::StatusOr<Environment> MakeEnvironment() const;
  // Pinhole intrinsics of the default image (kDefaultImageWidthPx x
  // kDefaultImageHeightPx) for the field of view of `uav_id`'s camera
  // (KitOf; "": the mission's).
  [[nodiscard]] absl::StatusOr<CameraIntrinsics> DefaultIntrinsics(
      absl::string_view uav_id = "") const;
};

// One camera measurement from AddMeasurement, in core terms.
struct MeasurementInput {
  double mission_time_s = 0.0;
  CameraPose pose;  // camera position and yaw (radians)
  // Exactly one of the two is set.
  std::optional<CellLabels> labels = std::nullopt;
  struct Detections {
    std::optional<CameraIntrinsics> intrinsics =
        std::nullopt;  // unset: the mission's DefaultIntrinsics()
    std::vector<PixelBox> boxes = {};
    double min_confidence = 0.0;
  };
  std::optional<Detections> detections = std::nullopt;
  // The UAV that took it (MissionConfig::CheckUavId): "" without a team.
  std::string uav_id = {};
};

}  // namespace oaipp::api

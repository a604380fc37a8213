#include "api/spec.h"
#include "api/limits.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "api/geodetic.h"
#include "api/geometry.h"
#include "api/internal/airspace_spec.h"
#include "api/internal/checks.h"
#include "api/internal/home_spec.h"
#include "api/internal/search_area_spec.h"
#include "api/status.h"
#include "core/common/status_macros.h"

namespace oaipp::api {
namespace {

using internal::CheckAtLeast;
using internal::CheckIntRange;
using internal::CheckNonNegative;
using internal::CheckOpenInterval;
using internal::CheckUnitInterval;
using internal::Describe;
using internal::OrDefault;
using internal::Prefixed;

// The API's defaults: MissionConfig's initialisers.
const MissionConfig kDefaults;

absl::StatusOr<Vec2> FieldCorner(const v1::FieldSpec& f, bool max_corner) {
  const Vec2 fallback = max_corner ? kDefaults.field_max_W : kDefaults.field_min_W;
  const double x = max_corner ? OrDefault(f.has_x_max_m(), f.x_max_m(), fallback.x())
                              : OrDefault(f.has_x_min_m(), f.x_min_m(), fallback.x());
  const double y = max_corner ? OrDefault(f.has_y_max_m(), f.y_max_m(), fallback.y())
                              : OrDefault(f.has_y_min_m(), f.y_min_m(), fallback.y());
  const char* suffix = max_corner ? "max_m" : "min_m";
  OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat("spec.field.x_", suffix), x));
  OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat("spec.field.y_", suffix), y));
  return Vec2(x, y);
}

absl::Status FillField(const v1::FieldSpec& f, MissionConfig& c) {
  OAIPP_ASSIGN_OR_RETURN(c.field_min_W, FieldCorner(f, /*max_corner=*/false));
  OAIPP_ASSIGN_OR_RETURN(c.field_max_W, FieldCorner(f, /*max_corner=*/true));
  c.resolution_m = OrDefault(f.has_resolution_m(), f.resolution_m(), kDefaults.resolution_m);
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.field.resolution_m", c.resolution_m));
  switch (f.map_backend()) {
    case v1::MAP_BACKEND_UNSPECIFIED:
      c.map_backend = MapBackend::kAuto;
      break;
    case v1::MAP_BACKEND_DENSE:
      c.map_backend = MapBackend::kDense;
      break;
    case v1::MAP_BACKEND_SPARSE:
      c.map_backend = MapBackend::kSparse;
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("spec.field.map_backend: unknown value ", static_cast<int>(f.map_backend()),
                       " (expected MAP_BACKEND_DENSE or MAP_BACKEND_SPARSE)"));
  }
  for (int a = 0; a < 2; ++a) {
    if (!(c.field_max_W[a] > c.field_min_W[a])) {
      const char* axis = a == 0 ? "x" : "y";
      return absl::InvalidArgumentError(
          absl::StrCat("spec.field.", axis, "_max_m: must exceed spec.field.", axis, "_min_m (",
                       c.field_min_W[a], "), got ", c.field_max_W[a]));
    }
  }
  // The resolution and corners are checked above; what FieldGrid can still
  // refuse is an extent that is not a whole number of cells (InvalidArgument,
  // named "resolution_m" as in FieldSpec) or too many cells
  // (ResourceExhausted, a property of the whole field).
  if (auto grid = c.MakeGrid(); !grid.ok()) {
    return Prefixed(
        grid.status().code() == absl::StatusCode::kInvalidArgument ? "spec.field." : "spec.field: ",
        grid.status());
  }
  return absl::OkStatus();
}

// spec.gp.prior_map into c.prior_map (the field already filled in).
absl::Status FillPriorMap(const v1::PriorMap& m, MissionConfig& c) {
  switch (m.units()) {
    case v1::PRIOR_MAP_UNITS_UNSPECIFIED:
    case v1::PRIOR_MAP_UNITS_LABEL_MEAN:
      c.prior_map_units = PriorMapUnits::kLabelMean;
      break;
    case v1::PRIOR_MAP_UNITS_PROBABILITY:
      c.prior_map_units = PriorMapUnits::kProbability;
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("spec.gp.prior_map.units: unknown value ", static_cast<int>(m.units()),
                       " (expected PRIOR_MAP_UNITS_LABEL_MEAN or PRIOR_MAP_UNITS_PROBABILITY)"));
  }
  OAIPP_ASSIGN_OR_RETURN(const FieldGrid grid, c.MakeGrid());
  if (m.values_size() != grid.num_cells()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "spec.gp.prior_map.values: ", m.values_size(), " values for a field of ", grid.nx(), " x ",
        grid.ny(), " cells (expected ", grid.num_cells(), ", row-major along y)"));
  }
  const bool probability = c.prior_map_units == PriorMapUnits::kProbability;
  const double bound = probability ? 1.0 : kMaxPriorMapValue;
  auto values = std::make_shared<Eigen::VectorXd>(grid.num_cells());
  double sum = 0.0;
  for (int i = 0; i < m.values_size(); ++i) {
    const double v = m.values(i);
    if (!(v >= 0.0 && v <= bound)) {
      return absl::InvalidArgumentError(
          absl::StrCat("spec.gp.prior_map.values[", i, "]: ",
                       probability ? "a probability must be in [0, 1]"
                                   : absl::StrCat("must be in [0, ", bound, "] (label units)"),
                       ", got ", v));
    }
    (*values)[i] = v;
    sum += v;
  }
  // One person: the cells' probabilities add up to at most 1 (the rest is
  // the probability that the person is outside the field).
  if (probability && sum > 1.0 + 1e-6) {
    return absl::InvalidArgumentError(absl::StrCat(
        "spec.gp.prior_map.values: probabilities sum to ", sum, " (at most 1: one person)"));
  }
  c.gp.prior_mean = sum / grid.num_cells();
  c.prior_map = std::move(values);
  return absl::OkStatus();
}

absl::Status FillGp(const v1::GpSpec& g, MissionConfig& c) {
  const GpParams paper = GpParams::PaperPreset(c.resolution_m);
  c.gp.length_scale_m = OrDefault(g.has_length_scale_m(), g.length_scale_m(), paper.length_scale_m);
  c.gp.signal_var = OrDefault(g.has_signal_var(), g.signal_var(), paper.signal_var);
  c.gp.noise_var = OrDefault(g.has_noise_var(), g.noise_var(), paper.noise_var);
  c.gp.prior_mean = OrDefault(g.has_prior_mean(), g.prior_mean(), paper.prior_mean);
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.gp.length_scale_m", c.gp.length_scale_m));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.gp.signal_var", c.gp.signal_var));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.gp.noise_var", c.gp.noise_var));
  OAIPP_RETURN_IF_ERROR(CheckFinite("spec.gp.prior_mean", c.gp.prior_mean));
  if (g.has_prior_map()) {
    if (g.has_prior_mean()) {
      return absl::InvalidArgumentError(
          "spec.gp.prior_mean: not with spec.gp.prior_map (the map sets every cell's prior mean)");
    }
    OAIPP_RETURN_IF_ERROR(FillPriorMap(g.prior_map(), c));
  }
  return Prefixed("spec.gp.", c.gp.Validate());
}

// A camera and its detector's noise from `s`, each unset field taken from
// `base` (the defaults for spec.sensor, the mission's for a team member's);
// `field` names `s` in errors ("spec.sensor", "spec.team[1].sensor").
// Setting detector_noise switches to the detector's curve (its unset fields
// the base detector's, or the defaults); setting noise_a_var or
// noise_b_per_m switches to A (1 - exp(-B h)).
absl::Status FillSensorOf(const v1::SensorSpec& s, const UavKit& base, absl::string_view field,
                          DownwardCamera& camera, SensorNoise& noise) {
  const std::string prefix = absl::StrCat(field, ".");
  camera = base.camera;
  noise = base.noise;
  camera.fov_x_deg = OrDefault(s.has_fov_x_deg(), s.fov_x_deg(), base.camera.fov_x_deg);
  camera.fov_y_deg = OrDefault(s.has_fov_y_deg(), s.fov_y_deg(), base.camera.fov_y_deg);
  noise.a_var = OrDefault(s.has_noise_a_var(), s.noise_a_var(), base.noise.a_var);
  noise.b_per_m = OrDefault(s.has_noise_b_per_m(), s.noise_b_per_m(), base.noise.b_per_m);
  camera.rate_hz = OrDefault(s.has_rate_hz(), s.rate_hz(), base.camera.rate_hz);
  OAIPP_RETURN_IF_ERROR(CheckOpenInterval(prefix + "fov_x_deg", camera.fov_x_deg, 0, 180));
  OAIPP_RETURN_IF_ERROR(CheckOpenInterval(prefix + "fov_y_deg", camera.fov_y_deg, 0, 180));
  OAIPP_RETURN_IF_ERROR(CheckPositive(prefix + "noise_a_var", noise.a_var));
  OAIPP_RETURN_IF_ERROR(CheckPositive(prefix + "noise_b_per_m", noise.b_per_m));
  OAIPP_RETURN_IF_ERROR(CheckPositive(prefix + "rate_hz", camera.rate_hz));
  if (s.has_detector_noise()) {
    if (s.has_noise_a_var() || s.has_noise_b_per_m()) {
      return absl::InvalidArgumentError(absl::StrCat(
          prefix, "detector_noise: replaces noise_a_var and noise_b_per_m, set one or the other"));
    }
    const v1::DetectorNoise& d = s.detector_noise();
    const DetectorAccuracy from = base.noise.detector.value_or(DetectorAccuracy{});
    noise.detector =
        DetectorAccuracy{.p_max = OrDefault(d.has_p_max(), d.p_max(), from.p_max),
                         .h_best_m = OrDefault(d.has_h_best_m(), d.h_best_m(), from.h_best_m),
                         .width_m = OrDefault(d.has_width_m(), d.width_m(), from.width_m),
                         .false_positive_rate = d.has_false_positive_rate()
                                                    ? std::optional<double>(d.false_positive_rate())
                                                    : from.false_positive_rate};
    OAIPP_RETURN_IF_ERROR(Prefixed(prefix + "detector_noise.", noise.detector->Validate()));
  } else if (s.has_noise_a_var() || s.has_noise_b_per_m()) {
    noise.detector.reset();
  }
  OAIPP_RETURN_IF_ERROR(Prefixed(prefix, camera.Validate()));
  return Prefixed(prefix, noise.Validate());
}

absl::Status FillSensor(const v1::SensorSpec& s, MissionConfig& c) {
  return FillSensorOf(s, kDefaults.KitOf(""), "spec.sensor", c.camera, c.noise);
}

// A UAV's speed, acceleration and radius from `f`, each unset one taken
// from `base`; `field` names `f` in errors.
absl::Status FillLimitsOf(const v1::FlightSpec& f, const PlannerLimits& base,
                          absl::string_view field, PlannerLimits& l) {
  const std::string prefix = absl::StrCat(field, ".");
  l = base;
  l.dynamics.max_speed_m_s =
      OrDefault(f.has_max_speed_m_s(), f.max_speed_m_s(), base.dynamics.max_speed_m_s);
  l.dynamics.max_accel_m_s2 =
      OrDefault(f.has_max_accel_m_s2(), f.max_accel_m_s2(), base.dynamics.max_accel_m_s2);
  l.uav_radius_m = OrDefault(f.has_uav_radius_m(), f.uav_radius_m(), base.uav_radius_m);
  l.tracking_error_m =
      OrDefault(f.has_tracking_error_m(), f.tracking_error_m(), base.tracking_error_m);
  OAIPP_RETURN_IF_ERROR(CheckPositive(prefix + "max_speed_m_s", l.dynamics.max_speed_m_s));
  OAIPP_RETURN_IF_ERROR(CheckPositive(prefix + "max_accel_m_s2", l.dynamics.max_accel_m_s2));
  OAIPP_RETURN_IF_ERROR(CheckPositive(prefix + "uav_radius_m", l.uav_radius_m));
  if (!(l.tracking_error_m >= 0.0 && l.tracking_error_m <= 10.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat(prefix, "tracking_error_m: must be in [0, 10], got ", l.tracking_error_m));
  }
  return Prefixed(prefix, l.Validate());
}

absl::Status FillFlight(const v1::FlightSpec& f, MissionConfig& c) {
  const EsdfConfig& esdf = kDefaults.esdf;
  c.min_altitude_m =
      OrDefault(f.has_min_altitude_m(), f.min_altitude_m(), kDefaults.min_altitude_m);
  c.max_altitude_m =
      OrDefault(f.has_max_altitude_m(), f.max_altitude_m(), kDefaults.max_altitude_m);
  c.esdf.voxel_size_m = OrDefault(f.has_esdf_voxel_m(), f.esdf_voxel_m(), esdf.voxel_size_m);
  c.esdf.truncation_m =
      OrDefault(f.has_esdf_truncation_m(), f.esdf_truncation_m(), esdf.truncation_m);

  OAIPP_RETURN_IF_ERROR(CheckNonNegative("spec.flight.min_altitude_m", c.min_altitude_m));
  OAIPP_RETURN_IF_ERROR(CheckFinite("spec.flight.max_altitude_m", c.max_altitude_m));
  if (!(c.max_altitude_m > c.min_altitude_m)) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.flight.max_altitude_m: must exceed spec.flight.min_altitude_m (",
                     c.min_altitude_m, "), got ", c.max_altitude_m));
  }
  // The paper's preset keeps the paper's r / 2 from obstacles; the service
  // keeps the UAV's whole body and its tracking error (docs/method.md).
  PlannerLimits base = kDefaults.planner.common.limits;
  base.obstacle_rule = c.preset == "paper" ? PlannerLimits::ObstacleRule::kPaperHalfRadius
                                           : PlannerLimits::ObstacleRule::kBody;
  OAIPP_RETURN_IF_ERROR(FillLimitsOf(f, base, "spec.flight", c.planner.common.limits));
  if (!(c.esdf.voxel_size_m > 0.0 && c.esdf.voxel_size_m <= 10.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.flight.esdf_voxel_m: must be in (0, 10], got ", c.esdf.voxel_size_m));
  }
  if (!(std::isfinite(c.esdf.truncation_m) && c.esdf.truncation_m >= c.esdf.voxel_size_m)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "spec.flight.esdf_truncation_m: must be finite and >= spec.flight.esdf_voxel_m (",
        c.esdf.voxel_size_m, "), got ", c.esdf.truncation_m));
  }
  return absl::OkStatus();
}

absl::Status FillPlanner(const v1::PlannerSpec& p, MissionConfig& c) {
  OAIPP_ASSIGN_OR_RETURN(c.planner.kind, [&]() -> absl::StatusOr<PlannerKind> {
    auto kind = PlannerKindFromProto(p.kind());
    if (!kind.ok()) return Prefixed("spec.", kind.status());
    return kind;
  }());
  PlannerCommon& common = c.planner.common;
  const InformationParams& info = kDefaults.planner.common.information;
  const OaIppConfig& oaipp = kDefaults.planner.oaipp;
  const LawnmowerConfig& lawnmower = kDefaults.planner.lawnmower;
  common.seed = OrDefault(p.has_seed(), p.seed(), kDefaults.planner.common.seed);
  // The objective follows the kind (ObjectiveFor), as MakePlanner sets it.
  common.information.kind = ObjectiveFor(c.planner.kind);
  common.information.kappa = OrDefault(p.has_kappa(), p.kappa(), info.kappa);
  common.information.h_opt_m = OrDefault(p.has_h_opt_m(), p.h_opt_m(), info.h_opt_m);
  common.information.sigma1_m = OrDefault(p.has_sigma1_m(), p.sigma1_m(), info.sigma1_m);
  common.information.h_sat_m = OrDefault(p.has_h_sat_m(), p.h_sat_m(), info.h_sat_m);
  common.information.confirmation_weight =
      OrDefault(p.has_confirmation_weight(), p.confirmation_weight(), info.confirmation_weight);
  common.information.decision_threshold =
      OrDefault(p.has_decision_threshold(), p.decision_threshold(), info.decision_threshold);
  common.information.confirmation_preposterior = p.confirmation_preposterior();
  common.information.confirmation_phase_s =
      OrDefault(p.has_confirmation_phase_s(), p.confirmation_phase_s(), info.confirmation_phase_s);
  common.information.confirmation_phase_weight =
      OrDefault(p.has_confirmation_phase_weight(), p.confirmation_phase_weight(),
                info.confirmation_phase_weight);
  common.information.ambiguity_margin =
      OrDefault(p.has_ambiguity_margin(), p.ambiguity_margin(), info.ambiguity_margin);
  common.information.second_look_weight =
      OrDefault(p.has_second_look_weight(), p.second_look_weight(), info.second_look_weight);
  common.information.second_look_sharpness = OrDefault(
      p.has_second_look_sharpness(), p.second_look_sharpness(), info.second_look_sharpness);
  common.information.detection_discount =
      OrDefault(p.has_detection_discount(), p.detection_discount(), info.detection_discount);
  c.planner.oaipp.num_waypoints =
      OrDefault(p.has_num_waypoints(), p.num_waypoints(), oaipp.num_waypoints);
  c.planner.oaipp.population = OrDefault(p.has_population(), p.population(), oaipp.population);
  c.planner.oaipp.generations = OrDefault(p.has_generations(), p.generations(), oaipp.generations);
  c.planner.oaipp.stall_generations =
      OrDefault(p.has_stall_generations(), p.stall_generations(), oaipp.stall_generations);
  c.planner.oaipp.stall_tolerance =
      OrDefault(p.has_stall_tolerance(), p.stall_tolerance(), oaipp.stall_tolerance);
  c.planner.lawnmower.altitude_m =
      OrDefault(p.has_lawnmower_altitude_m(), p.lawnmower_altitude_m(), lawnmower.altitude_m);
  c.planner.lawnmower.start_corner =
      OrDefault(p.has_lawnmower_start_corner(), p.lawnmower_start_corner(), lawnmower.start_corner);

  OAIPP_RETURN_IF_ERROR(
      CheckIntRange("spec.planner.num_waypoints", c.planner.oaipp.num_waypoints, 2, kMaxWaypoints));
  OAIPP_RETURN_IF_ERROR(
      CheckIntRange("spec.planner.population", c.planner.oaipp.population, 5, kMaxPopulation));
  OAIPP_RETURN_IF_ERROR(
      CheckIntRange("spec.planner.generations", c.planner.oaipp.generations, 0, kMaxGenerations));
  OAIPP_RETURN_IF_ERROR(CheckIntRange("spec.planner.stall_generations",
                                      c.planner.oaipp.stall_generations, 0, kMaxGenerations));
  OAIPP_RETURN_IF_ERROR(
      CheckUnitInterval("spec.planner.stall_tolerance", c.planner.oaipp.stall_tolerance));
  OAIPP_RETURN_IF_ERROR(CheckNonNegative("spec.planner.kappa", common.information.kappa));
  OAIPP_RETURN_IF_ERROR(CheckFinite("spec.planner.h_opt_m", common.information.h_opt_m));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.planner.sigma1_m", common.information.sigma1_m));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.planner.h_sat_m", common.information.h_sat_m));
  OAIPP_RETURN_IF_ERROR(
      CheckNonNegative("spec.planner.confirmation_weight", common.information.confirmation_weight));
  OAIPP_RETURN_IF_ERROR(CheckOpenInterval("spec.planner.decision_threshold",
                                          common.information.decision_threshold, 0.0, 1.0));
  OAIPP_RETURN_IF_ERROR(CheckNonNegative("spec.planner.confirmation_phase_s",
                                         common.information.confirmation_phase_s));
  OAIPP_RETURN_IF_ERROR(CheckNonNegative("spec.planner.confirmation_phase_weight",
                                         common.information.confirmation_phase_weight));
  OAIPP_RETURN_IF_ERROR(
      CheckNonNegative("spec.planner.second_look_weight", common.information.second_look_weight));
  OAIPP_RETURN_IF_ERROR(CheckNonNegative("spec.planner.second_look_sharpness",
                                         common.information.second_look_sharpness));
  if (const double margin = common.information.ambiguity_margin; !(margin > 0.0 && margin <= 0.5)) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.planner.ambiguity_margin: must lie in (0, 0.5], got ", margin));
  }
  if (const double g = common.information.detection_discount; !(g > 0.0 && g <= 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.planner.detection_discount: must lie in (0, 1], got ", g));
  }
  OAIPP_RETURN_IF_ERROR(
      CheckPositive("spec.planner.lawnmower_altitude_m", c.planner.lawnmower.altitude_m));
  OAIPP_RETURN_IF_ERROR(CheckIntRange("spec.planner.lawnmower_start_corner",
                                      c.planner.lawnmower.start_corner, -1, 3));
  // The core's own checks, as a backstop for anything above missed.
  return Prefixed("spec.planner.", MakePlanner(c.planner).status());
}

absl::Status FillObstacles(const google::protobuf::RepeatedPtrField<v1::Obstacle>& obstacles,
                           MissionConfig& c) {
  if (obstacles.size() > kMaxObstacles) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.obstacles: ", obstacles.size(), " obstacles; at most ", kMaxObstacles));
  }
  std::map<std::string, int> first_index;
  c.obstacles.reserve(obstacles.size());
  for (int i = 0; i < obstacles.size(); ++i) {
    const std::string field = absl::StrCat("spec.obstacles[", i, "]");
    OAIPP_ASSIGN_OR_RETURN(Obstacle o, ObstacleFromProto(obstacles.Get(i), field));
    if (auto [it, inserted] = first_index.emplace(o.id, i); !inserted) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".id: duplicate id '", o.id,
                                                     "' (also spec.obstacles[", it->second, "])"));
    }
    c.obstacles.push_back(std::move(o));
  }
  return absl::OkStatus();
}

// A start the UAV may fly from: inside the flight volume, within its
// speed and acceleration limits. `field` names it (spec.start, ...).
absl::Status CheckStart(const UavState& start, const MissionConfig& c,
                        const TrajectoryLimits& dynamics, absl::string_view field) {
  const Aabb volume = c.FlightVolume();
  if (!volume.Contains(start.position_W)) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ".position_m: ", Describe(start.position_W), " lies outside the flight volume ",
        Describe(volume.min_W), " .. ", Describe(volume.max_W)));
  }
  if (const double v = start.velocity_W_m_s.norm(); v > dynamics.max_speed_m_s) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".velocity_m_s: speed ", v,
                                                   " m/s exceeds max_speed_m_s (",
                                                   dynamics.max_speed_m_s, ")"));
  }
  if (const double a = start.accel_W_m_s2.norm(); a > dynamics.max_accel_m_s2) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".acceleration_m_s2: ", a,
                                                   " m/s^2 exceeds max_accel_m_s2 (",
                                                   dynamics.max_accel_m_s2, ")"));
  }
  return absl::OkStatus();
}

absl::Status FillStart(const v1::MissionSpec& spec, MissionConfig& c) {
  if (!spec.has_start()) {
    const Vec2 centre = 0.5 * (c.field_min_W + c.field_max_W);
    c.start.position_W = Vec3(centre.x(), centre.y(), MissionConfig::kDefaultStartAltitude_m);
    if (const Aabb volume = c.FlightVolume(); !volume.Contains(c.start.position_W)) {
      return absl::InvalidArgumentError(
          absl::StrCat("spec.start: unset, and the default start ", Describe(c.start.position_W),
                       " lies outside the flight volume ", Describe(volume.min_W), " .. ",
                       Describe(volume.max_W)));
    }
    return absl::OkStatus();
  }
  OAIPP_ASSIGN_OR_RETURN(c.start, UavStateFromProto(spec.start(), "spec.start"));
  return CheckStart(c.start, c, c.planner.common.limits.dynamics, "spec.start");
}

bool ValidUavId(absl::string_view id) {
  if (id.empty() || id.size() > static_cast<std::size_t>(kMaxUavIdBytes)) return false;
  return std::all_of(id.begin(), id.end(), [](char ch) {
    return (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '-';
  });
}

// A member's own kit: the mission's camera, noise and limits but for what
// its sensor and flight set. The flight volume and the ESDF are the
// mission's, so a member may not set them.
absl::StatusOr<UavKit> FillMemberKit(const v1::TeamMember& m, const MissionConfig& c,
                                     const std::string& field) {
  const v1::FlightSpec& f = m.flight();
  for (const auto& [set, name] : {std::pair{f.has_min_altitude_m(), "min_altitude_m"},
                                  std::pair{f.has_max_altitude_m(), "max_altitude_m"},
                                  std::pair{f.has_esdf_voxel_m(), "esdf_voxel_m"},
                                  std::pair{f.has_esdf_truncation_m(), "esdf_truncation_m"}}) {
    if (set) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".flight.", name,
                                                     ": the flight volume and the ESDF are the "
                                                     "mission's: set spec.flight.",
                                                     name, " instead"));
    }
  }
  const UavKit mission = c.KitOf("");
  UavKit kit;
  OAIPP_RETURN_IF_ERROR(
      FillSensorOf(m.sensor(), mission, field + ".sensor", kit.camera, kit.noise));
  OAIPP_RETURN_IF_ERROR(FillLimitsOf(f, mission.limits, field + ".flight", kit.limits));
  if (kit.limits.uav_radius_m > c.min_separation_m) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".flight.uav_radius_m: ", kit.limits.uav_radius_m,
                     " exceeds spec.min_separation_m (", c.min_separation_m, ")"));
  }
  return kit;
}

// The team (docs/teams.md): 1-16 members with distinct ids, each start
// valid as spec.start is (within its own limits), every two at least
// min_separation_m apart, one mission clock; `start` becomes the first
// member's (spec.start is not read).
absl::Status FillTeam(const v1::MissionSpec& spec, MissionConfig& c) {
  if (spec.team().empty()) return absl::OkStatus();  // min_separation_m unused
  c.count_teammate_shots = !spec.has_count_teammate_shots() || spec.count_teammate_shots();
  c.silent_after_s =
      OrDefault(spec.has_silent_after_s(), spec.silent_after_s(), MissionConfig{}.silent_after_s);
  if (!(c.silent_after_s > 0.0 && c.silent_after_s <= 3600.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.silent_after_s: must be in (0, 3600], got ", c.silent_after_s));
  }
  const double radius = c.planner.common.limits.uav_radius_m;
  c.min_separation_m = OrDefault(spec.has_min_separation_m(), spec.min_separation_m(),
                                 MissionConfig{}.min_separation_m);
  if (!std::isfinite(c.min_separation_m) || c.min_separation_m < radius ||
      c.min_separation_m > kMaxCoordinateM) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.min_separation_m: must be finite and at least flight.uav_radius_m (",
                     radius, "), got ", c.min_separation_m));
  }
  if (spec.team_size() > kMaxTeam) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.team: ", spec.team_size(), " UAVs; at most ", kMaxTeam));
  }
  if (c.planner.kind == PlannerKind::kLawnmower) {
    return absl::InvalidArgumentError(
        "spec.planner.kind: the lawnmower's pattern is one UAV's; a team plans with OA-IPP or "
        "random");
  }
  std::map<std::string, int> first_index;
  for (int i = 0; i < spec.team_size(); ++i) {
    const v1::TeamMember& m = spec.team(i);
    const std::string field = absl::StrCat("spec.team[", i, "]");
    if (!ValidUavId(m.uav_id())) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".uav_id: must match [a-z0-9-]{1,",
                                                     kMaxUavIdBytes, "}, got ",
                                                     EchoInput(m.uav_id())));
    }
    if (auto [it, inserted] = first_index.emplace(m.uav_id(), i); !inserted) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".uav_id: duplicate id '", m.uav_id(),
                                                     "' (also spec.team[", it->second, "])"));
    }
    if (!m.has_start()) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".start: required"));
    }
    OAIPP_ASSIGN_OR_RETURN(UavKit kit, FillMemberKit(m, c, field));
    OAIPP_ASSIGN_OR_RETURN(UavState start, UavStateFromProto(m.start(), field + ".start"));
    OAIPP_RETURN_IF_ERROR(CheckStart(start, c, kit.limits.dynamics, field + ".start"));
    if (i > 0 && start.mission_time_s != c.team.front().start.mission_time_s) {
      return absl::InvalidArgumentError(absl::StrCat(
          field,
          ".start.mission_time_s: the team shares one mission clock: must equal spec.team[0]'s (",
          c.team.front().start.mission_time_s, "), got ", start.mission_time_s));
    }
    c.team.push_back({.uav_id = m.uav_id(), .start = start, .kit = std::move(kit)});
    // As far apart as every plan's final check asks (its 0.05 m margin
    // included), so that a team accepted here can plan from its starts.
    for (int j = 0; j < i; ++j) {
      const double d = (start.position_W - c.team[j].start.position_W).norm();
      const double required = c.PairDistance(c.team.back().uav_id, c.team[j].uav_id) +
                              0.5 * c.planner.common.limits.exact_check_spacing_m;
      if (d < required) {
        return absl::InvalidArgumentError(absl::StrCat(
            field, ".start.position_m: ", d, " m from spec.team[", j, "] ('", c.team[j].uav_id,
            "'), closer than the ", required,
            " m every plan keeps (min_separation_m or the two bodies with their tracking "
            "errors, whichever is more, and the final check's margin)"));
      }
    }
  }
  c.start = c.team.front().start;
  return absl::OkStatus();
}

}  // namespace

v1::PlannerKind PlannerKindToProto(PlannerKind kind) {
  switch (kind) {
    case PlannerKind::kOaIpp:
      return v1::PLANNER_KIND_OAIPP;
    case PlannerKind::kOaIppNonAdaptive:
      return v1::PLANNER_KIND_OAIPP_NONADAPTIVE;
    case PlannerKind::kLawnmower:
      return v1::PLANNER_KIND_LAWNMOWER;
    case PlannerKind::kRandom:
      return v1::PLANNER_KIND_RANDOM;
    case PlannerKind::kOaIppDetection:
      return v1::PLANNER_KIND_OAIPP_DETECTION;
  }
  return v1::PLANNER_KIND_UNSPECIFIED;  // unreachable for a valid enumerator
}

absl::StatusOr<PlannerKind> PlannerKindFromProto(v1::PlannerKind kind) {
  switch (kind) {
    case v1::PLANNER_KIND_UNSPECIFIED:
    case v1::PLANNER_KIND_OAIPP:
      return PlannerKind::kOaIpp;
    case v1::PLANNER_KIND_OAIPP_NONADAPTIVE:
      return PlannerKind::kOaIppNonAdaptive;
    case v1::PLANNER_KIND_LAWNMOWER:
      return PlannerKind::kLawnmower;
    case v1::PLANNER_KIND_RANDOM:
      return PlannerKind::kRandom;
    case v1::PLANNER_KIND_OAIPP_DETECTION:
      return PlannerKind::kOaIppDetection;
    default:
      break;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("planner.kind: unknown value ", static_cast<int>(kind), " (expected ",
                   v1::PlannerKind_MIN, "..", v1::PlannerKind_MAX, ")"));
}

absl::StatusOr<MissionConfig> MissionSpecToConfig(const v1::MissionSpec& spec) {
  if (HasGeoFields(spec)) {
    // Geodetic points become local metres first; the rest sees those only.
    v1::MissionSpec local = spec;
    OAIPP_RETURN_IF_ERROR(ResolveGeoFields(&local, "spec"));
    return MissionSpecToConfig(local);
  }
  if (!spec.preset().empty() && spec.preset() != "paper") {
    return absl::InvalidArgumentError(absl::StrCat("spec.preset: unknown preset '", spec.preset(),
                                                   "' (expected \"\" or \"paper\")"));
  }
  MissionConfig c;
  c.preset = spec.preset();
  OAIPP_RETURN_IF_ERROR(FillField(spec.field(), c));
  OAIPP_RETURN_IF_ERROR(FillGp(spec.gp(), c));
  OAIPP_RETURN_IF_ERROR(FillSensor(spec.sensor(), c));
  OAIPP_RETURN_IF_ERROR(FillFlight(spec.flight(), c));
  OAIPP_RETURN_IF_ERROR(FillPlanner(spec.planner(), c));
  OAIPP_RETURN_IF_ERROR(FillObstacles(spec.obstacles(), c));
  OAIPP_RETURN_IF_ERROR(internal::FillSearchAreas(spec.search_areas(), c));
  OAIPP_RETURN_IF_ERROR(internal::FillAirspace(spec, c));
  if (spec.team().empty()) {
    if (spec.has_count_teammate_shots()) {
      return absl::InvalidArgumentError(
          "spec.count_teammate_shots: applies to a team only; spec.team is empty");
    }
    OAIPP_RETURN_IF_ERROR(FillStart(spec, c));
  } else {
    OAIPP_RETURN_IF_ERROR(FillTeam(spec, c));
  }
  c.budget_s = OrDefault(spec.has_budget_s(), spec.budget_s(), kDefaults.budget_s);
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.budget_s", c.budget_s));
  OAIPP_RETURN_IF_ERROR(internal::FillHome(spec, c));
  if (spec.has_geo_origin()) {
    OAIPP_ASSIGN_OR_RETURN(c.geo_origin, GeoPointFromProto(spec.geo_origin(), "spec.geo_origin"));
  }
  return c;
}

}  // namespace oaipp::api

#include "server/convert.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <variant>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"
#include "core/mapping/field_grid.h"

namespace oaipp::server {
namespace {

// Defaults documented in mission_service.proto (the paper's values).
constexpr double kDefaultFieldMin_m = -15.0;
constexpr double kDefaultFieldMax_m = 15.0;
constexpr double kDefaultResolution_m = 0.75;
constexpr double kDefaultStartAltitude_m = 10.0;
constexpr double kDefaultBudget_s = 150.0;
constexpr std::uint32_t kDefaultSeed = 1;

constexpr std::size_t kMaxIdLength = 128;
// Samples per second of the sampled path in PlanPathResponse.
constexpr double kSampleRate_hz = 10.0;

double RadToDeg(double rad) { return rad * 180.0 / kPi; }

template <typename T>
T OrDefault(bool has, T value, T fallback) {
  return has ? value : fallback;
}

// `status` with `prefix` put before its message; OK stays OK.
absl::Status Prefixed(absl::string_view prefix, const absl::Status& status) {
  if (status.ok()) return status;
  return absl::Status(status.code(), absl::StrCat(prefix, status.message()));
}

absl::Status CheckFiniteVector(absl::string_view field, const v1::Vector3& v) {
  OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat(field, ".x"), v.x()));
  OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat(field, ".y"), v.y()));
  return CheckFinite(absl::StrCat(field, ".z"), v.z());
}

absl::Status CheckNonNegative(absl::string_view field, double value) {
  if (std::isfinite(value) && value >= 0.0) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, ": must be >= 0 and finite, got ", value));
}

absl::Status CheckUnitInterval(absl::string_view field, double value) {
  if (value >= 0.0 && value <= 1.0) return absl::OkStatus();  // false for NaN
  return absl::InvalidArgumentError(absl::StrCat(field, ": must be in [0, 1], got ", value));
}

absl::Status CheckOpenInterval(absl::string_view field, double value, double lo, double hi) {
  if (value > lo && value < hi) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be in (", lo, ", ", hi, "), got ", value));
}

absl::Status CheckIntRange(absl::string_view field, std::int64_t value, std::int64_t lo,
                           std::int64_t hi) {
  if (value >= lo && value <= hi) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be in [", lo, ", ", hi, "], got ", value));
}

absl::Status CheckAtLeast(absl::string_view field, std::int64_t value, std::int64_t lo) {
  if (value >= lo) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, ": must be >= ", lo, ", got ", value));
}

absl::Status CheckId(absl::string_view field, const std::string& id) {
  if (!id.empty() && id.size() <= kMaxIdLength) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be 1..", kMaxIdLength, " characters, got ", id.size()));
}

std::string Describe(const Vec3& v) {
  return absl::StrCat("(", v.x(), ", ", v.y(), ", ", v.z(), ")");
}

// FieldGrid::FromBounds names its own arguments; say which spec field is meant.
absl::Status FieldError(const absl::Status& status) {
  absl::string_view message = status.message();
  if (absl::StartsWith(message, "resolution_m")) return Prefixed("spec.field.", status);
  return Prefixed("spec.field: ", status);
}

absl::StatusOr<Vec2> FieldCorner(const v1::FieldSpec& f, bool max_corner) {
  const double fallback = max_corner ? kDefaultFieldMax_m : kDefaultFieldMin_m;
  const double x = max_corner ? OrDefault(f.has_x_max_m(), f.x_max_m(), fallback)
                              : OrDefault(f.has_x_min_m(), f.x_min_m(), fallback);
  const double y = max_corner ? OrDefault(f.has_y_max_m(), f.y_max_m(), fallback)
                              : OrDefault(f.has_y_min_m(), f.y_min_m(), fallback);
  const char* suffix = max_corner ? "max_m" : "min_m";
  OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat("spec.field.x_", suffix), x));
  OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat("spec.field.y_", suffix), y));
  return Vec2(x, y);
}

absl::Status FillField(const v1::FieldSpec& f, MissionConfig& c) {
  OAIPP_ASSIGN_OR_RETURN(c.field_min_W, FieldCorner(f, /*max_corner=*/false));
  OAIPP_ASSIGN_OR_RETURN(c.field_max_W, FieldCorner(f, /*max_corner=*/true));
  c.resolution_m = OrDefault(f.has_resolution_m(), f.resolution_m(), kDefaultResolution_m);
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.field.resolution_m", c.resolution_m));
  for (int a = 0; a < 2; ++a) {
    if (!(c.field_max_W[a] > c.field_min_W[a])) {
      const char* axis = a == 0 ? "x" : "y";
      return absl::InvalidArgumentError(
          absl::StrCat("spec.field.", axis, "_max_m: must exceed spec.field.", axis, "_min_m (",
                       c.field_min_W[a], "), got ", c.field_max_W[a]));
    }
  }
  if (auto grid = FieldGrid::FromBounds(c.field_min_W, c.field_max_W, c.resolution_m); !grid.ok()) {
    return FieldError(grid.status());
  }
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
  return Prefixed("spec.gp.", c.gp.Validate());
}

absl::Status FillSensor(const v1::SensorSpec& s, MissionConfig& c) {
  const DownwardCamera camera;
  const SensorNoise noise;
  const PlannerLimits limits;
  c.camera.fov_x_deg = OrDefault(s.has_fov_x_deg(), s.fov_x_deg(), camera.fov_x_deg);
  c.camera.fov_y_deg = OrDefault(s.has_fov_y_deg(), s.fov_y_deg(), camera.fov_y_deg);
  c.noise.a_var = OrDefault(s.has_noise_a_var(), s.noise_a_var(), noise.a_var);
  c.noise.b_per_m = OrDefault(s.has_noise_b_per_m(), s.noise_b_per_m(), noise.b_per_m);
  c.planner.common.limits.sensor_rate_hz =
      OrDefault(s.has_rate_hz(), s.rate_hz(), limits.sensor_rate_hz);
  OAIPP_RETURN_IF_ERROR(CheckOpenInterval("spec.sensor.fov_x_deg", c.camera.fov_x_deg, 0, 180));
  OAIPP_RETURN_IF_ERROR(CheckOpenInterval("spec.sensor.fov_y_deg", c.camera.fov_y_deg, 0, 180));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.sensor.noise_a_var", c.noise.a_var));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.sensor.noise_b_per_m", c.noise.b_per_m));
  OAIPP_RETURN_IF_ERROR(
      CheckPositive("spec.sensor.rate_hz", c.planner.common.limits.sensor_rate_hz));
  OAIPP_RETURN_IF_ERROR(Prefixed("spec.sensor.", c.camera.Validate()));
  return Prefixed("spec.sensor.", c.noise.Validate());
}

absl::Status FillFlight(const v1::FlightSpec& f, MissionConfig& c) {
  const MissionConfig defaults;
  const PlannerLimits limits;
  const EsdfConfig esdf;
  c.min_altitude_m = OrDefault(f.has_min_altitude_m(), f.min_altitude_m(), defaults.min_altitude_m);
  c.max_altitude_m = OrDefault(f.has_max_altitude_m(), f.max_altitude_m(), defaults.max_altitude_m);
  PlannerLimits& l = c.planner.common.limits;
  l.dynamics.max_speed_m_s =
      OrDefault(f.has_max_speed_m_s(), f.max_speed_m_s(), limits.dynamics.max_speed_m_s);
  l.dynamics.max_accel_m_s2 =
      OrDefault(f.has_max_accel_m_s2(), f.max_accel_m_s2(), limits.dynamics.max_accel_m_s2);
  l.uav_radius_m = OrDefault(f.has_uav_radius_m(), f.uav_radius_m(), limits.uav_radius_m);
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
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.flight.max_speed_m_s", l.dynamics.max_speed_m_s));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.flight.max_accel_m_s2", l.dynamics.max_accel_m_s2));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.flight.uav_radius_m", l.uav_radius_m));
  if (!(c.esdf.voxel_size_m > 0.0 && c.esdf.voxel_size_m <= 10.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.flight.esdf_voxel_m: must be in (0, 10], got ", c.esdf.voxel_size_m));
  }
  if (!(std::isfinite(c.esdf.truncation_m) && c.esdf.truncation_m >= c.esdf.voxel_size_m)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "spec.flight.esdf_truncation_m: must be finite and >= spec.flight.esdf_voxel_m (",
        c.esdf.voxel_size_m, "), got ", c.esdf.truncation_m));
  }
  return Prefixed("spec.flight.", l.Validate());
}

absl::Status FillPlanner(const v1::PlannerSpec& p, MissionConfig& c) {
  OAIPP_ASSIGN_OR_RETURN(c.planner.kind, [&]() -> absl::StatusOr<PlannerKind> {
    auto kind = PlannerKindFromProto(p.kind());
    if (!kind.ok()) return Prefixed("spec.", kind.status());
    return kind;
  }());
  PlannerCommon& common = c.planner.common;
  const InformationParams info;
  const OaIppConfig oaipp;
  const LawnmowerConfig lawnmower;
  common.seed = OrDefault(p.has_seed(), p.seed(), kDefaultSeed);
  common.information.kind = c.planner.kind == PlannerKind::kOaIppNonAdaptive
                                ? ObjectiveKind::kNonAdaptive
                                : ObjectiveKind::kAdaptive;
  common.information.kappa = OrDefault(p.has_kappa(), p.kappa(), info.kappa);
  common.information.h_opt_m = OrDefault(p.has_h_opt_m(), p.h_opt_m(), info.h_opt_m);
  common.information.sigma1_m = OrDefault(p.has_sigma1_m(), p.sigma1_m(), info.sigma1_m);
  common.information.h_sat_m = OrDefault(p.has_h_sat_m(), p.h_sat_m(), info.h_sat_m);
  c.planner.oaipp.num_waypoints =
      OrDefault(p.has_num_waypoints(), p.num_waypoints(), oaipp.num_waypoints);
  c.planner.oaipp.population = OrDefault(p.has_population(), p.population(), oaipp.population);
  c.planner.oaipp.generations = OrDefault(p.has_generations(), p.generations(), oaipp.generations);
  c.planner.lawnmower.altitude_m =
      OrDefault(p.has_lawnmower_altitude_m(), p.lawnmower_altitude_m(), lawnmower.altitude_m);
  c.planner.lawnmower.start_corner =
      OrDefault(p.has_lawnmower_start_corner(), p.lawnmower_start_corner(), lawnmower.start_corner);

  OAIPP_RETURN_IF_ERROR(
      CheckIntRange("spec.planner.num_waypoints", c.planner.oaipp.num_waypoints, 2, 20));
  OAIPP_RETURN_IF_ERROR(CheckAtLeast("spec.planner.population", c.planner.oaipp.population, 5));
  OAIPP_RETURN_IF_ERROR(CheckAtLeast("spec.planner.generations", c.planner.oaipp.generations, 0));
  OAIPP_RETURN_IF_ERROR(CheckNonNegative("spec.planner.kappa", common.information.kappa));
  OAIPP_RETURN_IF_ERROR(CheckFinite("spec.planner.h_opt_m", common.information.h_opt_m));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.planner.sigma1_m", common.information.sigma1_m));
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.planner.h_sat_m", common.information.h_sat_m));
  OAIPP_RETURN_IF_ERROR(
      CheckPositive("spec.planner.lawnmower_altitude_m", c.planner.lawnmower.altitude_m));
  OAIPP_RETURN_IF_ERROR(CheckIntRange("spec.planner.lawnmower_start_corner",
                                      c.planner.lawnmower.start_corner, -1, 3));
  // The core's own checks, as a backstop for anything above missed.
  return Prefixed("spec.planner.", MakePlanner(c.planner).status());
}

absl::Status FillObstacles(const google::protobuf::RepeatedPtrField<v1::Obstacle>& obstacles,
                           MissionConfig& c) {
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

absl::Status FillStart(const v1::MissionSpec& spec, MissionConfig& c) {
  const Aabb volume = c.FlightVolume();
  const auto outside = [&](absl::string_view what) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, Describe(c.start.position_W), " lies outside the flight volume ",
                     Describe(volume.min_W), " .. ", Describe(volume.max_W)));
  };
  if (!spec.has_start()) {
    c.start = UavState{};
    const Vec2 centre = 0.5 * (c.field_min_W + c.field_max_W);
    c.start.position_W = Vec3(centre.x(), centre.y(), kDefaultStartAltitude_m);
    if (!volume.Contains(c.start.position_W)) {
      return outside("spec.start: unset, and the default start ");
    }
    return absl::OkStatus();
  }
  OAIPP_ASSIGN_OR_RETURN(c.start, UavStateFromProto(spec.start(), "spec.start"));
  if (!volume.Contains(c.start.position_W)) return outside("spec.start.position_m: ");
  const TrajectoryLimits& dynamics = c.planner.common.limits.dynamics;
  if (const double v = c.start.velocity_W_m_s.norm(); v > dynamics.max_speed_m_s) {
    return absl::InvalidArgumentError(absl::StrCat("spec.start.velocity_m_s: speed ", v,
                                                   " m/s exceeds max_speed_m_s (",
                                                   dynamics.max_speed_m_s, ")"));
  }
  if (const double a = c.start.accel_W_m_s2.norm(); a > dynamics.max_accel_m_s2) {
    return absl::InvalidArgumentError(absl::StrCat("spec.start.acceleration_m_s2: ", a,
                                                   " m/s^2 exceeds max_accel_m_s2 (",
                                                   dynamics.max_accel_m_s2, ")"));
  }
  return absl::OkStatus();
}

}  // namespace

// ---------------------------------------------------------------------------

v1::Vector3 ToProto(const Vec3& v) {
  v1::Vector3 out;
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
  return out;
}

Vec3 FromProto(const v1::Vector3& v) { return Vec3(v.x(), v.y(), v.z()); }

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
    default:
      break;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("planner.kind: unknown value ", static_cast<int>(kind), " (expected ",
                   v1::PlannerKind_MIN, "..", v1::PlannerKind_MAX, ")"));
}

// ---------------------------------------------------------------------------

absl::StatusOr<MissionConfig> MissionSpecToConfig(const v1::MissionSpec& spec) {
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
  OAIPP_RETURN_IF_ERROR(FillStart(spec, c));
  c.budget_s = OrDefault(spec.has_budget_s(), spec.budget_s(), kDefaultBudget_s);
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.budget_s", c.budget_s));
  return c;
}

v1::MissionSpec ConfigToMissionSpec(const MissionConfig& c) {
  v1::MissionSpec spec;
  spec.set_preset(c.preset);

  v1::FieldSpec& f = *spec.mutable_field();
  f.set_x_min_m(c.field_min_W.x());
  f.set_y_min_m(c.field_min_W.y());
  f.set_x_max_m(c.field_max_W.x());
  f.set_y_max_m(c.field_max_W.y());
  f.set_resolution_m(c.resolution_m);

  v1::GpSpec& g = *spec.mutable_gp();
  g.set_length_scale_m(c.gp.length_scale_m);
  g.set_signal_var(c.gp.signal_var);
  g.set_noise_var(c.gp.noise_var);
  g.set_prior_mean(c.gp.prior_mean);

  const PlannerCommon& common = c.planner.common;
  v1::SensorSpec& s = *spec.mutable_sensor();
  s.set_fov_x_deg(c.camera.fov_x_deg);
  s.set_fov_y_deg(c.camera.fov_y_deg);
  s.set_noise_a_var(c.noise.a_var);
  s.set_noise_b_per_m(c.noise.b_per_m);
  s.set_rate_hz(common.limits.sensor_rate_hz);

  v1::FlightSpec& fl = *spec.mutable_flight();
  fl.set_min_altitude_m(c.min_altitude_m);
  fl.set_max_altitude_m(c.max_altitude_m);
  fl.set_max_speed_m_s(common.limits.dynamics.max_speed_m_s);
  fl.set_max_accel_m_s2(common.limits.dynamics.max_accel_m_s2);
  fl.set_uav_radius_m(common.limits.uav_radius_m);
  fl.set_esdf_voxel_m(c.esdf.voxel_size_m);
  fl.set_esdf_truncation_m(c.esdf.truncation_m);

  v1::PlannerSpec& p = *spec.mutable_planner();
  p.set_kind(PlannerKindToProto(c.planner.kind));
  p.set_seed(common.seed);
  p.set_num_waypoints(c.planner.oaipp.num_waypoints);
  p.set_population(c.planner.oaipp.population);
  p.set_generations(c.planner.oaipp.generations);
  p.set_kappa(common.information.kappa);
  p.set_h_opt_m(common.information.h_opt_m);
  p.set_sigma1_m(common.information.sigma1_m);
  p.set_h_sat_m(common.information.h_sat_m);
  p.set_lawnmower_altitude_m(c.planner.lawnmower.altitude_m);
  p.set_lawnmower_start_corner(c.planner.lawnmower.start_corner);

  for (const Obstacle& o : c.obstacles) *spec.add_obstacles() = ObstacleToProto(o);
  *spec.mutable_start() = UavStateToProto(c.start);
  spec.set_budget_s(c.budget_s);
  return spec;
}

// ---------------------------------------------------------------------------

absl::StatusOr<Obstacle> ObstacleFromProto(const v1::Obstacle& obstacle, absl::string_view field) {
  OAIPP_RETURN_IF_ERROR(CheckId(absl::StrCat(field, ".id"), obstacle.id()));
  Obstacle out;
  out.id = obstacle.id();
  switch (obstacle.shape_case()) {
    case v1::Obstacle::kBox: {
      const v1::Box& b = obstacle.box();
      const std::string name = absl::StrCat(field, ".box");
      OAIPP_RETURN_IF_ERROR(CheckFiniteVector(absl::StrCat(name, ".centre_m"), b.centre_m()));
      OAIPP_RETURN_IF_ERROR(CheckPositive(absl::StrCat(name, ".size_m.x"), b.size_m().x()));
      OAIPP_RETURN_IF_ERROR(CheckPositive(absl::StrCat(name, ".size_m.y"), b.size_m().y()));
      OAIPP_RETURN_IF_ERROR(CheckPositive(absl::StrCat(name, ".size_m.z"), b.size_m().z()));
      OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat(name, ".yaw_deg"), b.yaw_deg()));
      out.shape = Box{.centre_W = FromProto(b.centre_m()),
                      .size_m = FromProto(b.size_m()),
                      .yaw_rad = DegToRad(b.yaw_deg())};
      break;
    }
    case v1::Obstacle::kCylinder: {
      const v1::Cylinder& cyl = obstacle.cylinder();
      const std::string name = absl::StrCat(field, ".cylinder");
      OAIPP_RETURN_IF_ERROR(CheckFiniteVector(absl::StrCat(name, ".centre_m"), cyl.centre_m()));
      OAIPP_RETURN_IF_ERROR(CheckPositive(absl::StrCat(name, ".radius_m"), cyl.radius_m()));
      OAIPP_RETURN_IF_ERROR(CheckPositive(absl::StrCat(name, ".height_m"), cyl.height_m()));
      out.shape = Cylinder{.centre_W = FromProto(cyl.centre_m()),
                           .radius_m = cyl.radius_m(),
                           .height_m = cyl.height_m()};
      break;
    }
    case v1::Obstacle::SHAPE_NOT_SET:
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".shape: must be set (a box or a cylinder)"));
  }
  // The core's own check, as a backstop.
  OAIPP_RETURN_IF_ERROR(ValidateShape(out.shape, absl::StrCat(field, ".shape")));
  return out;
}

v1::Obstacle ObstacleToProto(const Obstacle& obstacle) {
  v1::Obstacle out;
  out.set_id(obstacle.id);
  if (const Box* b = std::get_if<Box>(&obstacle.shape)) {
    v1::Box& box = *out.mutable_box();
    *box.mutable_centre_m() = ToProto(b->centre_W);
    *box.mutable_size_m() = ToProto(b->size_m);
    box.set_yaw_deg(RadToDeg(b->yaw_rad));
  } else if (const Cylinder* c = std::get_if<Cylinder>(&obstacle.shape)) {
    v1::Cylinder& cyl = *out.mutable_cylinder();
    *cyl.mutable_centre_m() = ToProto(c->centre_W);
    cyl.set_radius_m(c->radius_m);
    cyl.set_height_m(c->height_m);
  }
  return out;
}

absl::StatusOr<ObstacleChange> ObstacleChangeFromProto(const v1::UpdateObstaclesRequest& request) {
  ObstacleChange change;
  std::set<std::string> seen;
  const auto note = [&](const std::string& field, const std::string& id) -> absl::Status {
    if (seen.insert(id).second) return absl::OkStatus();
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": id '", id, "' appears more than once in the change"));
  };
  for (int i = 0; i < request.add_size(); ++i) {
    const std::string field = absl::StrCat("add[", i, "]");
    OAIPP_ASSIGN_OR_RETURN(Obstacle o, ObstacleFromProto(request.add(i), field));
    OAIPP_RETURN_IF_ERROR(note(absl::StrCat(field, ".id"), o.id));
    change.add.push_back(std::move(o));
  }
  for (int i = 0; i < request.remove_size(); ++i) {
    const std::string field = absl::StrCat("remove[", i, "]");
    OAIPP_RETURN_IF_ERROR(CheckId(field, request.remove(i)));
    OAIPP_RETURN_IF_ERROR(note(field, request.remove(i)));
    change.remove.push_back(request.remove(i));
  }
  for (int i = 0; i < request.replace_size(); ++i) {
    const std::string field = absl::StrCat("replace[", i, "]");
    OAIPP_ASSIGN_OR_RETURN(Obstacle o, ObstacleFromProto(request.replace(i), field));
    OAIPP_RETURN_IF_ERROR(note(absl::StrCat(field, ".id"), o.id));
    change.replace.push_back(std::move(o));
  }
  return change;
}

// ---------------------------------------------------------------------------

absl::StatusOr<UavState> UavStateFromProto(const v1::UavState& state, absl::string_view field) {
  OAIPP_RETURN_IF_ERROR(CheckFiniteVector(absl::StrCat(field, ".position_m"), state.position_m()));
  OAIPP_RETURN_IF_ERROR(
      CheckFiniteVector(absl::StrCat(field, ".velocity_m_s"), state.velocity_m_s()));
  OAIPP_RETURN_IF_ERROR(
      CheckFiniteVector(absl::StrCat(field, ".acceleration_m_s2"), state.acceleration_m_s2()));
  OAIPP_RETURN_IF_ERROR(
      CheckNonNegative(absl::StrCat(field, ".mission_time_s"), state.mission_time_s()));
  UavState out;
  out.position_W = FromProto(state.position_m());
  out.velocity_W_m_s = FromProto(state.velocity_m_s());
  out.accel_W_m_s2 = FromProto(state.acceleration_m_s2());
  out.mission_time_s = state.mission_time_s();
  return out;
}

v1::UavState UavStateToProto(const UavState& state) {
  v1::UavState out;
  *out.mutable_position_m() = ToProto(state.position_W);
  *out.mutable_velocity_m_s() = ToProto(state.velocity_W_m_s);
  *out.mutable_acceleration_m_s2() = ToProto(state.accel_W_m_s2);
  out.set_mission_time_s(state.mission_time_s);
  return out;
}

// ---------------------------------------------------------------------------

namespace {

absl::StatusOr<CellLabels> LabelsFromProto(const v1::CellLabels& in) {
  if (in.labels_size() != in.cells_size()) {
    return absl::InvalidArgumentError(absl::StrCat("labels.labels: has ", in.labels_size(),
                                                   " entries but labels.cells has ",
                                                   in.cells_size(), " (must match)"));
  }
  CellLabels out;
  out.cells.reserve(in.cells_size());
  out.labels.reserve(in.labels_size());
  std::map<int, int> first_index;
  for (int i = 0; i < in.cells_size(); ++i) {
    const int cell = in.cells(i);
    if (cell < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("labels.cells[", i, "]: must be >= 0, got ", cell));
    }
    if (auto [it, inserted] = first_index.emplace(cell, i); !inserted) {
      return absl::InvalidArgumentError(absl::StrCat("labels.cells[", i, "]: cell ", cell,
                                                     " repeats labels.cells[", it->second, "]"));
    }
    OAIPP_RETURN_IF_ERROR(CheckUnitInterval(absl::StrCat("labels.labels[", i, "]"), in.labels(i)));
    out.cells.push_back(cell);
    out.labels.push_back(in.labels(i));
  }
  return out;
}

CameraIntrinsics IntrinsicsFromProto(const v1::CameraIntrinsics& k) {
  return {.fx_px = k.fx_px(),
          .fy_px = k.fy_px(),
          .cx_px = k.cx_px(),
          .cy_px = k.cy_px(),
          .width_px = k.width_px(),
          .height_px = k.height_px(),
          .k1 = k.k1(),
          .k2 = k.k2(),
          .p1 = k.p1(),
          .p2 = k.p2(),
          .k3 = k.k3()};
}

absl::Status CheckBox(absl::string_view field, const PixelBox& b,
                      const std::optional<CameraIntrinsics>& intrinsics) {
  const auto name = [&](absl::string_view sub) { return absl::StrCat(field, ".", sub); };
  OAIPP_RETURN_IF_ERROR(CheckNonNegative(name("x_min_px"), b.x_min_px));
  OAIPP_RETURN_IF_ERROR(CheckNonNegative(name("y_min_px"), b.y_min_px));
  OAIPP_RETURN_IF_ERROR(CheckFinite(name("x_max_px"), b.x_max_px));
  OAIPP_RETURN_IF_ERROR(CheckFinite(name("y_max_px"), b.y_max_px));
  if (!(b.x_max_px > b.x_min_px)) {
    return absl::InvalidArgumentError(absl::StrCat(name("x_max_px"), ": must exceed x_min_px (",
                                                   b.x_min_px, "), got ", b.x_max_px));
  }
  if (!(b.y_max_px > b.y_min_px)) {
    return absl::InvalidArgumentError(absl::StrCat(name("y_max_px"), ": must exceed y_min_px (",
                                                   b.y_min_px, "), got ", b.y_max_px));
  }
  if (intrinsics.has_value()) {
    if (b.x_max_px > intrinsics->width_px) {
      return absl::InvalidArgumentError(absl::StrCat(name("x_max_px"), ": must be <= width_px (",
                                                     intrinsics->width_px, "), got ", b.x_max_px));
    }
    if (b.y_max_px > intrinsics->height_px) {
      return absl::InvalidArgumentError(absl::StrCat(name("y_max_px"), ": must be <= height_px (",
                                                     intrinsics->height_px, "), got ", b.y_max_px));
    }
  }
  return CheckUnitInterval(name("confidence"), b.confidence);
}

absl::StatusOr<MeasurementInput::Detections> DetectionsFromProto(const v1::ImageDetections& in) {
  MeasurementInput::Detections out;
  if (in.has_intrinsics()) {
    out.intrinsics = IntrinsicsFromProto(in.intrinsics());
    // CameraIntrinsics::Validate names its fields "intrinsics.<name>".
    OAIPP_RETURN_IF_ERROR(Prefixed("detections.", out.intrinsics->Validate()));
  }
  out.boxes.reserve(in.boxes_size());
  for (int i = 0; i < in.boxes_size(); ++i) {
    const v1::PixelBox& b = in.boxes(i);
    PixelBox box{.x_min_px = b.x_min_px(),
                 .y_min_px = b.y_min_px(),
                 .x_max_px = b.x_max_px(),
                 .y_max_px = b.y_max_px(),
                 .confidence = b.confidence()};
    OAIPP_RETURN_IF_ERROR(CheckBox(absl::StrCat("detections.boxes[", i, "]"), box, out.intrinsics));
    out.boxes.push_back(box);
  }
  out.min_confidence = in.min_confidence();
  OAIPP_RETURN_IF_ERROR(CheckUnitInterval("detections.min_confidence", out.min_confidence));
  return out;
}

}  // namespace

absl::StatusOr<MeasurementInput> MeasurementFromProto(const v1::AddMeasurementRequest& request) {
  MeasurementInput out;
  OAIPP_RETURN_IF_ERROR(CheckNonNegative("mission_time_s", request.mission_time_s()));
  out.mission_time_s = request.mission_time_s();
  OAIPP_RETURN_IF_ERROR(CheckFiniteVector("camera_position_m", request.camera_position_m()));
  if (!(request.camera_position_m().z() > 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera_position_m.z: must be above the ground (> 0), got ",
                     request.camera_position_m().z()));
  }
  OAIPP_RETURN_IF_ERROR(CheckFinite("camera_yaw_deg", request.camera_yaw_deg()));
  out.pose.p_WC = FromProto(request.camera_position_m());
  out.pose.yaw_rad = DegToRad(request.camera_yaw_deg());
  OAIPP_RETURN_IF_ERROR(out.pose.Validate());  // backstop; checked above

  switch (request.data_case()) {
    case v1::AddMeasurementRequest::kLabels: {
      OAIPP_ASSIGN_OR_RETURN(out.labels, LabelsFromProto(request.labels()));
      break;
    }
    case v1::AddMeasurementRequest::kDetections: {
      OAIPP_ASSIGN_OR_RETURN(out.detections, DetectionsFromProto(request.detections()));
      break;
    }
    case v1::AddMeasurementRequest::DATA_NOT_SET:
      return absl::InvalidArgumentError("data: must be set (labels or detections)");
  }
  return out;
}

// ---------------------------------------------------------------------------

void PlannedPathToProto(const PlannedPath& path, v1::PlanPathResponse* out) {
  out->Clear();
  const PolynomialTrajectory& trajectory = path.trajectory;
  v1::Trajectory& t = *out->mutable_trajectory();
  const double duration_s = trajectory.Duration();
  t.set_duration_s(duration_s);
  for (int i = 0; i < trajectory.NumSegments(); ++i) {
    const PolynomialTrajectory::SegmentCoefficients c = trajectory.Coefficients(i);
    v1::PolynomialSegment& segment = *t.add_segments();
    segment.set_duration_s(trajectory.SegmentDurations()[i]);
    for (int k = 0; k < PolynomialTrajectory::kNumCoefficients; ++k) {
      segment.add_x_coefficients(c(k, 0));
      segment.add_y_coefficients(c(k, 1));
      segment.add_z_coefficients(c(k, 2));
    }
  }
  // t = j / rate (no accumulated drift) below the duration, then the end
  // itself, as SampleTrajectory does.
  const auto add_sample = [&](double t_s) {
    v1::TrajectorySample& s = *t.add_samples();
    s.set_t_s(t_s);
    *s.mutable_position_m() = ToProto(trajectory.Position(t_s));
    *s.mutable_velocity_m_s() = ToProto(trajectory.Velocity(t_s));
  };
  for (int j = 0;; ++j) {
    const double t_s = j / kSampleRate_hz;
    if (!(t_s < duration_s)) break;
    add_sample(t_s);
  }
  add_sample(duration_s);

  for (const Vec3& c : path.control_waypoints_W) *out->add_control_waypoints_m() = ToProto(c);
  for (const MeasurementPose& pose : path.measurement_poses) {
    v1::MeasurementPose& p = *out->add_measurement_poses();
    p.set_t_s(pose.t_s);
    p.set_mission_time_s(pose.mission_time_s);
    *p.mutable_position_m() = ToProto(pose.position_W);
  }
  out->set_objective(path.objective);
  out->set_information(path.information);
  out->set_collision_samples(path.collision_samples);
  out->set_collision_free(path.collision_free);
  out->set_next_shot_mission_s(path.next_shot_mission_s);
  v1::PlannerStats& stats = *out->mutable_stats();
  stats.set_evaluations(path.stats.evaluations);
  stats.set_generations(path.stats.generations);
  stats.set_wall_time_s(path.stats.wall_time_s);
  stats.set_stop_reason(path.stats.stop_reason);
  stats.set_initial_objective(path.stats.initial_objective);
}

void MapToProto(const GpMap& map, bool include_cells, v1::GetMapResponse* out) {
  const FieldGrid& grid = map.grid();
  out->set_nx(grid.nx());
  out->set_ny(grid.ny());
  out->set_resolution_m(grid.resolution_m());
  out->set_x_min_m(grid.min_W().x());
  out->set_y_min_m(grid.min_W().y());
  out->set_trace(map.Trace());
  out->clear_mean();
  out->clear_variance();
  if (!include_cells) return;
  const int n = map.num_cells();
  out->mutable_mean()->Reserve(n);
  out->mutable_variance()->Reserve(n);
  for (int i = 0; i < n; ++i) {
    out->add_mean(map.Mean()[i]);
    out->add_variance(map.Variance(i));
  }
}

absl::StatusOr<std::string> MapToPng(const GpMap& map) {
  const FieldGrid& grid = map.grid();
  const int nx = grid.nx();
  const int ny = grid.ny();
  // At most ~2048 px per panel side, at least one pixel per cell.
  const int k = std::clamp(2048 / std::max(nx, ny), 1, kMapPngCellPx);
  // Value in [0, 1] -> grey level; NaN -> 0, out of range clipped.
  const auto level = [](double v) -> std::uint8_t {
    if (std::isnan(v)) return 0;
    return static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(v, 0.0, 1.0)));
  };
  // North up: image row 0 holds the grid's last row (largest y).
  cv::Mat mean_levels(ny, nx, CV_8UC1);
  cv::Mat std_levels(ny, nx, CV_8UC1);
  for (int row = 0; row < ny; ++row) {
    for (int col = 0; col < nx; ++col) {
      const int cell = grid.Index(row, col);
      mean_levels.at<std::uint8_t>(ny - 1 - row, col) = level(map.Mean()[cell]);
      std_levels.at<std::uint8_t>(ny - 1 - row, col) =
          level(std::sqrt(std::max(0.0, map.Variance(cell))));
    }
  }
  try {
    cv::Mat mean_colour, std_colour;
    cv::applyColorMap(mean_levels, mean_colour, cv::COLORMAP_VIRIDIS);
    cv::applyColorMap(std_levels, std_colour, cv::COLORMAP_VIRIDIS);
    const int panel_w = nx * k;
    cv::Mat canvas(ny * k, 2 * panel_w + kMapPngGapPx, CV_8UC3, cv::Scalar(255, 255, 255));
    // Block replication by hand: exact k x k squares, no interpolation.
    const std::pair<const cv::Mat*, int> panels[] = {{&mean_colour, 0},
                                                     {&std_colour, panel_w + kMapPngGapPx}};
    for (const auto& [colours, x0] : panels) {
      for (int r = 0; r < ny; ++r) {
        for (int c = 0; c < nx; ++c) {
          canvas(cv::Rect(x0 + c * k, r * k, k, k)).setTo(cv::Scalar(colours->at<cv::Vec3b>(r, c)));
        }
      }
    }
    std::vector<std::uint8_t> bytes;
    if (!cv::imencode(".png", canvas, bytes)) {
      return absl::InternalError("map png: OpenCV could not encode the image");
    }
    return std::string(bytes.begin(), bytes.end());
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("map png: ", e.what()));
  }
}

// ---------------------------------------------------------------------------

grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

}  // namespace oaipp::server

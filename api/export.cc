#include "api/export.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "api/geodetic.h"
#include "api/geometry.h"
#include "api/plan.h"
#include "core/common/status_macros.h"
#include "core/trajectory/polynomial_trajectory.h"
#include "nlohmann/json.hpp"

namespace oaipp::api {
namespace {

constexpr int kMaxSegments = 1000;
constexpr int kMaxSetpoints = 200000;
constexpr double kDenseStep_s = 0.01;  // waypoint search: the trajectory at 100 Hz
// Bounds the work of one export (Douglas-Peucker scans the samples once per
// waypoint it adds): at most 20000 samples and max_items waypoints.
constexpr int kMaxDenseSamples = 20000;
constexpr double kMaxTolerance_m = 100.0;
constexpr double kMinLegSpeed_m_s = 0.1;
// Heading of every waypoint and setpoint, degrees from north: the camera's
// x axis east (camera yaw 0), as the planner assumed.
constexpr double kHeadingDeg = 90.0;

Vec3 EnuToNed(const Vec3& v) { return {v.y(), v.x(), -v.z()}; }

double PointSegmentDistance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + s * ab - p).norm();
}

// The trajectory sampled densely, with every camera shot's time among the
// samples (flagged), and both ends.
struct DenseSamples {
  std::vector<double> t_s;
  std::vector<Vec3> p_W;
  std::vector<bool> shot;
};

DenseSamples Sample(const PolynomialTrajectory& traj, std::vector<double> shot_times) {
  const double duration = traj.Duration();
  const double step = std::max(kDenseStep_s, duration / kMaxDenseSamples);
  std::vector<std::pair<double, bool>> times;
  for (int j = 0; j * step < duration; ++j) times.emplace_back(j * step, false);
  times.emplace_back(duration, false);
  for (double t : shot_times) times.emplace_back(t, true);
  std::sort(times.begin(), times.end());
  DenseSamples out;
  for (const auto& [t, shot] : times) {
    if (!out.t_s.empty() && t - out.t_s.back() < 1e-9) {
      out.shot.back() = out.shot.back() || shot;
      continue;
    }
    out.t_s.push_back(t);
    out.p_W.push_back(traj.Position(t));
    out.shot.push_back(shot);
  }
  return out;
}

// Indices of the waypoints: the ends, every shot, and what Douglas-Peucker
// keeps at `tolerance` between them. *deviation: the largest distance of a
// sample from its leg. Empty when more than `limit` would be needed (the
// search stops there).
std::vector<std::size_t> ChooseWaypoints(const DenseSamples& d, double tolerance, std::size_t limit,
                                         double* deviation) {
  std::vector<std::size_t> fixed;
  for (std::size_t i = 0; i < d.t_s.size(); ++i) {
    if (i == 0 || i + 1 == d.t_s.size() || d.shot[i]) fixed.push_back(i);
  }
  if (fixed.size() > limit) return {};
  std::vector<bool> keep(d.t_s.size(), false);
  for (std::size_t i : fixed) keep[i] = true;
  std::size_t kept = fixed.size();
  std::vector<std::pair<std::size_t, std::size_t>> stack;
  for (std::size_t k = 0; k + 1 < fixed.size(); ++k) stack.emplace_back(fixed[k], fixed[k + 1]);
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    double worst = 0.0;
    std::size_t worst_i = a;
    for (std::size_t i = a + 1; i < b; ++i) {
      const double e = PointSegmentDistance(d.p_W[i], d.p_W[a], d.p_W[b]);
      if (e > worst) {
        worst = e;
        worst_i = i;
      }
    }
    if (worst > tolerance) {
      if (++kept > limit) return {};
      keep[worst_i] = true;
      stack.emplace_back(a, worst_i);
      stack.emplace_back(worst_i, b);
    }
  }
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (keep[i]) out.push_back(i);
  }
  *deviation = 0.0;
  for (std::size_t k = 0; k + 1 < out.size(); ++k) {
    for (std::size_t i = out[k] + 1; i < out[k + 1]; ++i) {
      *deviation =
          std::max(*deviation, PointSegmentDistance(d.p_W[i], d.p_W[out[k]], d.p_W[out[k + 1]]));
    }
  }
  return out;
}

// One mission item before it is written out: a waypoint (with its point)
// or a command.
struct Item {
  int command = kMavCmdNavWaypoint;
  std::array<double, 4> params = {0, 0, 0, 0};
  std::optional<Vec3> p_W;
};

std::vector<Item> BuildItems(const DenseSamples& d, const std::vector<std::size_t>& waypoints,
                             double acceptance_m) {
  std::vector<Item> items;
  double commanded = -1.0;
  int captures = 0;
  for (std::size_t k = 0; k < waypoints.size(); ++k) {
    const std::size_t i = waypoints[k];
    if (k > 0) {
      const std::size_t a = waypoints[k - 1];
      double length = 0.0;
      for (std::size_t j = a; j < i; ++j) length += (d.p_W[j + 1] - d.p_W[j]).norm();
      const double speed = std::max(kMinLegSpeed_m_s, length / (d.t_s[i] - d.t_s[a]));
      if (commanded < 0.0 || std::abs(speed - commanded) > kSpeedStep_m_s) {
        // param1 1: ground speed; param3 -1: throttle unchanged.
        items.push_back({kMavCmdDoChangeSpeed, {1.0, speed, -1.0, 0.0}, std::nullopt});
        commanded = speed;
      }
    }
    items.push_back({kMavCmdNavWaypoint, {0.0, acceptance_m, 0.0, kHeadingDeg}, d.p_W[i]});
    if (d.shot[i]) {
      // All cameras, no interval, one image with its sequence number (1, 2,
      // ...), so that a command sent again does not shoot again.
      items.push_back({kMavCmdImageStartCapture,
                       {0.0, 0.0, 1.0, static_cast<double>(++captures)},
                       std::nullopt});
    }
  }
  return items;
}

std::vector<Vec2> Rectangle(const Vec2& centre, const Vec2& half, double yaw_rad) {
  const double c = std::cos(yaw_rad);
  const double s = std::sin(yaw_rad);
  std::vector<Vec2> corners;
  for (const auto& [u, v] : {std::pair{1.0, 1.0}, {-1.0, 1.0}, {-1.0, -1.0}, {1.0, -1.0}}) {
    const double x = u * half.x();
    const double y = v * half.y();
    corners.emplace_back(centre.x() + c * x - s * y, centre.y() + s * x + c * y);
  }
  return corners;
}

// Whether the 2-D point lies over the obstacle's footprint.
bool Over(const Shape& shape, const Vec3& p_W) {
  if (const auto* b = std::get_if<Box>(&shape)) {
    const Vec2 d = p_W.head<2>() - b->centre_W.head<2>();
    const double c = std::cos(b->yaw_rad);
    const double s = std::sin(b->yaw_rad);
    return std::abs(c * d.x() + s * d.y()) <= 0.5 * b->size_m.x() &&
           std::abs(-s * d.x() + c * d.y()) <= 0.5 * b->size_m.y();
  }
  if (const auto* prism = std::get_if<Prism>(&shape)) {
    return PolygonSignedDistance(prism->footprint(), p_W.head<2>()) <= 0.0;
  }
  const auto& cyl = std::get<Cylinder>(shape);
  return (p_W.head<2>() - cyl.centre_W.head<2>()).norm() <= cyl.radius_m;
}

nlohmann::json LatLon(const GeoFrame& frame, const Vec2& p) {
  const GeoPoint g = frame.ToGeo(Vec3(p.x(), p.y(), 0.0));
  return nlohmann::json::array({g.latitude_deg, g.longitude_deg});
}

}  // namespace

absl::StatusOr<ExportOptions> ExportOptionsFromProto(const v1::ExportPathRequest& request) {
  ExportOptions o;
  if (request.has_setpoint_rate_hz()) {
    o.setpoint_rate_hz = request.setpoint_rate_hz();
    if (!(o.setpoint_rate_hz >= 10.0 && o.setpoint_rate_hz <= 1000.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat("setpoint_rate_hz: must be in [10, 1000], got ", o.setpoint_rate_hz));
    }
  }
  if (request.has_waypoint_tolerance_m()) {
    o.waypoint_tolerance_m = request.waypoint_tolerance_m();
    if (!(o.waypoint_tolerance_m >= 0.01 && o.waypoint_tolerance_m <= kMaxTolerance_m)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "waypoint_tolerance_m: must be in [0.01, 100], got ", o.waypoint_tolerance_m));
    }
  }
  if (request.has_max_items()) {
    o.max_items = request.max_items();
    if (o.max_items < 8 || o.max_items > 2000) {
      return absl::InvalidArgumentError(
          absl::StrCat("max_items: must be in [8, 2000], got ", o.max_items));
    }
  }
  switch (request.autopilot()) {
    case v1::AUTOPILOT_UNSPECIFIED:
    case v1::AUTOPILOT_PX4:
      o.firmware_type = kQgcFirmwarePx4;
      break;
    case v1::AUTOPILOT_ARDUPILOT:
      o.firmware_type = kQgcFirmwareArduPilot;
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("autopilot: unknown value ", static_cast<int>(request.autopilot())));
  }
  return o;
}

absl::StatusOr<v1::ExportPathResponse> ExportPath(const MissionConfig& config,
                                                  const std::vector<Obstacle>& obstacles,
                                                  const v1::PlanPathResponse& path,
                                                  const ExportOptions& options) {
  OAIPP_RETURN_IF_ERROR(config.CheckUavId(path.uav_id(), "path.uav_id"));
  if (path.trajectory().segments_size() > kMaxSegments) {
    return absl::InvalidArgumentError(absl::StrCat("path.trajectory.segments: at most ",
                                                   kMaxSegments, ", got ",
                                                   path.trajectory().segments_size()));
  }
  absl::StatusOr<PolynomialTrajectory> parsed = TrajectoryFromProto(path.trajectory());
  if (!parsed.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("path.", parsed.status().message()));
  }
  const PolynomialTrajectory& traj = *parsed;
  const double duration = traj.Duration();
  if (!(duration <= config.budget_s + 1e-6)) {
    return absl::InvalidArgumentError(absl::StrCat("path.trajectory: lasts ", duration,
                                                   " s, longer than the mission's budget_s (",
                                                   config.budget_s, " s)"));
  }
  std::vector<double> shots;
  for (int i = 0; i < path.measurement_poses_size(); ++i) {
    const double t = path.measurement_poses(i).t_s();
    if (!(t >= 0.0 && t <= duration)) {
      return absl::InvalidArgumentError(absl::StrCat("path.measurement_poses[", i,
                                                     "].t_s: must be in [0, ", duration,
                                                     "] (the trajectory), got ", t));
    }
    shots.push_back(t);
  }
  const double setpoints = std::floor(duration * options.setpoint_rate_hz) + 2.0;
  if (setpoints > kMaxSetpoints) {
    return absl::InvalidArgumentError(absl::StrCat("setpoint_rate_hz: ", options.setpoint_rate_hz,
                                                   " Hz over ", duration, " s gives more than ",
                                                   kMaxSetpoints, " setpoints"));
  }

  v1::ExportPathResponse out;
  // Setpoints: t = k / rate below the duration, then the end itself.
  const double dt = 1.0 / options.setpoint_rate_hz;
  auto add_setpoint = [&](double t) {
    v1::Setpoint* s = out.add_setpoints();
    s->set_t_s(t);
    *s->mutable_position_ned_m() = ToProto(EnuToNed(traj.Position(t)));
    *s->mutable_velocity_ned_m_s() = ToProto(EnuToNed(traj.Velocity(t)));
    *s->mutable_acceleration_ned_m_s2() = ToProto(EnuToNed(traj.Acceleration(t)));
    s->set_yaw_deg(kHeadingDeg);
  };
  for (int k = 0; k * dt < duration; ++k) add_setpoint(k * dt);
  add_setpoint(duration);

  // Waypoints, loosened until the items fit.
  const DenseSamples dense = Sample(traj, shots);
  double tolerance = options.waypoint_tolerance_m;
  double deviation = 0.0;
  std::vector<Item> items;
  for (;;) {
    const std::vector<std::size_t> waypoints =
        ChooseWaypoints(dense, tolerance, static_cast<std::size_t>(options.max_items), &deviation);
    if (!waypoints.empty()) {
      items = BuildItems(dense, waypoints, std::clamp(tolerance, 0.5, 5.0));
      if (static_cast<int>(items.size()) <= options.max_items) break;
    }
    if (tolerance >= kMaxTolerance_m) {
      return absl::FailedPreconditionError(absl::StrCat(
          "max_items: ", options.max_items, " items are too few for this path even at a ",
          kMaxTolerance_m, " m tolerance (", shots.size(), " camera shots); raise max_items"));
    }
    tolerance = std::min(2.0 * tolerance, kMaxTolerance_m);
  }
  out.set_waypoint_deviation_m(deviation);

  // Obstacles the path passes over cannot be fenced out (a fence is a column).
  std::vector<bool> overflown(obstacles.size(), false);
  for (std::size_t o = 0; o < obstacles.size(); ++o) {
    for (const Vec3& p : dense.p_W) {
      if (Over(obstacles[o].shape, p)) {
        overflown[o] = true;
        out.add_overflown_obstacles(obstacles[o].id);
        break;
      }
    }
  }

  if (!config.geo_origin.has_value()) return out;
  OAIPP_ASSIGN_OR_RETURN(const GeoFrame frame, GeoFrame::FromOrigin(*config.geo_origin));
  // Home: the ground under the UAV's start (its team member's, with a
  // team), where it took off; under the path's first point instead should
  // an obstacle added since stand there. Never inside an obstacle's
  // footprint, which the fence excludes. Altitudes are relative to it: its
  // height is the origin's, the ground (z = 0), so that an item's relative
  // altitude is its z.
  const TeamMember* member = config.FindMember(path.uav_id());
  const Vec3& start_W = member != nullptr ? member->start.position_W : config.start.position_W;
  Vec3 home_W(start_W.x(), start_W.y(), 0.0);
  for (const Obstacle& o : obstacles) {
    if (Over(o.shape, home_W)) {
      home_W = Vec3(traj.Position(0.0).x(), traj.Position(0.0).y(), 0.0);
      break;
    }
  }
  GeoPoint home = frame.ToGeo(home_W);
  home.altitude_m = frame.origin().altitude_m;

  nlohmann::json plan_items = nlohmann::json::array();
  for (std::size_t k = 0; k < items.size(); ++k) {
    const Item& item = items[k];
    v1::MissionItem* m = out.add_mission_items();
    m->set_seq(static_cast<std::uint32_t>(k));
    m->set_current(k == 0 ? 1 : 0);
    m->set_autocontinue(1);
    m->set_command(static_cast<std::uint32_t>(item.command));
    m->set_param1(static_cast<float>(item.params[0]));
    m->set_param2(static_cast<float>(item.params[1]));
    m->set_param3(static_cast<float>(item.params[2]));
    m->set_param4(static_cast<float>(item.params[3]));
    m->set_mission_type(0);
    nlohmann::json j = {{"autoContinue", true},
                        {"command", item.command},
                        {"doJumpId", k + 1},
                        {"type", "SimpleItem"}};
    if (item.p_W.has_value()) {
      const GeoPoint g = frame.ToGeo(*item.p_W);
      const double relative_alt = g.altitude_m - home.altitude_m;
      m->set_frame(kMavFrameGlobalRelativeAlt);
      m->set_x(static_cast<std::int32_t>(std::lround(g.latitude_deg * 1e7)));
      m->set_y(static_cast<std::int32_t>(std::lround(g.longitude_deg * 1e7)));
      m->set_z(static_cast<float>(relative_alt));
      j["frame"] = kMavFrameGlobalRelativeAlt;
      j["params"] = {item.params[0], item.params[1],  item.params[2], item.params[3],
                     g.latitude_deg, g.longitude_deg, relative_alt};
      j["Altitude"] = relative_alt;
      j["AltitudeMode"] = 1;  // relative to home
      j["AMSLAltAboveTerrain"] = nullptr;
    } else {
      m->set_frame(kMavFrameMission);
      j["frame"] = kMavFrameMission;
      j["params"] = {item.params[0], item.params[1], item.params[2], item.params[3], 0, 0, 0};
    }
    plan_items.push_back(std::move(j));
  }

  // The exporting UAV's own limits (a team member's may differ).
  const PlannerLimits limits = config.KitOf(path.uav_id()).limits;
  const double max_speed = limits.dynamics.max_speed_m_s;
  nlohmann::json mission = {
      {"version", 2},
      {"firmwareType", options.firmware_type},
      {"vehicleType", kQgcVehicleQuadrotor},
      {"cruiseSpeed", max_speed},
      {"hoverSpeed", max_speed},
      {"globalPlanAltitudeMode", 1},
      {"plannedHomePosition", {home.latitude_deg, home.longitude_deg, home.altitude_m}},
      {"items", std::move(plan_items)}};

  const double margin = std::max(kFenceMargin_m, limits.uav_radius_m);
  const Vec2 lo = config.field_min_W - Vec2(margin, margin);
  const Vec2 hi = config.field_max_W + Vec2(margin, margin);
  nlohmann::json field_fence = nlohmann::json::array();
  for (const Vec2& c :
       {Vec2(lo.x(), lo.y()), Vec2(hi.x(), lo.y()), Vec2(hi.x(), hi.y()), Vec2(lo.x(), hi.y())}) {
    field_fence.push_back(LatLon(frame, c));
  }
  nlohmann::json polygons = nlohmann::json::array(
      {{{"inclusion", true}, {"version", 1}, {"polygon", std::move(field_fence)}}});
  nlohmann::json circles = nlohmann::json::array();
  const auto polygon_of = [&](const std::vector<Vec2>& ring, bool inclusion) {
    nlohmann::json polygon = nlohmann::json::array();
    for (const Vec2& c : ring) polygon.push_back(LatLon(frame, c));
    polygons.push_back({{"inclusion", inclusion}, {"version", 1}, {"polygon", std::move(polygon)}});
  };
  const auto circle_of = [&](const Vec2& centre_W, double radius_m, bool inclusion) {
    circles.push_back({{"inclusion", inclusion},
                       {"version", 1},
                       {"circle", {{"center", LatLon(frame, centre_W)}, {"radius", radius_m}}}});
  };
  // A shape's column, fenced out.
  const auto exclude = [&](const Shape& shape) {
    if (const auto* b = std::get_if<Box>(&shape)) {
      polygon_of(Rectangle(b->centre_W.head<2>(), 0.5 * b->size_m.head<2>(), b->yaw_rad), false);
    } else if (const auto* prism = std::get_if<Prism>(&shape)) {
      polygon_of(prism->footprint(), false);
    } else {
      const auto& cyl = std::get<Cylinder>(shape);
      circle_of(cyl.centre_W.head<2>(), cyl.radius_m, false);
    }
  };
  for (std::size_t o = 0; o < obstacles.size(); ++o) {
    if (!overflown[o]) exclude(obstacles[o].shape);
  }
  // The mission's own fence and no-fly zones, which every path keeps out
  // of; a zone the path passes under or over is not fenced (a fence is a
  // column), as an overflown obstacle is not.
  if (const std::optional<Fence>& fence = config.airspace.fence(); fence.has_value()) {
    if (!fence->polygon_W.empty()) {
      polygon_of(fence->polygon_W, true);
    } else {
      circle_of(fence->centre_W, fence->radius_m, true);
    }
  }
  for (const Obstacle& zone : config.airspace.zones()) {
    if (std::none_of(dense.p_W.begin(), dense.p_W.end(),
                     [&](const Vec3& p) { return Over(zone.shape, p); })) {
      exclude(zone.shape);
    }
  }
  // One rally point: the mission's home (MissionSpec.home), where every way
  // home ends; without one, where the path starts, a point known to be
  // clear.
  const GeoPoint start = frame.ToGeo(config.planner.home.has_value() ? config.planner.home->home_W
                                                                     : traj.Position(0.0));
  const nlohmann::json plan = {
      {"fileType", "Plan"},
      {"version", 1},
      {"groundStation", "oaipp"},
      {"mission", std::move(mission)},
      {"geoFence",
       {{"version", 2}, {"polygons", std::move(polygons)}, {"circles", std::move(circles)}}},
      {"rallyPoints",
       {{"version", 2},
        {"points", nlohmann::json::array({{start.latitude_deg, start.longitude_deg,
                                           start.altitude_m - home.altitude_m}})}}}};
  out.set_qgc_plan_json(plan.dump(2));
  return out;
}

}  // namespace oaipp::api

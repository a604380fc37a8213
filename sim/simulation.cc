#include "sim/simulation.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "api/limits.h"
#include "api/spec.h"
#include "core/common/status_macros.h"

namespace oaipp::sim {
namespace {

// A person's (and a false positive's) size on the ground, metres.
constexpr double kPersonWidth_m = 0.75;
constexpr double kPersonLength_m = 2.0;

// Projects a ground point into a downward camera at p (yaw 0) with pinhole
// intrinsics K; false when behind the camera.
bool Project(const CameraIntrinsics& k, const Vec3& camera_W, const Vec3& point_W, Vec2* px) {
  const Eigen::Matrix3d r_wc = RotationWorldFromCamera(0.0);
  const Vec3 p_c = r_wc.transpose() * (point_W - camera_W);
  if (p_c.z() <= 1e-9) return false;
  *px = Vec2(k.fx_px * p_c.x() / p_c.z() + k.cx_px, k.fy_px * p_c.y() / p_c.z() + k.cy_px);
  return true;
}

}  // namespace

double DetectorParams::DetectionProbability(double altitude_m) const {
  const double z = (altitude_m - h_best_m) / width_m;
  return p_max * std::exp(-0.5 * z * z);
}

double DetectorParams::FalsePositiveRate(double altitude_m) const {
  return fp_per_image_at_10m * (altitude_m / 10.0) * (altitude_m / 10.0);
}

absl::StatusOr<Simulation> Simulation::Create(const v1::Scenario& scenario) {
  Simulation sim;
  OAIPP_ASSIGN_OR_RETURN(sim.config_, api::MissionSpecToConfig(scenario.mission()));
  const api::MissionConfig& c = sim.config_;
  OAIPP_ASSIGN_OR_RETURN(Environment env, c.MakeEnvironment());
  sim.env_ = std::make_shared<Environment>(std::move(env));
  OAIPP_ASSIGN_OR_RETURN(FieldGrid grid, c.MakeGrid());
  sim.grid_ = std::make_shared<FieldGrid>(grid);
  // The camera's images have the size the server assumes when a
  // measurement carries no intrinsics.
  OAIPP_ASSIGN_OR_RETURN(sim.intrinsics_, c.DefaultIntrinsics());
  for (const api::TeamMember& member : c.team) {
    OAIPP_ASSIGN_OR_RETURN(sim.member_intrinsics_[member.uav_id],
                           c.DefaultIntrinsics(member.uav_id));
  }
  const v1::DetectorModel& d = scenario.detector();
  DetectorParams& p = sim.detector_;
  if (d.has_p_max()) p.p_max = d.p_max();
  if (d.has_h_best_m()) p.h_best_m = d.h_best_m();
  if (d.has_width_m()) p.width_m = d.width_m();
  if (d.has_fp_per_image_at_10m()) p.fp_per_image_at_10m = d.fp_per_image_at_10m();
  if (d.has_min_confidence()) p.min_confidence = d.min_confidence();
  if (!(p.p_max >= 0 && p.p_max <= 1)) {
    return absl::InvalidArgumentError("detector.p_max: must be in [0, 1]");
  }
  if (!(p.width_m > 0) || !std::isfinite(p.width_m) || !std::isfinite(p.h_best_m)) {
    return absl::InvalidArgumentError(
        "detector.width_m, detector.h_best_m: must be finite, width > 0");
  }
  if (!(p.fp_per_image_at_10m >= 0 && p.fp_per_image_at_10m <= kMaxFalsePositivesAt10m)) {
    return absl::InvalidArgumentError(absl::StrCat("detector.fp_per_image_at_10m: must be in [0, ",
                                                   kMaxFalsePositivesAt10m, "], got ",
                                                   p.fp_per_image_at_10m));
  }
  if (!(p.min_confidence >= 0 && p.min_confidence <= 1)) {
    return absl::InvalidArgumentError("detector.min_confidence: must be in [0, 1]");
  }
  sim.truth_.assign(static_cast<std::size_t>(grid.num_cells()), 0.0);
  for (int i = 0; i < scenario.targets_size(); ++i) {
    const v1::Target& t = scenario.targets(i);
    const std::string field = absl::StrCat("targets[", i, "]");
    if (!(t.x_max_m() > t.x_min_m()) || !(t.y_max_m() > t.y_min_m())) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": max must exceed min"));
    }
    std::vector<int> cells =
        grid.CellsOverlapping({t.x_min_m(), t.y_min_m()}, {t.x_max_m(), t.y_max_m()});
    if (cells.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": lies outside the field"));
    }
    for (int cell : cells) sim.truth_[static_cast<std::size_t>(cell)] = 1.0;
    sim.targets_.push_back(t);
    sim.target_cells_.push_back(std::move(cells));
  }
  return sim;
}

const CameraIntrinsics& Simulation::intrinsics(const std::string& uav_id) const {
  const auto it = member_intrinsics_.find(uav_id);
  return it == member_intrinsics_.end() ? intrinsics_ : it->second;
}

std::vector<PixelBox> Simulation::Detect(const Vec3& p_W, std::mt19937_64& rng,
                                         std::vector<TargetSightings>* sightings,
                                         const std::string& uav_id) const {
  const CameraIntrinsics& image = intrinsics(uav_id);
  if (sightings != nullptr) sightings->resize(targets_.size());
  std::vector<PixelBox> boxes;
  // A box clipped to the image edge can be left with no area: the rule every
  // box is held to (PixelBox::Validate) drops it, after its random draws, so
  // the stream does not depend on it.
  const auto keep_valid = [&](const PixelBox& box) {
    if (!box.Validate(&image).ok()) return false;
    boxes.push_back(box);
    return true;
  };
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double h = p_W.z();
  for (std::size_t i = 0; i < targets_.size(); ++i) {
    const v1::Target& t = targets_[i];
    const Vec3 centre(0.5 * (t.x_min_m() + t.x_max_m()), 0.5 * (t.y_min_m() + t.y_max_m()), 0.0);
    const double draw = unit(rng);  // drawn for every target: one stream whatever is visible
    if (!env_->IsVisible(p_W, centre)) continue;
    Vec2 lo(1e18, 1e18), hi(-1e18, -1e18);
    bool in_front = true;
    for (double x : {t.x_min_m(), t.x_max_m()}) {
      for (double y : {t.y_min_m(), t.y_max_m()}) {
        Vec2 px;
        in_front &= Project(image, p_W, Vec3(x, y, 0), &px);
        lo = lo.cwiseMin(px);
        hi = hi.cwiseMax(px);
      }
    }
    Vec2 c;
    if (!in_front || !Project(image, p_W, centre, &c)) continue;
    if (c.x() < 0 || c.y() < 0 || c.x() > image.width_px || c.y() > image.height_px) continue;
    if (sightings != nullptr) ++(*sightings)[i].in_view;
    if (draw >= detector_.DetectionProbability(h)) continue;
    lo = lo.cwiseMax(Vec2(0, 0));
    hi = hi.cwiseMin(Vec2(image.width_px, image.height_px));
    if (keep_valid({lo.x(), lo.y(), hi.x(), hi.y(), 0.5 + 0.5 * unit(rng)}) && sightings != nullptr)
      ++(*sightings)[i].detected;
  }
  // The server takes at most api::kMaxBoxes boxes an image; a mean far
  // above that (a high camera) would only draw boxes to be refused.
  std::poisson_distribution<int> false_positives(
      std::min(detector_.FalsePositiveRate(h), static_cast<double>(api::kMaxBoxes)));
  const int n = false_positives(rng);
  // A person's size in pixels at this altitude.
  const double w = image.fx_px * kPersonWidth_m / h, l = image.fy_px * kPersonLength_m / h;
  for (int i = 0; i < n; ++i) {
    const double x = unit(rng) * std::max(1.0, image.width_px - w),
                 y = unit(rng) * std::max(1.0, image.height_px - l);
    (void)keep_valid({x, y, std::min<double>(x + w, image.width_px),
                      std::min<double>(y + l, image.height_px), 0.5 + 0.5 * unit(rng)});
  }
  return boxes;
}

absl::StatusOr<CellLabels> Simulation::Labels(const Vec3& p_W, const std::vector<PixelBox>& boxes,
                                              const std::string& uav_id) const {
  return DetectionsToLabels(*grid_, intrinsics(uav_id), CameraPose{p_W, 0.0}, boxes,
                            detector_.min_confidence, env_.get());
}

CellLabels Simulation::TruthLabels(const Vec3& p_W) const {
  CellLabels out;
  out.cells = config_.camera.VisibleFootprintCells(*grid_, p_W, env_.get());
  out.labels.reserve(out.cells.size());
  for (int c : out.cells) out.labels.push_back(truth_[static_cast<std::size_t>(c)]);
  return out;
}

double Simulation::Rse(const std::vector<double>& mean) const {
  double sum = 0.0;
  for (std::size_t i = 0; i < truth_.size() && i < mean.size(); ++i) {
    sum += (mean[i] - truth_[i]) * (mean[i] - truth_[i]);
  }
  return std::sqrt(sum);
}

double Simulation::Rmse(const std::vector<double>& mean) const {
  return Rse(mean) / std::sqrt(static_cast<double>(truth_.size()));
}

std::vector<bool> Simulation::FoundEach(const std::vector<double>& mean) const {
  std::vector<bool> found;
  for (double m : TargetMeans(mean)) found.push_back(m > 0.5);
  return found;
}

std::vector<double> Simulation::TargetMeans(const std::vector<double>& mean) const {
  std::vector<double> out;
  out.reserve(target_cells_.size());
  for (const std::vector<int>& cells : target_cells_) {
    double best = -std::numeric_limits<double>::infinity();
    for (int c : cells) {
      // NaN compares false: such a cell is left out.
      if (static_cast<std::size_t>(c) < mean.size() && mean[static_cast<std::size_t>(c)] > best)
        best = mean[static_cast<std::size_t>(c)];
    }
    out.push_back(best);
  }
  return out;
}

int Simulation::TargetsFound(const std::vector<double>& mean) const {
  const std::vector<bool> found = FoundEach(mean);
  return static_cast<int>(std::count(found.begin(), found.end(), true));
}

std::vector<std::string> Simulation::TargetIds() const {
  std::vector<std::string> ids;
  for (std::size_t i = 0; i < targets_.size(); ++i) {
    ids.push_back(targets_[i].id().empty() ? absl::StrCat("target ", i + 1) : targets_[i].id());
  }
  return ids;
}

std::vector<std::pair<Vec2, Vec2>> Simulation::TargetRectangles() const {
  std::vector<std::pair<Vec2, Vec2>> out;
  for (const v1::Target& t : targets_) {
    out.emplace_back(Vec2(t.x_min_m(), t.y_min_m()), Vec2(t.x_max_m(), t.y_max_m()));
  }
  return out;
}

bool Simulation::Collides(const Vec3& p_W) const {
  return Collides(p_W, config_.planner.common.limits.uav_radius_m);
}

bool Simulation::Collides(const Vec3& p_W, double uav_radius_m) const {
  return !env_->flight_volume().Contains(p_W, 1e-9) ||
         env_->SignedDistance(p_W) < 0.5 * uav_radius_m;
}

double FalsePositivesPerCell(const DetectorParams& detector, const DownwardCamera& camera,
                             double resolution_m) {
  const double s = resolution_m;
  const Vec2 footprint_m = camera.FootprintSize(10.0);
  const double cells_per_box = (1.0 + kPersonWidth_m / s) * (1.0 + kPersonLength_m / s);
  const double cells_in_view = footprint_m.x() * footprint_m.y() / (s * s);
  // Box confidences are uniform on [0.5, 1]; those below min_confidence
  // are dropped.
  const double kept = std::clamp(2.0 * (1.0 - detector.min_confidence), 0.0, 1.0);
  return detector.fp_per_image_at_10m * kept * cells_per_box / cells_in_view;
}

absl::StatusOr<v1::Scenario> WithDetectorNoise(v1::Scenario scenario, bool with_false_positives) {
  const v1::DetectorModel& d = scenario.detector();
  const DetectorParams defaults;
  if (d.has_p_max() && !(d.p_max() > 0.0 && d.p_max() < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("detector.p_max: detector noise needs it in (0, 1), got ", d.p_max()));
  }
  v1::SensorSpec& sensor = *scenario.mutable_mission()->mutable_sensor();
  sensor.clear_noise_a_var();
  sensor.clear_noise_b_per_m();
  v1::DetectorNoise& noise = *sensor.mutable_detector_noise();
  noise.set_p_max(d.has_p_max() ? d.p_max() : defaults.p_max);
  noise.set_h_best_m(d.has_h_best_m() ? d.h_best_m() : defaults.h_best_m);
  noise.set_width_m(d.has_width_m() ? d.width_m() : defaults.width_m);
  noise.clear_false_positive_rate();
  // Every member of a team flies the scenario's one detector: its own
  // noise settings give way to the mission's (a member's camera stays its
  // own).
  for (v1::TeamMember& member : *scenario.mutable_mission()->mutable_team()) {
    member.mutable_sensor()->clear_noise_a_var();
    member.mutable_sensor()->clear_noise_b_per_m();
    member.mutable_sensor()->clear_detector_noise();
  }
  if (!with_false_positives) return scenario;
  DetectorParams params;
  if (d.has_fp_per_image_at_10m()) params.fp_per_image_at_10m = d.fp_per_image_at_10m();
  if (d.has_min_confidence()) params.min_confidence = d.min_confidence();
  if (!(params.fp_per_image_at_10m > 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("detector.fp_per_image_at_10m: a false-positive rate needs it positive, got ",
                     params.fp_per_image_at_10m));
  }
  if (!(params.min_confidence < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("detector.min_confidence: a false-positive rate needs it below 1, got ",
                     params.min_confidence));
  }
  OAIPP_ASSIGN_OR_RETURN(const api::MissionConfig config,
                         api::MissionSpecToConfig(scenario.mission()));
  const double q = FalsePositivesPerCell(params, config.camera, config.resolution_m);
  if (!(q < 1.0)) {
    return absl::InvalidArgumentError(absl::StrCat("detector.fp_per_image_at_10m: gives ", q,
                                                   " false positives a cell, must be below 1"));
  }
  noise.set_false_positive_rate(q);
  // A member with a camera of its own sees another share of an image's false
  // positives in each cell.
  for (std::size_t i = 0; i < config.team.size(); ++i) {
    const double own =
        FalsePositivesPerCell(params, config.team[i].kit.camera, config.resolution_m);
    if (own == q) continue;
    if (!(own < 1.0)) {
      return absl::InvalidArgumentError(absl::StrCat("detector.fp_per_image_at_10m: gives ", own,
                                                     " false positives a cell to ", "mission.team[",
                                                     i, "]'s camera, must be below 1"));
    }
    scenario.mutable_mission()
        ->mutable_team(static_cast<int>(i))
        ->mutable_sensor()
        ->mutable_detector_noise()
        ->set_false_positive_rate(own);
  }
  return scenario;
}

}  // namespace oaipp::sim

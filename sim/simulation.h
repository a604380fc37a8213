// The simulated world the client flies in: ground-truth targets, a
// simulated detector and the metrics of docs/method.md §10.3.
//
//   OAIPP_ASSIGN_OR_RETURN(Simulation sim, Simulation::Create(scenario));
//   std::vector<PixelBox> boxes = sim.Detect(camera_W, rng);   // what a camera sees
//   double rse = sim.Rse(map_mean);
#pragma once

#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "api/mission_config.h"
#include "core/environment/environment.h"
#include "core/mapping/detection_projection.h"
#include "core/mapping/field_grid.h"
#include "oaipp/v1/scenario.pb.h"

namespace oaipp::sim {

// Most false positives per image at 10 m a scenario may ask for: a
// detector that sees 100 people who are not there in every image.
inline constexpr double kMaxFalsePositivesAt10m = 100.0;

struct DetectorParams {
  double p_max = 0.95;
  double h_best_m = 10.0;
  double width_m = 7.0;
  double fp_per_image_at_10m = 0.3;
  double min_confidence = 0.5;
  // p(h) of detecting a visible target from altitude h.
  [[nodiscard]] double DetectionProbability(double altitude_m) const;
  // Mean number of false positives in one image from altitude h.
  [[nodiscard]] double FalsePositiveRate(double altitude_m) const;
};

// How often the camera had a target in view and how often the detector
// reported it: what tells a target never seen from one seen and missed.
struct TargetSightings {
  int in_view = 0;   // visible and its centre inside the image
  int detected = 0;  // of those, reported by the detector
};

class Simulation {
 public:
  // Validates the scenario (targets inside the field, detector ranges) and
  // builds the exact world for visibility. InvalidArgument naming the field.
  [[nodiscard]] static absl::StatusOr<Simulation> Create(const v1::Scenario& scenario);

  // The boxes a downward camera at p_W (yaw 0) reports: each visible target
  // (its centre in line of sight, inside the image) with probability p(h),
  // plus Poisson false positives of a person's size at random places.
  // When `sightings` is set (one entry per target, in scenario order), each
  // target in view counts one sighting there, and one detection when it is
  // reported; the random stream is the same either way.
  // `uav_id` names the team member whose camera takes the image ("": the
  // mission's camera).
  [[nodiscard]] std::vector<PixelBox> Detect(const Vec3& p_W, std::mt19937_64& rng,
                                             std::vector<TargetSightings>* sightings = nullptr,
                                             const std::string& uav_id = "") const;
  // What a perfect detector reports from p_W (yaw 0): the visible footprint
  // cells, labelled 1 where a target covers them and 0 elsewhere.
  [[nodiscard]] CellLabels TruthLabels(const Vec3& p_W) const;
  // Per-cell labels of the same detections over the visible image footprint.
  [[nodiscard]] absl::StatusOr<CellLabels> Labels(const Vec3& p_W,
                                                  const std::vector<PixelBox>& boxes,
                                                  const std::string& uav_id = "") const;

  // RSE = sqrt(sum (mu - truth)^2) and RMSE over the cells.
  [[nodiscard]] double Rse(const std::vector<double>& mean) const;
  [[nodiscard]] double Rmse(const std::vector<double>& mean) const;
  // Targets whose cells reach a map mean above 0.5: how many, and which (in
  // the scenario's order).
  [[nodiscard]] int TargetsFound(const std::vector<double>& mean) const;
  [[nodiscard]] std::vector<bool> FoundEach(const std::vector<double>& mean) const;
  // Per target (the scenario's order), the highest map mean over its cells:
  // what FoundEach compares with 0.5. Cells past the end of `mean` and NaN
  // means are left out; -infinity for a target with none left.
  [[nodiscard]] std::vector<double> TargetMeans(const std::vector<double>& mean) const;
  // The targets' ids in the scenario's order ("target <i>" when unnamed,
  // 1-based).
  [[nodiscard]] std::vector<std::string> TargetIds() const;
  // Closer than r_uav / 2 to an obstacle under the exact geometry, or
  // outside the flight volume; r_uav the mission's radius unless given.
  [[nodiscard]] bool Collides(const Vec3& p_W) const;
  [[nodiscard]] bool Collides(const Vec3& p_W, double uav_radius_m) const;

  [[nodiscard]] const api::MissionConfig& config() const { return config_; }
  // The images of `uav_id`'s camera (a team member's own field of view; "":
  // the mission's), of the size the server assumes for images sent without
  // intrinsics.
  [[nodiscard]] const CameraIntrinsics& intrinsics(const std::string& uav_id = "") const;
  [[nodiscard]] const DetectorParams& detector() const { return detector_; }
  [[nodiscard]] int num_targets() const { return static_cast<int>(target_cells_.size()); }
  [[nodiscard]] const Environment& environment() const { return *env_; }
  // The targets' ground rectangles (min, max corners), metres.
  [[nodiscard]] std::vector<std::pair<Vec2, Vec2>> TargetRectangles() const;

 private:
  Simulation() = default;
  api::MissionConfig config_;
  std::shared_ptr<Environment> env_;
  std::shared_ptr<FieldGrid> grid_;
  CameraIntrinsics intrinsics_;
  std::map<std::string, CameraIntrinsics> member_intrinsics_;  // by uav_id
  DetectorParams detector_;
  std::vector<v1::Target> targets_;
  std::vector<std::vector<int>> target_cells_;
  std::vector<double> truth_;
};

// The scenario with its mission fusing labels by the noise of the
// scenario's own detector (SensorSpec.detector_noise from
// DetectorModel's p_max, h_best_m and width_m, defaults as DetectorParams),
// in place of noise_a_var and noise_b_per_m: a ground station that knows its
// detector's accuracy curve tells the server. InvalidArgument naming
// detector.p_max when it is 0 or 1 (a scenario may have them; the noise
// needs p_max in (0, 1)).
//
// With with_false_positives, the mission also gets the detector's
// false-positive rate per cell (DetectorNoise.false_positive_rate), so that
// detections and misses are weighed by their likelihood ratios:
// FalsePositivesPerCell. InvalidArgument naming detector.fp_per_image_at_10m
// when it is 0, or detector.min_confidence when it is 1 (the rate must be
// positive). Without it any rate the scenario's mission gives is cleared.
// A team's members all take the detector's noise (their own noise settings
// are cleared); with with_false_positives, a member with a camera of its own
// gets the rate for that camera.
[[nodiscard]] absl::StatusOr<v1::Scenario> WithDetectorNoise(v1::Scenario scenario,
                                                             bool with_false_positives = false);

// The probability that a cell in view holding no one is labelled as a
// person: false positives per image times the cells one covers on average,
// over the cells in view. Both counts grow as h^2 (boxes are a person's size
// on the ground, 0.75 x 2 m, and overlap (1 + 0.75 / s)(1 + 2 / s) cells of
// edge s on average), so the rate is the same at every altitude:
// fp_per_image_at_10m k (1 + 0.75 / s)(1 + 2 / s) s^2 / (footprint area at 10 m),
// k = min(1, 2 (1 - min_confidence)) the share of boxes confident enough
// (confidences are uniform on [0.5, 1]). For the defaults (0.3 an image,
// min_confidence 0.5, s = 0.75 m, 45 x 60 deg): 0.01294. It leaves out boxes
// at the image's edge (which overlap cells out of view) and boxes
// overlapping each other, a few per cent (tests/sim/detector_test.cc).
[[nodiscard]] double FalsePositivesPerCell(const DetectorParams& detector,
                                           const DownwardCamera& camera, double resolution_m);

}  // namespace oaipp::sim

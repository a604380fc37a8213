// Parameters of the field map's Gaussian process and of the sensor noise
// (docs/method.md §3).
//
// The map's prior is a GP with an isotropic Matérn 3/2 kernel over the cell
// centres; a measurement taken from altitude h has noise variance
// var(h) = A (1 - exp(-B h)): higher is noisier; or, per mission, a variance
// from the detector's accuracy at h (DetectorAccuracy).
//
//   GpParams gp = GpParams::PaperPreset(/*resolution_m=*/0.75);  // l = 2.752 m
//   double k = Matern32(/*distance_m=*/1.5, gp.length_scale_m, gp.signal_var);
//   double var = SensorNoise{}.Variance(/*altitude_m=*/10.0);     // 0.393469
#pragma once

#include <cmath>
#include <optional>

#include "absl/status/status.h"

namespace oaipp {

// Matérn 3/2 kernel k(d) = sf2 (1 + sqrt(3) d / l) exp(-sqrt(3) d / l)
// (docs/method.md §3). distance and length scale share one unit (metres in this
// project). Preconditions: distance >= 0, length_scale > 0.
[[nodiscard]] inline double Matern32(double distance_m, double length_scale_m, double signal_var) {
  const double r = std::sqrt(3.0) * distance_m / length_scale_m;
  return signal_var * (1.0 + r) * std::exp(-r);
}

// Hyper-parameters of the field map. The defaults are PaperPreset(0.75).
// Largest noise_var / signal_var a GpParams may have (see Validate).
inline constexpr double kMaxNoiseToSignal = 1e6;

struct GpParams {
  // Matérn length scale l, metres. Valid: > 0.
  double length_scale_m = 2.7519725007144333;
  // Kernel signal variance sf2 (label units squared). Valid: > 0.
  double signal_var = 1.8221188003905089;
  // Noise variance sn2 used only to build the prior P0 = K - K (K + sn2 I)^-1 K.
  // Valid: > 0 (sn2 = 0 would make P0 zero) and at most kMaxNoiseToSignal
  // x signal_var.
  double noise_var = 2.0137527074704766;
  // Prior mean mu0 of every cell: targets are sparse. Valid: finite.
  double prior_mean = 0.1;

  // The published code's hyper-parameters, which measure distances in cells
  // (docs/method.md §3): l = e^1.3 cells = e^1.3 * resolution_m metres
  // (2.751973 m at 0.75 m), sf2 = e^0.6, sn2 = e^0.7, mu0 = 0.1. The paper
  // prints {sn2, sf2, l} = {1.42, 1.82, 3.67}, but 1.42 = e^0.35 is sigma_n,
  // not its square, and 3.67 is in cells, not metres; read literally they
  // give a different prior (docs/reference-values.md).
  // Precondition: resolution_m > 0.
  [[nodiscard]] static GpParams PaperPreset(double resolution_m) {
    return {.length_scale_m = std::exp(1.3) * resolution_m,
            .signal_var = std::exp(0.6),
            .noise_var = std::exp(0.7),
            .prior_mean = 0.1};
  }

  // InvalidArgument naming the first bad field.
  [[nodiscard]] absl::Status Validate() const;
};

// A label at least this counts as a detection: the server's record of seen
// cells and, with a false-positive rate, the variance a label gets.
inline constexpr double kDetectedLabel = 0.5;

// Noise from the detector's own accuracy (docs/method.md §3.4): a person in
// view from altitude h is detected with probability
// p(h) = p_max exp(-((h - h_best) / width)^2 / 2). A label from there gets
// the variance (1 - p) / p, the one that label / p(h), an unbiased
// estimate of the person's presence, has for a cell holding one; the label
// itself is fused unscaled. Lowest at h_best and growing both above and
// below it, where the paper's model makes the lowest shots the most precise.
//
//   DetectorAccuracy d;                  // 0.95 at 10 m, width 7 m
//   double v = d.Variance(10.0);         // 0.05 / 0.95 = 0.0526
//   double w = d.Variance(17.0);         // p = 0.95 e^-0.5 = 0.5762: 0.7355
//
// With a false-positive rate q (the probability that a cell in view holding
// no person is labelled as one), the two labels get different variances
// instead: those under which a label moves a cell's log-odds of holding a
// person as much as the detector's hit and miss rates say. A Gaussian label
// y fused with variance v shifts that log-odds by (2 y - 1) / (2 v); the
// detector's likelihood ratios shift it by ln(p / q) for a detection and
// ln((1 - p) / (1 - q)) for a miss, so
//   v_detection = 1 / (2 ln(p / q)),  v_miss = 1 / (2 ln((1 - q) / (1 - p))).
// Where false positives are rarer than misses (q < 1 - p, for p > 1/2), a
// miss weighs less than a detection: one detection and one miss of a cell
// give the detection 62 % of the weight at 11.5 m with the simulated
// detector (q = 0.0129), where equal variances give each half.
//
//   d.false_positive_rate = 0.01;
//   double v_det = d.LabelVariance(10.0, 1.0);   // 1 / (2 ln 95) = 0.1098
//   double v_miss = d.LabelVariance(10.0, 0.0);  // 1 / (2 ln(0.99 / 0.05)) = 0.1675
struct DetectorAccuracy {
  // Detection probability at h_best_m. Valid: (0, 1).
  double p_max = 0.95;
  // Altitude of the best detection, metres. Valid: >= 0, finite.
  double h_best_m = 10.0;
  // Width of the accuracy curve, metres. Valid: > 0, finite.
  double width_m = 7.0;
  // Probability that a cell in view holding no person is labelled as one.
  // Unset: both labels get Variance(h). Valid: (0, 1).
  std::optional<double> false_positive_rate;

  // Largest variance returned, where p(h) all but vanishes: a label from
  // there changes nothing.
  static constexpr double kMaxVariance = 1e6;

  [[nodiscard]] double DetectionProbability(double altitude_m) const {
    const double z = (altitude_m - h_best_m) / width_m;
    return p_max * std::exp(-0.5 * z * z);
  }
  // The variance of a shot whose labels are not known yet (a planned one):
  // (1 - p) / p, or with a false-positive rate the variance of a miss, the
  // label nearly every cell in view gets. NaN for a NaN altitude, as the
  // paper's model gives.
  [[nodiscard]] double Variance(double altitude_m) const { return LabelVariance(altitude_m, 0.0); }
  // The variance a label in [0, 1] is fused with: Variance(h) without a
  // false-positive rate; with one, v_detection for a label >= kDetectedLabel
  // and v_miss below. At most kMaxVariance, which is also what both labels get where
  // p(h) <= q: such a label tells a person from empty ground no better than
  // chance.
  [[nodiscard]] double LabelVariance(double altitude_m, double label) const;

  // InvalidArgument naming the first bad field.
  [[nodiscard]] absl::Status Validate() const;

  bool operator==(const DetectorAccuracy&) const = default;
};

// Altitude-dependent measurement noise var(h) = A (1 - exp(-B h))
// (docs/method.md §3; the paper's A = 1, B = 0.05), or, when `detector` is
// set, the detector's accuracy curve instead (DetectorAccuracy).
struct SensorNoise {
  // Saturation variance A, label units squared. Valid: > 0.
  double a_var = 1.0;
  // Growth rate B, per metre of altitude. Valid: > 0.
  double b_per_m = 0.05;
  // When set, replaces A and B. Off by default (the paper's model).
  std::optional<DetectorAccuracy> detector;

  // var(h) for a camera at altitude_m above the ground. Precondition:
  // altitude_m > 0 (callers check it: LabelsToObservations refuses other
  // altitudes, and the paper's var(0) = 0 is no valid observation variance).
  [[nodiscard]] double Variance(double altitude_m) const {
    if (detector.has_value()) return detector->Variance(altitude_m);
    return a_var * (1.0 - std::exp(-b_per_m * altitude_m));
  }
  // The variance a measured label is fused with: Variance(h), except for a
  // detector with a false-positive rate (DetectorAccuracy::LabelVariance).
  [[nodiscard]] double LabelVariance(double altitude_m, double label) const {
    if (detector.has_value()) return detector->LabelVariance(altitude_m, label);
    return Variance(altitude_m);
  }

  // InvalidArgument naming the first bad field.
  [[nodiscard]] absl::Status Validate() const;
};

}  // namespace oaipp

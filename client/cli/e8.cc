#include "client/cli/e8.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "api/limits.h"

namespace oaipp::client {
namespace {

constexpr absl::string_view kOaIpp = "OA-IPP";

// Mean and standard error of the mean (0 for fewer than two values).
struct MeanSe {
  double mean = 0.0;
  double se = 0.0;
};

MeanSe Summarise(const std::vector<double>& values) {
  MeanSe out;
  if (values.empty()) return out;
  for (const double v : values) out.mean += v;
  out.mean /= static_cast<double>(values.size());
  if (values.size() < 2) return out;
  double ss = 0.0;
  for (const double v : values) ss += (v - out.mean) * (v - out.mean);
  out.se =
      std::sqrt(ss / static_cast<double>(values.size() - 1) / static_cast<double>(values.size()));
  return out;
}

double Metric(const sarenv::PathMetrics& m, int which) {
  switch (which) {
    case 0:
      return m.likelihood;
    case 1:
      return m.time_discounted;
    case 2:
      return m.victims_found_pct;
    default:
      return m.area_covered_km2;
  }
}

}  // namespace

absl::StatusOr<v1::Scenario> E8Scenario(const sarenv::SearchArea& area, int agents, double budget_m,
                                        const E8Settings& settings) {
  if (agents < 1 || agents > api::kMaxTeam) {
    return absl::InvalidArgumentError(absl::StrCat("agents: must lie in [1, ", api::kMaxTeam, "]"));
  }
  if (!(budget_m > 0) || !std::isfinite(budget_m)) {
    return absl::InvalidArgumentError("budget_m: must be > 0 and finite");
  }
  const double cell = area.CellSizeX_m();
  if (area.heatmap.rows != area.heatmap.cols || area.heatmap.rows < 1 ||
      !(std::abs(cell - area.CellSizeY_m()) < 1e-9) || !(cell > 0)) {
    return absl::InvalidArgumentError(
        "area: E8 flies a square crop of square cells (a disc's bounding square)");
  }
  if (!(settings.altitude_m > 2) || !(settings.max_speed_m_s > 0) ||
      !(settings.shot_spacing_m > 0) || !(settings.discount_per_m > 0) ||
      !(settings.discount_per_m <= 1) || !(settings.team_spacing_m > 0)) {
    return absl::InvalidArgumentError(
        "settings: altitude > 2 m, speed and shot spacing > 0, discount in (0, 1], team spacing "
        "> 0");
  }
  // The grid's cell to a nanometre: the crop's extent over its shape is
  // 30 m up to rounding, and the service wants a whole number of cells.
  const double resolution = std::round(cell * 1e9) / 1e9;
  const double half = 0.5 * resolution * static_cast<double>(area.heatmap.cols);

  v1::Scenario scenario;
  scenario.set_name(absl::StrCat("e8-", area.name, "-n", agents));
  scenario.set_seed(settings.seed);
  scenario.set_send_cell_labels(true);
  // A little past each UAV's share: the runner counts the 3-D path, the
  // benchmark its 2-D shadow (altitude changes within the band), and the
  // path is cut to the share exactly when it is scored.
  scenario.set_path_budget_m(budget_m / agents * 1.02);
  scenario.set_final_map_only(true);
  scenario.mutable_detector()->set_fp_per_image_at_10m(0.0);

  v1::MissionSpec& m = *scenario.mutable_mission();
  v1::FieldSpec& field = *m.mutable_field();
  field.set_x_min_m(-half);
  field.set_y_min_m(-half);
  field.set_x_max_m(half);
  field.set_y_max_m(half);
  field.set_resolution_m(resolution);
  field.set_map_backend(v1::MAP_BACKEND_SPARSE);
  m.mutable_gp()->set_length_scale_m(settings.length_scale_m);
  v1::PriorMap& prior = *m.mutable_gp()->mutable_prior_map();
  prior.set_units(v1::PRIOR_MAP_UNITS_PROBABILITY);
  prior.mutable_values()->Assign(area.heatmap.values.begin(), area.heatmap.values.end());
  // A camera that sees whoever is in view (the benchmark's): label noise
  // far below the prior's variance, so a shot clears what it saw.
  v1::SensorSpec& sensor = *m.mutable_sensor();
  sensor.set_fov_x_deg(settings.fov_deg);
  sensor.set_fov_y_deg(settings.fov_deg);
  sensor.set_noise_a_var(1e-3);
  sensor.set_noise_b_per_m(0.05);
  sensor.set_rate_hz(settings.max_speed_m_s / settings.shot_spacing_m);
  v1::FlightSpec& flight = *m.mutable_flight();
  flight.set_min_altitude_m(settings.altitude_m - 2.0);
  flight.set_max_altitude_m(settings.altitude_m + 2.0);
  flight.set_max_speed_m_s(settings.max_speed_m_s);
  flight.set_max_accel_m_s2(settings.max_accel_m_s2);
  flight.set_esdf_voxel_m(2.0);  // no obstacles: the voxel only sizes the empty grid's table
  // Time is not what the benchmark budgets: enough never to bind before
  // the path budget at a third of full speed on average.
  m.set_budget_s(budget_m / agents / (settings.max_speed_m_s / 3.0) + 60.0);
  v1::PlannerSpec& planner = *m.mutable_planner();
  planner.set_kind(v1::PLANNER_KIND_OAIPP_DETECTION);
  planner.set_seed(settings.seed);
  planner.set_num_waypoints(settings.num_waypoints);
  planner.set_h_sat_m(10.0 * settings.altitude_m);
  planner.set_detection_discount(std::pow(settings.discount_per_m, settings.shot_spacing_m));
  const auto start_at = [&](double x) {
    v1::UavState s;
    s.mutable_position_m()->set_x(x);
    s.mutable_position_m()->set_y(0.0);
    s.mutable_position_m()->set_z(settings.altitude_m);
    return s;
  };
  if (agents == 1) {
    *m.mutable_start() = start_at(0.0);
  } else {
    for (int k = 0; k < agents; ++k) {
      v1::TeamMember& member = *m.add_team();
      member.set_uav_id(absl::StrCat("uav-", k + 1));
      *member.mutable_start() = start_at(settings.team_spacing_m * (k - 0.5 * (agents - 1)));
    }
  }
  return scenario;
}

std::vector<sarenv::Polyline> FlownPathsInCrs(const RunResult& run,
                                              const sarenv::SearchArea& area) {
  std::vector<sarenv::Polyline> paths;
  for (const UavRecord& uav : run.uavs) {
    sarenv::Polyline line;
    line.reserve(uav.flown_path_W.size());
    for (const Vec3& p : uav.flown_path_W) {
      line.push_back({p.x() + area.center_x_m, p.y() + area.center_y_m});
    }
    paths.push_back(std::move(line));
  }
  return paths;
}

std::string E8Csv(const std::vector<E8Row>& rows) {
  std::string csv =
      "dataset,algorithm,n_agents,budget_m,likelihood,time_discounted,victims_found_pct,"
      "area_covered_km2,total_path_length_km,plans,planning_s,flight_wall_s\n";
  for (const E8Row& r : rows) {
    absl::StrAppendFormat(&csv, "%s,%s,%d,%.0f,%.17g,%.17g,%.17g,%.17g,%.17g,%d,%.3f,%.3f\n",
                          r.dataset, r.algorithm, r.agents, r.budget_m, r.metrics.likelihood,
                          r.metrics.time_discounted, r.metrics.victims_found_pct,
                          r.metrics.area_covered_km2, r.metrics.total_path_length_km, r.plans,
                          r.planning_s, r.flight_wall_s);
  }
  return csv;
}

std::string E8SummaryMarkdown(const std::vector<E8Row>& rows) {
  // (agents, budget) -> algorithm -> dataset -> row, algorithms in the
  // order first seen.
  using ByDataset = std::map<std::string, const E8Row*>;
  std::map<std::pair<int, double>, std::map<std::string, ByDataset>> groups;
  std::vector<std::string> order;
  for (const E8Row& r : rows) {
    groups[{r.agents, r.budget_m}][r.algorithm][r.dataset] = &r;
    if (std::find(order.begin(), order.end(), r.algorithm) == order.end())
      order.push_back(r.algorithm);
  }
  // OA-IPP minus `base` in metric `which` over the datasets both have.
  struct Pairs {
    MeanSe diff;
    double own = 0.0;   // OA-IPP's mean over those datasets
    double base = 0.0;  // the baseline's
    int count = 0;
  };
  const auto paired = [](const ByDataset& own, const ByDataset& base, int which) {
    std::vector<double> d, a, b;
    for (const auto& [dataset, row] : own) {
      const auto it = base.find(dataset);
      if (it == base.end()) continue;
      a.push_back(Metric(row->metrics, which));
      b.push_back(Metric(it->second->metrics, which));
      d.push_back(a.back() - b.back());
    }
    return Pairs{.diff = Summarise(d),
                 .own = Summarise(a).mean,
                 .base = Summarise(b).mean,
                 .count = static_cast<int>(d.size())};
  };
  std::string md;
  for (const auto& [key, by_algorithm] : groups) {
    const auto [agents, budget] = key;
    absl::StrAppendFormat(&md, "### n = %d, %.0f km in all\n\n", agents, budget / 1000.0);
    md += "| algorithm | datasets | likelihood | time-discounted | victims found % | area km^2 |\n";
    md += "| --- | --- | --- | --- | --- | --- |\n";
    for (const std::string& algorithm : order) {
      const auto it = by_algorithm.find(algorithm);
      if (it == by_algorithm.end()) continue;
      absl::StrAppendFormat(&md, "| %s | %d |", algorithm, it->second.size());
      for (int which = 0; which < 4; ++which) {
        std::vector<double> v;
        for (const auto& [dataset, row] : it->second) v.push_back(Metric(row->metrics, which));
        const MeanSe s = Summarise(v);
        absl::StrAppendFormat(&md, which == 1 ? " %.5f +- %.5f |" : " %.4f +- %.4f |", s.mean,
                              1.96 * s.se);
      }
      md += "\n";
    }
    const auto oa = by_algorithm.find(std::string(kOaIpp));
    if (oa == by_algorithm.end()) {
      md += "\n";
      continue;
    }
    md +=
        "\nOA-IPP minus each baseline, paired by dataset: mean difference (its standard error, "
        "the mean in standard errors; n/a below two pairs):\n\n";
    md += "| baseline | likelihood | time-discounted | victims found % | area km^2 |\n";
    md += "| --- | --- | --- | --- | --- |\n";
    // The z of a pairing, or NaN when it has no spread to measure it by.
    const auto z_of = [](const Pairs& p) {
      return p.count >= 2 && p.diff.se > 0 ? p.diff.mean / p.diff.se : std::nan("");
    };
    for (const std::string& algorithm : order) {
      if (algorithm == kOaIpp) continue;
      const auto base = by_algorithm.find(algorithm);
      if (base == by_algorithm.end()) continue;
      absl::StrAppendFormat(&md, "| %s |", algorithm);
      for (int which = 0; which < 4; ++which) {
        const Pairs p = paired(oa->second, base->second, which);
        const double z = z_of(p);
        if (std::isnan(z)) {
          absl::StrAppendFormat(&md, " n/a |");
        } else {
          absl::StrAppendFormat(&md,
                                which == 1 ? " %+.5f (%.5f, %+.1f) |" : " %+.4f (%.4f, %+.1f) |",
                                p.diff.mean, p.diff.se, z);
        }
      }
      md += "\n";
    }
    // E8's targets (docs/experiments.md), each over the datasets both sides have.
    const auto target = [&](const std::string& baseline, int which, absl::string_view what) {
      const auto base = by_algorithm.find(baseline);
      if (base == by_algorithm.end()) return absl::StrCat(what, " above ", baseline, ": n/a");
      const double z = z_of(paired(oa->second, base->second, which));
      if (std::isnan(z)) return absl::StrCat(what, " above ", baseline, ": n/a");
      return absl::StrFormat("%s above %s by %.1f SE (> 2: %s)", what, baseline, z,
                             z > 2 ? "met" : "not met");
    };
    Pairs best;
    std::string best_name;
    for (const std::string& algorithm : order) {
      const auto base = by_algorithm.find(algorithm);
      if (algorithm == kOaIpp || base == by_algorithm.end()) continue;
      const Pairs p = paired(oa->second, base->second, 2);
      if (p.count > 0 && (best_name.empty() || p.base > best.base)) {
        best = p;
        best_name = algorithm;
      }
    }
    int short_rows = 0;
    for (const auto& [dataset, row] : oa->second) short_rows += row->short_of_budget ? 1 : 0;
    absl::StrAppendFormat(&md, "\nTargets: %s; %s; ", target("Greedy", 1, "time-discounted"),
                          target("Spiral", 0, "likelihood"));
    if (best_name.empty()) {
      md += "victims found: n/a.\n";
    } else {
      absl::StrAppendFormat(&md, "victims found %.1f %% against %s's %.1f %% (%s).\n", best.own,
                            best_name, best.base, best.own >= best.base ? "met" : "not met");
    }
    if (short_rows > 0) {
      absl::StrAppendFormat(&md, "%d OA-IPP flight(s) ended short of the budget.\n", short_rows);
    }
    md += "\n";
  }
  return md;
}

}  // namespace oaipp::client

#include "client/cli/team_evaluation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "api/spec.h"

namespace oaipp::client {
namespace {

constexpr double kNeverFound = std::numeric_limits<double>::infinity();

// The q-quantile (0..1) of `values` by the nearest rank; NaN when empty.
double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::clamp<std::size_t>(rank, 1, values.size()) - 1];
}

// A time to find everyone: "> budget" when the trial never did.
std::string Seconds(double t, double budget_s) {
  if (std::isnan(t)) return "-";
  if (std::isinf(t)) return absl::StrFormat("> %.0f", budget_s);
  return absl::StrFormat("%.1f", t);
}

// What one variant's trials add up to.
struct VariantStats {
  int uavs = 1;
  int trials = 0, failed = 0, all_found = 0, violations = 0;
  std::vector<double> times_s;    // to find everyone; kNeverFound when never
  std::vector<double> latencies;  // every plan's
  double closest_m = kNeverFound;
  // Mean and standard error of the times with never counted at the budget.
  double mean_s = 0.0, se_s = 0.0;
};

}  // namespace

absl::StatusOr<std::vector<Variant>> TeamVariants(const std::vector<v1::Scenario>& scenarios) {
  std::vector<Variant> variants;
  std::set<int> sizes;
  for (const v1::Scenario& base : scenarios) {
    const int n = std::max(1, base.mission().team_size());
    if (!sizes.insert(n).second) {
      return absl::InvalidArgumentError(
          absl::StrCat("eval E7: two scenarios have a team of ", n, " UAVs"));
    }
    // mode 0: coordinated; 1: shared map without pending shots; 2: alone.
    for (int mode = 0; mode < (n > 1 ? 3 : 1); ++mode) {
      const std::string label =
          absl::StrCat("team", n, mode == 1 ? "-noshots" : (mode == 2 ? "-alone" : ""));
      variants.push_back({label, [base, mode](int trial) {
                            v1::Scenario s = base;
                            s.set_seed(static_cast<std::uint64_t>(trial));
                            v1::PlannerSpec* planner = s.mutable_mission()->mutable_planner();
                            planner->set_kind(v1::PLANNER_KIND_OAIPP);
                            planner->set_seed(static_cast<std::uint32_t>(trial));
                            if (mode == 1) s.mutable_mission()->set_count_teammate_shots(false);
                            if (mode == 2) s.set_separate_maps(true);
                            return absl::StatusOr<v1::Scenario>(std::move(s));
                          }});
    }
  }
  return variants;
}

std::string TeamSummaryMarkdown(const EvalResult& result, double budget_s) {
  std::vector<std::string> order;
  std::map<std::string, VariantStats> stats;
  for (const TrialResult& t : result.trials) {
    if (!stats.contains(t.variant)) order.push_back(t.variant);
    VariantStats& v = stats[t.variant];
    ++v.trials;
    if (!t.error.empty() || t.steps.empty()) {
      ++v.failed;
      continue;
    }
    v.uavs = t.uavs;
    v.all_found += t.all_found_s >= 0.0;
    v.times_s.push_back(t.all_found_s >= 0.0 ? t.all_found_s : kNeverFound);
    v.latencies.insert(v.latencies.end(), t.plan_latencies_s.begin(), t.plan_latencies_s.end());
    v.closest_m = std::min(v.closest_m, t.closest_approach_m);
    v.violations += t.separation_violations;
  }
  std::string md = absl::StrFormat(
      "| variant | UAVs | trials | failed | found everyone | time to find everyone, median s | "
      "mean +- std error s (never = %.0f) | plan s p50 | p95 | max | closest approach m | "
      "separation violations |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
      budget_s);
  for (const std::string& name : order) {
    VariantStats& v = stats[name];
    double sum = 0.0, sum2 = 0.0;
    for (double t : v.times_s) {
      const double c = std::min(t, budget_s);
      sum += c;
      sum2 += c * c;
    }
    const auto n = static_cast<double>(v.times_s.size());
    v.mean_s = n > 0 ? sum / n : 0.0;
    v.se_s = n > 1 ? std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / (n - 1)) / n) : 0.0;
    absl::StrAppendFormat(
        &md, "| %s | %d | %d | %d | %d | %s | %.1f +- %.1f | %.3f | %.3f | %.3f | %s | %d |\n",
        name, v.uavs, v.trials, v.failed, v.all_found, Seconds(Quantile(v.times_s, 0.5), budget_s),
        v.mean_s, v.se_s, Quantile(v.latencies, 0.5), Quantile(v.latencies, 0.95),
        Quantile(v.latencies, 1.0),
        v.uavs > 1 && std::isfinite(v.closest_m) ? absl::StrFormat("%.2f", v.closest_m) : "-",
        v.violations);
  }
  // Per team size: efficiency against one UAV and coordinated against the
  // baselines.
  absl::StrAppend(&md,
                  "\n| UAVs | team efficiency T1 / (N TN) | sooner than noshots, s (in std errors) "
                  "| sooner than alone, s (in std errors) |\n| --- | --- | --- | --- |\n");
  const double t1 = stats.contains("team1") ? Quantile(stats["team1"].times_s, 0.5) : std::nan("");
  const auto sooner = [&](const VariantStats& team, const std::string& other) -> std::string {
    if (!stats.contains(other)) return "-";
    const VariantStats& o = stats[other];
    const double d = o.mean_s - team.mean_s;
    const double se = std::hypot(o.se_s, team.se_s);
    return se > 0.0 ? absl::StrFormat("%.1f (%.1f)", d, d / se) : absl::StrFormat("%.1f", d);
  };
  for (const std::string& name : order) {
    const VariantStats& v = stats[name];
    if (v.uavs < 2 || name != absl::StrCat("team", v.uavs)) continue;
    const double tn = Quantile(v.times_s, 0.5);
    std::string efficiency = "-";
    if (std::isfinite(t1) && std::isfinite(tn) && tn > 0.0) {
      efficiency = absl::StrFormat("%.2f", t1 / (v.uavs * tn));
    } else if (!std::isnan(t1) && std::isfinite(tn) && tn > 0.0) {
      efficiency = absl::StrFormat("> %.2f", budget_s / (v.uavs * tn));  // T1 beyond the budget
    }
    absl::StrAppendFormat(&md, "| %d | %s | %s | %s |\n", v.uavs, efficiency,
                          sooner(v, name + "-noshots"), sooner(v, name + "-alone"));
  }
  return md;
}

}  // namespace oaipp::client

// E7, the team experiment (docs/experiments.md): teams of several sizes in
// one world, each flown coordinated (one map, teammates' pending shots
// counted) and two ways without coordination: on the shared map without
// the pending shots, and each UAV alone on its own map. What it reports is
// the time until every person is found, team efficiency T1 / (N TN), plan
// latency and the closest two UAVs came.
//
//   OAIPP_ASSIGN_OR_RETURN(std::vector<Variant> v, TeamVariants({e5, e5_team2, e5_team4}));
//   EvalResult r = ...RunEvaluation(address, v, options, progress);
//   std::string md = TeamSummaryMarkdown(r, budget_s);
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/cli/evaluation.h"

namespace oaipp::client {

// For each scenario (its team's size N; a scenario without a team is
// N = 1): "team<N>" coordinated and, for N > 1, "team<N>-noshots" (the
// spec's count_teammate_shots false) and "team<N>-alone"
// (Scenario.separate_maps). Trial k flies seed k for the planner and the
// detector, OA-IPP, in every variant. InvalidArgument when two scenarios
// have the same team size.
[[nodiscard]] absl::StatusOr<std::vector<Variant>> TeamVariants(
    const std::vector<v1::Scenario>& scenarios);

// Two Markdown tables. Per variant: UAVs, trials, failed, trials that found
// everyone, the time to find everyone (median, and mean +- standard error
// with a trial that never did counted at the budget: a lower bound), plan
// latency (p50, p95, max over every plan), the closest approach and the
// separation violations. Per team size N > 1: team efficiency T1 / (N TN)
// on the medians (T1 of "team1"), and how much sooner coordinated planning
// found everyone than each baseline, in standard errors of the difference.
[[nodiscard]] std::string TeamSummaryMarkdown(const EvalResult& result, double budget_s);

}  // namespace oaipp::client

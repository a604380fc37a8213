#include "client/cli/evaluation.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <mutex>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "api/spec.h"
#include "sim/simulation.h"

namespace oaipp::client {
namespace {

struct Moments {
  double n = 0, sum = 0, sum2 = 0;
  void Add(double x) {
    ++n;
    sum += x;
    sum2 += x * x;
  }
  [[nodiscard]] double Mean() const { return n > 0 ? sum / n : 0.0; }
  [[nodiscard]] double Std() const {
    return n > 1 ? std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / (n - 1))) : 0.0;
  }
};

}  // namespace

std::vector<StepRecord> Resample(const std::vector<StepRecord>& steps,
                                 const std::vector<double>& grid_s) {
  // The value at t is the map after every measurement taken before t (so
  // t = 0 is the prior, and the end of the budget holds the final map).
  std::vector<StepRecord> out;
  std::size_t i = 0;
  for (double t : grid_s) {
    while (i + 1 < steps.size() && steps[i + 1].mission_time_s < t - 1e-9) ++i;
    StepRecord r = steps.empty() ? StepRecord{} : steps[i];
    r.mission_time_s = t;
    out.push_back(r);
  }
  return out;
}

std::vector<Variant> PlannerVariants(const v1::Scenario& scenario,
                                     const std::vector<PlannerKind>& planners) {
  std::vector<Variant> variants;
  for (PlannerKind kind : planners) {
    variants.push_back({PlannerKindName(kind), [scenario, kind](int trial) {
                          v1::Scenario s = scenario;
                          s.set_seed(static_cast<std::uint64_t>(trial));
                          v1::PlannerSpec* planner = s.mutable_mission()->mutable_planner();
                          planner->set_kind(api::PlannerKindToProto(kind));
                          planner->set_seed(static_cast<std::uint32_t>(trial));
                          return absl::StatusOr<v1::Scenario>(std::move(s));
                        }});
  }
  return variants;
}

Variant ConfirmationVariant(const v1::Scenario& scenario, const ConfirmationOptions& options) {
  Variant v = PlannerVariants(scenario, {PlannerKind::kOaIpp}).front();
  v.label = "oaipp_confirm";
  v.scenario = [oaipp = v.scenario, options](int trial) -> absl::StatusOr<v1::Scenario> {
    absl::StatusOr<v1::Scenario> s = oaipp(trial);
    if (s.ok()) {
      v1::PlannerSpec& planner = *s->mutable_mission()->mutable_planner();
      planner.set_confirmation_weight(options.weight);
      if (options.phase_s > 0.0) {
        planner.set_confirmation_phase_s(options.phase_s);
        if (options.phase_weight.has_value()) {
          planner.set_confirmation_phase_weight(*options.phase_weight);
        }
        if (options.ambiguity_margin.has_value()) {
          planner.set_ambiguity_margin(*options.ambiguity_margin);
        }
        if (options.second_look_weight > 0.0) {
          planner.set_second_look_weight(options.second_look_weight);
        }
        if (options.second_look_sharpness > 0.0) {
          planner.set_second_look_sharpness(options.second_look_sharpness);
        }
      }
    }
    return s;
  };
  return v;
}

absl::StatusOr<std::vector<Variant>> SelectVariants(std::vector<Variant> all,
                                                    const std::vector<std::string>& labels,
                                                    const std::string& flag) {
  if (labels.empty()) return all;
  std::vector<std::string> known;
  for (const Variant& v : all) known.push_back(v.label);
  for (std::size_t i = 0; i < labels.size(); ++i) {
    if (std::find(known.begin(), known.end(), labels[i]) == known.end()) {
      // The name comes from the command line: quote a bounded prefix.
      return absl::InvalidArgumentError(
          absl::StrCat(flag, ": no variant '", labels[i].substr(0, 40),
                       "' in this experiment (it has: ", absl::StrJoin(known, ", "), ")"));
    }
    if (std::find(labels.begin(), labels.begin() + static_cast<std::ptrdiff_t>(i), labels[i]) !=
        labels.begin() + static_cast<std::ptrdiff_t>(i)) {
      return absl::InvalidArgumentError(
          absl::StrCat(flag, ": variant '", labels[i], "' is named twice"));
    }
  }
  std::vector<Variant> kept;
  for (Variant& v : all) {
    if (std::find(labels.begin(), labels.end(), v.label) != labels.end()) {
      kept.push_back(std::move(v));
    }
  }
  return kept;
}

absl::StatusOr<EvalResult> RunEvaluation(const std::string& address,
                                         const std::vector<Variant>& variants,
                                         const EvalOptions& options,
                                         const std::function<void(int, int)>& progress) {
  if (options.trials < 1 || options.trials > kMaxTrials || options.parallel < 1 ||
      !(options.grid_s > 0) || options.first_trial < 1 || options.first_trial > kMaxFirstTrial) {
    return absl::InvalidArgumentError(absl::StrCat("eval: trials must lie in [1, ", kMaxTrials,
                                                   "], first_trial in [1, ", kMaxFirstTrial,
                                                   "], parallel and grid_s must be positive"));
  }
  if (variants.empty()) return absl::InvalidArgumentError("eval: no variants");
  if (!(options.plan_budget_s >= 0)) {
    return absl::InvalidArgumentError("eval: plan_budget_s must be >= 0");
  }
  struct Job {
    const Variant* variant;
    int trial;
  };
  std::vector<Job> jobs;
  for (int t = options.first_trial; t < options.first_trial + options.trials; ++t) {
    for (const Variant& v : variants) jobs.push_back({&v, t});
  }
  EvalResult result;
  result.trials.resize(jobs.size());
  absl::StatusOr<v1::Scenario> first = variants.front().scenario(options.first_trial);
  if (!first.ok()) return first.status();
  if (first->final_map_only()) {
    return absl::InvalidArgumentError(
        "final_map_only: eval's curves need the map after every shot; leave it unset");
  }
  const double budget =
      first->mission().has_budget_s() ? first->mission().budget_s() : api::MissionConfig{}.budget_s;
  for (double t = 0; t <= budget + 1e-9; t += options.grid_s) result.grid_s.push_back(t);

  std::atomic<std::size_t> next{0};
  std::atomic<int> done{0};
  std::mutex progress_mu;
  auto worker = [&] {
    // Checked by the caller; a file that went away meanwhile fails each call.
    absl::StatusOr<std::shared_ptr<grpc::Channel>> channel =
        Client::OpenChannel(address, options.client);
    Client client(
        channel.ok() ? *channel : grpc::CreateChannel(address, grpc::InsecureChannelCredentials()),
        options.client);
    for (std::size_t j = next++; j < jobs.size(); j = next++) {
      TrialResult& out = result.trials[j];
      out.variant = jobs[j].variant->label;
      out.trial = jobs[j].trial;
      absl::StatusOr<v1::Scenario> s = jobs[j].variant->scenario(jobs[j].trial);
      if (s.ok() && options.plan_budget_s > 0) s->set_planning_budget_s(options.plan_budget_s);
      absl::StatusOr<sim::Simulation> sim =
          s.ok() ? sim::Simulation::Create(*s) : absl::StatusOr<sim::Simulation>(s.status());
      absl::StatusOr<RunResult> run =
          sim.ok() ? RunScenario(client, *s, *sim) : absl::StatusOr<RunResult>(sim.status());
      if (run.ok()) {
        out.num_targets = sim->num_targets();
        out.target_ids = sim->TargetIds();
        out.found_at_end = run->found_at_end;
        out.sightings = run->sightings;
        out.sighting_log = std::move(run->sighting_log);
        out.steps = Resample(run->steps, result.grid_s);
        out.plans = run->plans;
        out.planning_time_s = run->planning_time_s;
        out.uavs = static_cast<int>(run->uavs.size());
        out.closest_approach_m = run->closest_approach_m;
        out.separation_violations = run->separation_violations;
        out.plan_latencies_s = std::move(run->plan_latencies_s);
        for (const StepRecord& step : run->steps) {
          if (out.num_targets > 0 && step.targets_found == out.num_targets) {
            out.all_found_s = step.mission_time_s - run->steps.front().mission_time_s;
            break;
          }
        }
        if (out.trial == options.first_trial) out.map_png = std::move(run->final_map_png);
      } else {
        out.error = std::string(run.status().message());
      }
      const int finished = ++done;
      std::lock_guard<std::mutex> lock(progress_mu);
      if (progress) progress(finished, static_cast<int>(jobs.size()));
    }
  };
  std::vector<std::thread> threads;
  for (int i = 0; i < options.parallel; ++i) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  return result;
}

std::string TrialsCsv(const EvalResult& result) {
  std::string csv = "variant,trial,time_s,rse,rmse,trace,targets_found,path_length_m,collisions\n";
  for (const TrialResult& t : result.trials) {
    for (const StepRecord& s : t.steps) {
      absl::StrAppendFormat(&csv, "%s,%d,%.1f,%.6f,%.6f,%.6f,%d,%.3f,%d\n", t.variant, t.trial,
                            s.mission_time_s, s.rse, s.rmse, s.trace, s.targets_found,
                            s.path_length_m, s.collisions);
    }
  }
  return csv;
}

std::string TargetsCsv(const EvalResult& result) {
  std::string csv = "variant,trial,target,in_view,detected,found\n";
  for (const TrialResult& t : result.trials) {
    const std::size_t n =
        std::min({t.target_ids.size(), t.sightings.size(), t.found_at_end.size()});
    for (std::size_t i = 0; i < n; ++i) {
      absl::StrAppendFormat(&csv, "%s,%d,%s,%d,%d,%d\n", t.variant, t.trial, t.target_ids[i],
                            t.sightings[i].in_view, t.sightings[i].detected,
                            t.found_at_end[i] ? 1 : 0);
    }
  }
  return csv;
}

std::string SightingsCsv(const EvalResult& result) {
  std::string csv = "variant,trial,target,time_s,altitude_m,detected,mean_after\n";
  for (const TrialResult& t : result.trials) {
    for (const SightingRecord& r : t.sighting_log) {
      if (r.target < 0 || static_cast<std::size_t>(r.target) >= t.target_ids.size()) continue;
      absl::StrAppendFormat(&csv, "%s,%d,%s,%.1f,%.2f,%d,%.4f\n", t.variant, t.trial,
                            t.target_ids[static_cast<std::size_t>(r.target)], r.mission_time_s,
                            r.altitude_m, r.detected ? 1 : 0, r.mean_after);
    }
  }
  return csv;
}

std::string SummaryMarkdown(const EvalResult& result, double budget_s) {
  std::vector<std::string> order;
  std::map<std::string, std::vector<const TrialResult*>> by_variant;
  for (const TrialResult& t : result.trials) {
    if (!by_variant.contains(t.variant)) order.push_back(t.variant);
    by_variant[t.variant].push_back(&t);
  }
  std::string md = absl::StrFormat(
      "| variant | trials | failed | RSE at 0 s | RSE at %.0f s (mean +- std) | std error | "
      "Tr(P) at %.0f s | targets found | all found | collisions | planning s / plan |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
      budget_s, budget_s);
  for (const std::string& name : order) {
    const std::vector<const TrialResult*>& trials = by_variant[name];
    Moments start, end, trace, found, per_plan;
    int failed = 0, collisions = 0, all_found = 0;
    for (const TrialResult* t : trials) {
      if (!t->error.empty() || t->steps.empty()) {
        ++failed;
        continue;
      }
      start.Add(t->steps.front().rse);
      end.Add(t->steps.back().rse);
      trace.Add(t->steps.back().trace);
      found.Add(t->steps.back().targets_found);
      all_found += t->num_targets > 0 && t->steps.back().targets_found == t->num_targets;
      collisions += t->steps.back().collisions;
      if (t->plans > 0) per_plan.Add(t->planning_time_s / t->plans);
    }
    absl::StrAppendFormat(&md,
                          "| %s | %d | %d | %.3f | %.3f +- %.3f | %.3f | %.1f +- %.1f | %.2f | "
                          "%.0f %% | %d | %.3f |\n",
                          name, static_cast<int>(trials.size()), failed, start.Mean(), end.Mean(),
                          end.Std(), end.n > 0 ? end.Std() / std::sqrt(end.n) : 0.0, trace.Mean(),
                          trace.Std(), found.Mean(), end.n > 0 ? 100.0 * all_found / end.n : 0.0,
                          collisions, per_plan.Mean());
  }
  // Which targets are found: ids in the order first seen.
  std::vector<std::string> ids;
  for (const TrialResult& t : result.trials) {
    for (const std::string& id : t.target_ids) {
      if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
    }
  }
  if (!ids.empty()) {
    absl::StrAppend(&md, "\nTrials that found each target at the end:\n\n| variant |");
    for (const std::string& id : ids) absl::StrAppend(&md, " ", id, " |");
    absl::StrAppend(&md, "\n| --- |");
    for (std::size_t i = 0; i < ids.size(); ++i) absl::StrAppend(&md, " --- |");
    absl::StrAppend(&md, "\n");
    for (const std::string& name : order) {
      absl::StrAppend(&md, "| ", name, " |");
      for (const std::string& id : ids) {
        int seen = 0, found = 0;
        for (const TrialResult* t : by_variant[name]) {
          for (std::size_t i = 0; i < t->target_ids.size() && i < t->found_at_end.size(); ++i) {
            if (t->target_ids[i] != id) continue;
            ++seen;
            found += t->found_at_end[i];
          }
        }
        if (seen == 0) {
          absl::StrAppend(&md, " - |");
        } else {
          absl::StrAppendFormat(&md, " %.0f %% |", 100.0 * found / seen);
        }
      }
      absl::StrAppend(&md, "\n");
    }
  }
  // Why targets were missed: never in view (coverage), in view but never
  // reported (the detector), or reported and still not above 0.5 at the end
  // (outvoted by misses, or not confirmed).
  bool any_sightings = false;
  for (const TrialResult& t : result.trials) any_sightings |= !t.sightings.empty();
  if (any_sightings) {
    absl::StrAppend(&md,
                    "\nTargets not found at the end, by what the camera saw (counts over all "
                    "trials):\n\n| variant | targets | not found | never in view | in view, "
                    "never detected | detected, not found | in view per target (mean) | in view "
                    "2+ times |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for (const std::string& name : order) {
      int targets = 0, missed = 0, unseen = 0, undetected = 0, outvoted = 0, twice = 0;
      double views = 0.0;
      for (const TrialResult* t : by_variant[name]) {
        const std::size_t n = std::min(t->sightings.size(), t->found_at_end.size());
        for (std::size_t i = 0; i < n; ++i) {
          const sim::TargetSightings& s = t->sightings[i];
          ++targets;
          views += s.in_view;
          twice += s.in_view >= 2;
          if (t->found_at_end[i]) continue;
          ++missed;
          if (s.in_view == 0) {
            ++unseen;
          } else if (s.detected == 0) {
            ++undetected;
          } else {
            ++outvoted;
          }
        }
      }
      if (targets == 0) continue;
      absl::StrAppendFormat(&md, "| %s | %d | %d | %d | %d | %d | %.2f | %.0f %% |\n", name,
                            targets, missed, unseen, undetected, outvoted, views / targets,
                            100.0 * twice / targets);
    }
  }
  for (const TrialResult& t : result.trials) {
    if (!t.error.empty()) {
      absl::StrAppendFormat(&md, "\n- %s trial %d failed: %s", t.variant, t.trial, t.error);
    }
  }
  return md;
}

}  // namespace oaipp::client

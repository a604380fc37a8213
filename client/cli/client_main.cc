// oaipp-client: flies simulated UAV missions against an oaipp-server.
//
//   oaipp-client run client/scenarios/e1.json --out=out/e1
//   oaipp-client health
//   oaipp-client map missions/m-000001 --png=map.png
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "client/cli/commands.h"
#include "client/cli/export_files.h"
#include "client/cli/map_image.h"
#include "client/cli/mission_runner.h"
#include "client/cli/prior_map_file.h"
#include "client/cli/search_files.h"
#include "core/common/status_macros.h"
#include "sim/random_world.h"
#include "sim/scenario.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051", "address of the oaipp-server (host:port)");
ABSL_FLAG(std::string, token, "",
          "bearer token for a server with --token_file (or the OAIPP_TOKEN environment variable, "
          "which keeps it out of the process list)");
ABSL_FLAG(std::string, tls_ca, "", "PEM CA bundle that signed the server's certificate (TLS)");
ABSL_FLAG(std::string, tls_cert, "", "PEM client certificate, for a server that asks for one");
ABSL_FLAG(std::string, tls_key, "", "PEM private key of --tls_cert");
ABSL_FLAG(std::string, out, "",
          "run: folder for steps.csv and map.png (default out/<scenario name>); eval: folder "
          "for trials.csv, summary.md and figures (default out/eval/<experiment>)");
ABSL_FLAG(bool, keep, false, "run: keep the mission on the server afterwards");
ABSL_FLAG(std::string, png, "", "map: file to write the map image to");
ABSL_FLAG(bool, detector_noise, false,
          "run, eval: missions fuse labels with the noise of the scenario's detector model "
          "(SensorSpec.detector_noise) instead of the paper's A (1 - exp(-B h))");
ABSL_FLAG(bool, detector_false_positives, false,
          "run, eval, with --detector_noise: missions also get the detector's false positives "
          "per cell (DetectorNoise.false_positive_rate), so detections and misses are weighed "
          "by their likelihood ratios");
ABSL_FLAG(bool, replan_on_detection, false,
          "run, eval: replan as soon as the detector reports anything, from where the UAV is "
          "(Scenario.replan_on_detection), not only at the end of each path");
ABSL_FLAG(std::string, geo_origin, "",
          "export: LAT,LON,ALT (degrees, degrees, metres above mean sea level) of the local "
          "frame's origin, for a scenario without mission.geo_origin; best the launch point");
ABSL_FLAG(double, setpoint_rate_hz, 20.0, "export: offboard setpoints per second, [10, 1000]");
ABSL_FLAG(std::string, autopilot, "px4", "export: the .plan's firmware, px4 or ardupilot");
ABSL_FLAG(std::string, frames, "",
          "run: folder for an image sequence of the mission (a map PNG per measurement)");

namespace {

constexpr char kUsage[] = R"(oaipp-client COMMAND [ARGS] [FLAGS]

Commands:
  run SCENARIO.json   fly the scenario's mission against the server; prints a
                      progress line per measurement (time, RSE, Tr(P), targets
                      found) and writes steps.csv and map.png to --out; with
                      --frames=DIR also a map image per measurement,
                      DIR/sequence.png (six of them side by side) and
                      DIR/sequence.avi (all of them, 2 per second); a
                      team scenario (mission.team) flies every UAV, each
                      path in its own colour, and prints per-UAV totals and
                      the closest approach of two UAVs
  health              check that the server answers
  map MISSION --png=FILE
                      write a mission's map image (mean | std deviation)
  export SCENARIO.json
                      create the scenario's mission (it needs a geo_origin, or
                      --geo_origin=LAT,LON,ALT), plan once from its start and
                      write what autopilots load to --out (default
                      out/export/<scenario name>): mission.plan
                      (QGroundControl), mission_items.csv (MAVLink mission
                      items, MAVSDK MissionRaw fields) and setpoints.csv
                      (NED offboard setpoints at --setpoint_rate_hz); for a
                      team, each UAV's in --out/<uav_id>
  eval E1|...|E7|PRIOR  many trials as concurrent missions (with a progress bar
                      and an ETA); trial k uses seed k:
                      E1 = OA-IPP, lawnmower and random on the E1 world;
                      E2 = adaptive against non-adaptive OA-IPP on E1;
                      E3 = OA-IPP over random worlds, low-/high-rise 4 x 4 m
                           buildings at densities 5, 10, 15 (trial k flies
                           world k), --e3_budget_s (300) each;
                      E4, E5 = OA-IPP and lawnmower on e4.json / e5.json;
                      E6 = OA-IPP, lawnmower and random on e6.json's
                           300 x 300 m field (the sparse map);
                      E7 = teams of 1, 2, 4 and 8 UAVs on e5.json's world
                           (--team_scenarios), each coordinated, on the
                           shared map without teammates' pending shots
                           (teamN-noshots) and each UAV alone on its own
                           map (teamN-alone): time to find everyone, team
                           efficiency, plan latency, separation;
                      PRIOR = OA-IPP (adaptive and detection objectives),
                           lawnmower and random from a prior map
                           (prior-demo.json by default).
                      --confirmation_weight=W (> 0) adds oaipp_confirm
                      to E1, E4, E5 and E6: OA-IPP with the confirmation
                      objective at weight W, same seeds;
                      --confirmation_phase_s=S adds a confirmation phase
                      over its last S seconds, at
                      --confirmation_phase_weight (default 3000) on the
                      cells within --ambiguity_margin (0.25) of the
                      threshold, and --second_look_weight on every other
                      cell (at --second_look_sharpness, when given).
                      --variants=a,b flies only the named variants
                      (e.g. oaipp_confirm). --detector_noise (run and
                      eval): every mission fuses labels with the noise of
                      the scenario's detector (SensorSpec.detector_noise);
                      --detector_false_positives adds its false-positive
                      rate per cell, weighing detections and misses by
                      their likelihood ratios. --replan_on_detection (run
                      and eval): replan from where the UAV is as soon as
                      the detector reports anything, not only at the end
                      of each path.
                      Writes trials.csv, targets.csv (how often each
                      target was in view and detected), sightings.csv
                      (each time one was in view: altitude, detected or
                      not, the map mean on it after), summary.md, a
                      figure over time (rse.png, or trace.png for E3) and
                      map_<variant>.png (the first trial) to --out (default
                      out/eval/<experiment>).

Flags: --server=HOST:PORT (default 127.0.0.1:50051), --out, --keep, --png,
       --frames (run), --trials (25), --first_trial (1), --parallel (2),
       --plan_budget_s (0: none), --scenario, --e3_budget_s, --team_scenarios,
       --e7_budget_s (0: the scenarios'), --confirmation_weight,
       --confirmation_phase_s, --confirmation_phase_weight, --ambiguity_margin,
       --second_look_weight, --second_look_sharpness, --variants, --detector_noise,
       --detector_false_positives, --replan_on_detection, --geo_origin, --setpoint_rate_hz (20),
       --autopilot (px4).)";

}  // namespace

namespace oaipp::client::cli {

int Fail(const absl::Status& status) {
  std::fprintf(stderr, "error: %s\n", std::string(status.ToString()).c_str());
  return 1;
}

// How to reach the server: the token and TLS flags.
oaipp::client::ClientOptions Options() {
  oaipp::client::ClientOptions options;
  options.token = absl::GetFlag(FLAGS_token);
  if (options.token.empty()) {
    if (const char* env = std::getenv("OAIPP_TOKEN"); env != nullptr) options.token = env;
  }
  options.tls_ca_file = absl::GetFlag(FLAGS_tls_ca);
  options.tls_cert_file = absl::GetFlag(FLAGS_tls_cert);
  options.tls_key_file = absl::GetFlag(FLAGS_tls_key);
  return options;
}

absl::StatusOr<std::shared_ptr<grpc::Channel>> OpenChannel() {
  return Client::OpenChannel(absl::GetFlag(FLAGS_server), Options());
}

// The scenario file at `path`, its prior map and map files read, with
// --replan_on_detection and --detector_noise applied.
absl::StatusOr<oaipp::v1::Scenario> LoadScenario(const std::string& path) {
  absl::StatusOr<oaipp::v1::Scenario> scenario = oaipp::sim::LoadScenarioFile(path);
  if (scenario.ok()) {
    if (absl::Status read = ReadPriorMapFile(*scenario, path); !read.ok()) return read;
    // What the map files held that the mission does not get, one line each.
    std::vector<std::string> dropped;
    if (absl::Status read = ReadSearchFiles(*scenario, path, dropped); !read.ok()) return read;
    for (const std::string& line : dropped) std::fprintf(stderr, "%s\n", line.c_str());
  }
  if (scenario.ok() && absl::GetFlag(FLAGS_replan_on_detection)) {
    scenario->set_replan_on_detection(true);
  }
  const bool false_positives = absl::GetFlag(FLAGS_detector_false_positives);
  if (false_positives && !absl::GetFlag(FLAGS_detector_noise)) {
    return absl::InvalidArgumentError("--detector_false_positives: needs --detector_noise");
  }
  if (!scenario.ok() || !absl::GetFlag(FLAGS_detector_noise)) return scenario;
  absl::StatusOr<oaipp::v1::Scenario> with =
      oaipp::sim::WithDetectorNoise(*std::move(scenario), false_positives);
  if (!with.ok()) {
    return absl::Status(
        with.status().code(),
        absl::StrCat(path,
                     false_positives ? ": --detector_false_positives: " : ": --detector_noise: ",
                     with.status().message()));
  }
  return with;
}

}  // namespace oaipp::client::cli

namespace {

using oaipp::client::Client;
using oaipp::client::cli::Fail;
using oaipp::client::cli::LoadScenario;
using oaipp::client::cli::OpenChannel;
using oaipp::client::cli::Options;

int Run(const std::string& path) {
  absl::StatusOr<oaipp::v1::Scenario> scenario = LoadScenario(path);
  if (!scenario.ok()) return Fail(scenario.status());
  absl::StatusOr<oaipp::sim::Simulation> sim = oaipp::sim::Simulation::Create(*scenario);
  if (!sim.ok())
    return Fail(
        absl::Status(sim.status().code(), absl::StrCat(path, ": ", sim.status().message())));
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel();
  if (!channel.ok()) return Fail(channel.status());
  Client client(*channel, Options());
  if (absl::Status up = client.WaitUntilServing(absl::Seconds(10)); !up.ok()) return Fail(up);
  const int team = scenario->mission().team_size();
  std::printf("scenario %s: %d targets, %.0f s budget, planner %s%s\n", scenario->name().c_str(),
              sim->num_targets(), sim->config().budget_s,
              oaipp::PlannerKindName(sim->config().planner.kind).c_str(),
              team > 0 ? absl::StrCat(", a team of ", team, " UAVs").c_str() : "");
  // With a team, a first column says whose shot the line follows.
  const auto uav_column = [&](const std::string& id) {
    if (team > 0) std::printf("%-12s ", id.empty() ? "-" : id.c_str());
  };
  uav_column("uav_id");
  std::printf("%8s %8s %8s %8s %10s %10s\n", "time_s", "RSE", "Tr(P)", "found", "path_m",
              "collisions");
  auto progress = [&](const oaipp::client::StepRecord& s) {
    uav_column(s.uav_id);
    std::printf("%8.1f %8.3f %8.2f %5d/%-2d %10.1f %10d\n", s.mission_time_s, s.rse, s.trace,
                s.targets_found, sim->num_targets(), s.path_length_m, s.collisions);
    std::fflush(stdout);
  };
  // --frames: a map image per measurement, kept with its caption.
  const std::string frames_dir = absl::GetFlag(FLAGS_frames);
  std::vector<std::string> frames, captions;
  std::string caption;
  auto on_step = [&](const oaipp::client::StepRecord& s) {
    progress(s);
    caption = absl::StrFormat("t = %.0f s, RSE %.2f, found %d/%d", s.mission_time_s, s.rse,
                              s.targets_found, sim->num_targets());
  };
  std::function<void(const std::string&)> on_frame;
  if (!frames_dir.empty()) {
    std::filesystem::create_directories(frames_dir);
    on_frame = [&](const std::string& png) {
      std::ofstream(absl::StrFormat("%s/frame_%03d.png", frames_dir, frames.size()),
                    std::ios::binary)
          << png;
      frames.push_back(png);
      captions.push_back(caption);
    };
  }
  absl::StatusOr<oaipp::client::RunResult> result = oaipp::client::RunScenario(
      client, *scenario, *sim, on_step, absl::GetFlag(FLAGS_keep), on_frame);
  if (!result.ok()) return Fail(result.status());
  std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) out = absl::StrCat("out/", scenario->name().empty() ? "run" : scenario->name());
  std::filesystem::create_directories(out);
  if (!frames.empty()) {
    // Six frames evenly spread over the mission, first and last included.
    std::vector<std::string> picked, picked_captions;
    const int count = std::min<int>(6, static_cast<int>(frames.size()));
    for (int i = 0; i < count; ++i) {
      const std::size_t k =
          count == 1 ? 0 : static_cast<std::size_t>(i) * (frames.size() - 1) / (count - 1);
      picked.push_back(frames[k]);
      picked_captions.push_back(captions[k]);
    }
    absl::StatusOr<std::string> sheet = oaipp::client::MontagePng(picked, picked_captions, 2);
    if (!sheet.ok()) return Fail(sheet.status());
    std::ofstream(frames_dir + "/sequence.png", std::ios::binary) << *sheet;
    // Every frame, two a second.
    const absl::Status video =
        oaipp::client::WriteVideo(frames, captions, 2.0, frames_dir + "/sequence.avi");
    if (!video.ok()) return Fail(video);
    std::printf("wrote %zu frames, sequence.png and sequence.avi to %s\n", frames.size(),
                frames_dir.c_str());
  }
  std::ofstream(out + "/steps.csv") << oaipp::client::StepsCsv(result->steps);
  std::ofstream(out + "/map.png", std::ios::binary) << result->final_map_png;
  const oaipp::client::StepRecord& last = result->steps.back();
  const std::vector<std::string> ids = sim->TargetIds();
  std::vector<std::string> missed;
  for (std::size_t i = 0; i < ids.size() && i < result->found_at_end.size(); ++i) {
    if (!result->found_at_end[i]) missed.push_back(ids[i]);
  }
  if (!missed.empty()) std::printf("not found: %s\n", absl::StrJoin(missed, ", ").c_str());
  if (team > 0) {
    for (const oaipp::client::UavRecord& u : result->uavs) {
      std::printf("%s: %d plans, %d shots, %.1f m flown, %d collisions%s\n", u.uav_id.c_str(),
                  u.plans, u.shots, u.path_length_m, u.collisions,
                  u.holds > 0 ? absl::StrCat(", ", u.holds, " s hovering boxed in").c_str() : "");
    }
    std::printf("closest approach of two UAVs: %.2f m (min_separation_m %.2f), %d violations\n",
                result->closest_approach_m, result->min_separation_m,
                result->separation_violations);
  }
  for (const oaipp::client::UavRecord& u : result->uavs) {
    if (!u.landed_with_s.has_value()) continue;
    std::printf("%s%sflew home: %.1f s of flight time left once landed\n", u.uav_id.c_str(),
                u.uav_id.empty() ? "" : ": ", *u.landed_with_s);
  }
  std::printf(
      "done: %d plans (%.1f s planning), RSE %.3f -> %.3f, %d/%d targets found, "
      "%d collisions; wrote %s/steps.csv and %s/map.png\n",
      result->plans, result->planning_time_s, result->steps.front().rse, last.rse,
      last.targets_found, sim->num_targets(), last.collisions, out.c_str(), out.c_str());
  return last.collisions == 0 && result->separation_violations == 0 ? 0 : 3;
}

// "LAT,LON,ALT" -> GeoPoint (range checks are the server's).
absl::StatusOr<oaipp::v1::GeoPoint> ParseGeoOrigin(const std::string& text) {
  const std::vector<std::string> parts = absl::StrSplit(text, ',');
  double v[3];
  if (parts.size() != 3 || !absl::SimpleAtod(parts[0], &v[0]) ||
      !absl::SimpleAtod(parts[1], &v[1]) || !absl::SimpleAtod(parts[2], &v[2])) {
    return absl::InvalidArgumentError(
        "--geo_origin: expected LAT,LON,ALT in degrees, degrees and metres, e.g. "
        "47.397742,8.545594,488");
  }
  oaipp::v1::GeoPoint g;
  g.set_latitude_deg(v[0]);
  g.set_longitude_deg(v[1]);
  g.set_altitude_m(v[2]);
  return g;
}

int Export(const std::string& path) {
  absl::StatusOr<oaipp::v1::Scenario> scenario = oaipp::sim::LoadScenarioFile(path);
  if (!scenario.ok()) return Fail(scenario.status());
  // The map files' fence, zones and buildings shape the exported geofence.
  std::vector<std::string> dropped;
  if (absl::Status read = oaipp::client::cli::ReadSearchFiles(*scenario, path, dropped);
      !read.ok()) {
    return Fail(read);
  }
  for (const std::string& line : dropped) std::fprintf(stderr, "%s\n", line.c_str());
  oaipp::v1::MissionSpec spec = scenario->mission();
  if (const std::string origin = absl::GetFlag(FLAGS_geo_origin); !origin.empty()) {
    absl::StatusOr<oaipp::v1::GeoPoint> g = ParseGeoOrigin(origin);
    if (!g.ok()) return Fail(g.status());
    *spec.mutable_geo_origin() = *g;
  }
  if (!spec.has_geo_origin()) {
    return Fail(absl::InvalidArgumentError(
        absl::StrCat(path,
                     ": mission.geo_origin is not set; give --geo_origin=LAT,LON,ALT (the launch "
                     "point, altitude above mean sea level)")));
  }
  oaipp::v1::ExportPathRequest request;
  request.set_setpoint_rate_hz(absl::GetFlag(FLAGS_setpoint_rate_hz));
  if (const std::string a = absl::GetFlag(FLAGS_autopilot); a == "ardupilot") {
    request.set_autopilot(oaipp::v1::AUTOPILOT_ARDUPILOT);
  } else if (a == "px4") {
    request.set_autopilot(oaipp::v1::AUTOPILOT_PX4);
  } else {
    return Fail(absl::InvalidArgumentError("--autopilot: px4 or ardupilot"));
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel();
  if (!channel.ok()) return Fail(channel.status());
  Client client(*channel, Options());
  if (absl::Status up = client.WaitUntilServing(absl::Seconds(10)); !up.ok()) return Fail(up);
  absl::StatusOr<oaipp::v1::Mission> mission = client.CreateMission(spec);
  if (!mission.ok()) return Fail(mission.status());
  std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) out = "out/export/" + scenario->name();
  // One UAV: its files in `out`. A team: each member plans from its start,
  // in the spec's order (so each path keeps clear of the ones before it),
  // and gets its files in out/<uav_id>.
  std::vector<std::pair<std::string, oaipp::v1::UavState>> uavs;
  if (mission->spec().team().empty()) uavs.emplace_back("", mission->spec().start());
  for (const oaipp::v1::TeamMember& m : mission->spec().team()) {
    uavs.emplace_back(m.uav_id(), m.start());
  }
  absl::Status failed;
  for (const auto& [uav_id, start] : uavs) {
    oaipp::v1::PlanPathRequest plan;
    plan.set_name(mission->name());
    plan.set_uav_id(uav_id);
    *plan.mutable_state() = start;
    if (scenario->has_planning_budget_s())
      plan.set_planning_budget_s(scenario->planning_budget_s());
    absl::StatusOr<oaipp::v1::PlanPathResponse> planned = client.PlanPath(plan);
    if (!planned.ok()) {
      failed = planned.status();
      break;
    }
    request.set_name(mission->name());
    *request.mutable_path() = *planned;
    absl::StatusOr<oaipp::v1::ExportPathResponse> exported = client.ExportPath(request);
    if (!exported.ok()) {
      failed = exported.status();
      break;
    }
    const std::string dir = uav_id.empty() ? out : out + "/" + uav_id;
    if (failed = oaipp::client::WriteExportFiles(dir, *exported); !failed.ok()) break;
    int waypoints = 0;
    for (const oaipp::v1::MissionItem& m : exported->mission_items()) {
      waypoints += m.command() == 16;
    }
    std::printf(
        "%s%splanned %.1f s (%d camera shots); %d mission items (%d waypoints, within %.2f m of "
        "the trajectory), %d setpoints at %.0f Hz%s%s\nwrote %s/mission.plan, "
        "%s/mission_items.csv and %s/setpoints.csv\n",
        uav_id.c_str(), uav_id.empty() ? "" : ": ", planned->trajectory().duration_s(),
        planned->measurement_poses_size(), exported->mission_items_size(), waypoints,
        exported->waypoint_deviation_m(), exported->setpoints_size(), request.setpoint_rate_hz(),
        exported->overflown_obstacles().empty() ? "" : "; overflown, so not fenced: ",
        absl::StrJoin(exported->overflown_obstacles(), ", ").c_str(), dir.c_str(), dir.c_str(),
        dir.c_str());
  }
  if (!absl::GetFlag(FLAGS_keep)) (void)client.DeleteMission(mission->name());
  return failed.ok() ? 0 : Fail(failed);
}

}  // namespace

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(kUsage);
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  if (args.size() < 2) {
    std::fprintf(stderr, "%s\n", kUsage);
    return 2;
  }
  const std::string command = args[1];
  if (command == "run" && args.size() == 3) return Run(args[2]);
  if (command == "eval" && args.size() == 3) return oaipp::client::cli::Eval(args[2]);
  if (command == "export" && args.size() == 3) return Export(args[2]);
  if (command == "health" && args.size() == 2) {
    absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel();
    if (!channel.ok()) return Fail(channel.status());
    Client client(*channel, Options());
    absl::Status up = client.WaitUntilServing(absl::Seconds(5));
    if (!up.ok()) return Fail(up);
    std::printf("%s: serving\n", absl::GetFlag(FLAGS_server).c_str());
    return 0;
  }
  if (command == "map" && args.size() == 3 && !absl::GetFlag(FLAGS_png).empty()) {
    absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel();
    if (!channel.ok()) return Fail(channel.status());
    Client client(*channel, Options());
    absl::StatusOr<oaipp::v1::GetMapResponse> map = client.GetMap(args[2], false, true);
    if (!map.ok()) return Fail(map.status());
    std::ofstream(absl::GetFlag(FLAGS_png), std::ios::binary) << map->png();
    std::printf("wrote %s (Tr(P) = %.3f)\n", absl::GetFlag(FLAGS_png).c_str(), map->trace());
    return 0;
  }
  std::fprintf(stderr, "%s\n", kUsage);
  return 2;
}

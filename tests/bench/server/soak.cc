// Soak: the real oaipp-server binary on loopback, a well-behaved ground
// station flying E1 missions, first alone and then beside hostile clients
// of another tenant. Every call of the well-behaved client must succeed
// within its deadline, its missions must fuse exactly the measurements it
// was told were fused, and no hostile call may see its missions. Prints
// the well-behaved client's latencies in both phases side by side; exits 1
// on any failure.
//
//   build/tests/bench/server/soak                       # 60 s alone, 300 s hostile
//   build/tests/bench/server/soak --alone_s=20 --hostile_s=60 --abusers=7
//
// The hostile clients (tenant "rogue", one thread each, kinds in turn):
//   idle-streams     holds as many WatchMission streams as it is allowed
//   cancelled-plans  starts endless plans and cancels them after 0-500 ms
//   plan-flood       8 threads asking for 60 s plans
//   oversized        huge population, huge ESDF, 1001 obstacles, 300,000
//                    boxes, a 17 MB message
//   malformed        random bytes to every method
//   trespasser       the good client's mission names with rogue's token, no
//                    token and a forged one
//   churn            a new connection per call, create and delete
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "grpcpp/generic/generic_stub.h"
#include "grpcpp/grpcpp.h"
#include "oaipp/v1/mission_service.grpc.pb.h"
#include "server/auth.h"
#include "tests/bench/server/e1_mission.h"
#include "tests/bench/server/latencies.h"
#include "tests/server/server_process.h"

ABSL_FLAG(int, alone_s, 60, "seconds the well-behaved client flies alone");
ABSL_FLAG(int, hostile_s, 300, "seconds it flies beside the hostile clients");
ABSL_FLAG(int, abusers, 7, "hostile clients (kinds in turn, see the file's comment)");
ABSL_FLAG(int, generations, 45, "CMA-ES generations of the good client's plans");
ABSL_FLAG(uint32_t, seed, 1, "seed of the hostile clients' random choices");

namespace {

using oaipp::bench::Latencies;
namespace v1 = oaipp::v1;
using Clock = std::chrono::steady_clock;

constexpr char kGoodToken[] = "good-token-5b1e";
constexpr char kRogueToken[] = "rogue-token-91c4";

// Failures of the well-behaved client and breaches by the hostile ones:
// counted, the first few printed.
class Failures {
 public:
  void Add(const std::string& what) {
    std::lock_guard<std::mutex> lock(mu_);
    if (++count_ <= 20) std::fprintf(stderr, "FAIL: %s\n", what.c_str());
  }
  int count() {
    std::lock_guard<std::mutex> lock(mu_);
    return count_;
  }

 private:
  std::mutex mu_;
  int count_ = 0;
};

std::unique_ptr<grpc::ClientContext> As(const std::string& token, double deadline_s) {
  auto context = std::make_unique<grpc::ClientContext>();
  if (!token.empty()) context->AddMetadata("authorization", "Bearer " + token);
  if (deadline_s > 0) {
    context->set_deadline(std::chrono::system_clock::now() +
                          std::chrono::milliseconds(static_cast<int>(deadline_s * 1000)));
  }
  return context;
}

// The well-behaved ground station: flies E1 missions one after another
// until `end`, as server_load does, with a WatchMission stream open on each
// and GetMission/ListMissions between plans.
class GoodClient {
 public:
  GoodClient(v1::MissionService::Stub* stub, Latencies* latencies, Failures* failures)
      : stub_(stub), latencies_(latencies), failures_(failures) {}

  // Names of the missions flown so far (the trespasser aims at them).
  std::vector<std::string> names() {
    std::lock_guard<std::mutex> lock(mu_);
    return names_;
  }

  void Fly(const std::string& phase, Clock::time_point end) {
    for (int n = 0; Clock::now() < end; ++n) FlyOne(absl::StrCat("good-", phase, "-", n), end);
  }

 private:
  template <typename Call>
  bool Timed(const char* method, Call call) {
    const auto t0 = Clock::now();
    const grpc::Status status = call();
    latencies_->Add(method, std::chrono::duration<double, std::milli>(Clock::now() - t0).count(),
                    status.ok());
    if (!status.ok()) {
      failures_->Add(absl::StrCat("good ", method, ": code ", status.error_code(), ": ",
                                  status.error_message().substr(0, 200)));
    }
    return status.ok();
  }

  void FlyOne(const std::string& id, Clock::time_point end) {
    const std::string name = "missions/" + id;
    constexpr double kFlight = 90.0;  // mission seconds
    v1::Mission created;
    if (!Timed("CreateMission", [&] {
          v1::CreateMissionRequest r;
          r.set_mission_id(id);
          *r.mutable_spec() = oaipp::bench::E1Spec(absl::GetFlag(FLAGS_generations));
          r.mutable_spec()->set_budget_s(kFlight);
          r.set_request_id("create-" + id);
          return stub_->CreateMission(As(kGoodToken, 10).get(), r, &created);
        })) {
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mu_);
      names_.push_back(name);
    }
    // A stream on the mission for its whole flight, as a map view would.
    auto watch_context = As(kGoodToken, 0);
    std::atomic<int> events{0};
    grpc::Status watch_status;
    std::thread watcher([&] {
      v1::WatchMissionRequest w;
      w.set_name(name);
      auto reader = stub_->WatchMission(watch_context.get(), w);
      v1::MissionEvent event;
      while (reader->Read(&event)) ++events;
      watch_status = reader->Finish();
    });
    v1::UavState state = created.spec().start();
    std::int64_t fused = 0;
    int shots = 0;
    while (state.mission_time_s() < kFlight && Clock::now() < end) {
      v1::PlanPathResponse path;
      if (!Timed("PlanPath", [&] {
            v1::PlanPathRequest r;
            r.set_name(name);
            *r.mutable_state() = state;
            r.set_planning_budget_s(2.0);
            r.set_request_id(absl::StrCat("plan-", state.mission_time_s()));
            return stub_->PlanPath(As(kGoodToken, 30).get(), r, &path);
          })) {
        break;
      }
      const double fly = std::min(path.trajectory().duration_s(), kFlight - state.mission_time_s());
      for (const auto& pose : path.measurement_poses()) {
        if (pose.t_s() > fly) break;
        v1::AddMeasurementResponse out;
        if (Timed("AddMeasurement", [&] {
              v1::AddMeasurementRequest r =
                  oaipp::bench::E1Measurement(name, pose.position_m(), pose.mission_time_s());
              r.set_request_id(absl::StrCat("shot-", shots++));
              return stub_->AddMeasurement(As(kGoodToken, 5).get(), r, &out);
            })) {
          ++fused;
        }
      }
      const auto& last = path.trajectory().samples(path.trajectory().samples_size() - 1);
      *state.mutable_position_m() = last.position_m();
      state.set_mission_time_s(state.mission_time_s() + fly);
      v1::Mission mission;
      if (Timed("GetMission",
                [&] {
                  v1::GetMissionRequest r;
                  r.set_name(name);
                  return stub_->GetMission(As(kGoodToken, 5).get(), r, &mission);
                }) &&
          mission.measurements_fused() != fused) {
        failures_->Add(absl::StrCat(name, ": ", mission.measurements_fused(),
                                    " measurements fused, ", fused, " acknowledged"));
      }
      v1::ListMissionsResponse list;
      Timed("ListMissions", [&] {
        v1::ListMissionsRequest r;
        r.set_page_size(50);
        return stub_->ListMissions(As(kGoodToken, 5).get(), r, &list);
      });
      for (const v1::Mission& m : list.missions()) {
        if (m.name().find("rogue") != std::string::npos) {
          failures_->Add("the good tenant's list shows " + m.name().substr(0, 80));
        }
      }
    }
    watch_context->TryCancel();
    watcher.join();
    if (watch_status.error_code() != grpc::StatusCode::CANCELLED || events.load() == 0) {
      failures_->Add(absl::StrCat(name, ": watch ended with code ", watch_status.error_code(),
                                  " after ", events.load(), " events"));
    }
    v1::DeleteMissionResponse deleted;
    Timed("DeleteMission", [&] {
      v1::DeleteMissionRequest r;
      r.set_name(name);
      return stub_->DeleteMission(As(kGoodToken, 10).get(), r, &deleted);
    });
  }

  v1::MissionService::Stub* stub_;
  Latencies* latencies_;
  Failures* failures_;
  std::mutex mu_;
  std::vector<std::string> names_;
};

// What the hostile clients share.
struct Arena {
  std::string address;
  std::shared_ptr<grpc::Channel> channel;
  GoodClient* good = nullptr;
  Failures* failures = nullptr;
  std::atomic<bool> stop{false};
  std::atomic<std::int64_t> calls{0};
};

v1::MissionSpec EndlessSpec() {
  v1::MissionSpec spec = oaipp::bench::E1Spec(100000);
  spec.set_budget_s(1e6);
  return spec;
}

void CreateRogueMission(v1::MissionService::Stub& stub, const std::string& id,
                        const v1::MissionSpec& spec) {
  v1::CreateMissionRequest r;
  r.set_mission_id(id);
  *r.mutable_spec() = spec;
  v1::Mission m;
  (void)stub.CreateMission(As(kRogueToken, 10).get(), r, &m);
}

void Pause(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

void IdleStreams(Arena& arena, std::mt19937&) {
  auto stub = v1::MissionService::NewStub(arena.channel);
  CreateRogueMission(*stub, "rogue-watched", EndlessSpec());
  struct Stream {
    std::unique_ptr<grpc::ClientContext> context;
    std::unique_ptr<grpc::ClientReader<v1::MissionEvent>> reader;
  };
  std::vector<Stream> streams;
  v1::WatchMissionRequest w;
  w.set_name("missions/rogue-watched");
  // Every 2 s: 40 new streams (more than any per-client limit), after
  // closing the oldest beyond 40, so that some are always held open.
  const auto close = [](Stream& s) {
    s.context->TryCancel();
    (void)s.reader->Finish();
  };
  while (!arena.stop) {
    const std::size_t excess = streams.size() > 40 ? streams.size() - 40 : 0;
    for (std::size_t i = 0; i < excess; ++i) close(streams[i]);
    streams.erase(streams.begin(), streams.begin() + static_cast<std::ptrdiff_t>(excess));
    for (int k = 0; k < 40; ++k) {
      Stream s{As(kRogueToken, 0), nullptr};
      s.reader = stub->WatchMission(s.context.get(), w);
      streams.push_back(std::move(s));
      ++arena.calls;
    }
    Pause(2000);
  }
  for (Stream& s : streams) close(s);
}

void CancelledPlans(Arena& arena, std::mt19937& rng) {
  auto stub = v1::MissionService::NewStub(arena.channel);
  CreateRogueMission(*stub, "rogue-cancelled", EndlessSpec());
  while (!arena.stop) {
    auto context = As(kRogueToken, 0);
    std::thread plan([&] {
      v1::PlanPathRequest r;
      r.set_name("missions/rogue-cancelled");
      *r.mutable_state() = oaipp::bench::E1Spec().start();
      v1::PlanPathResponse path;
      (void)stub->PlanPath(context.get(), r, &path);
    });
    Pause(static_cast<int>(rng() % 500));
    context->TryCancel();
    plan.join();
    ++arena.calls;
  }
}

void PlanFlood(Arena& arena, std::mt19937&) {
  auto stub = v1::MissionService::NewStub(arena.channel);
  CreateRogueMission(*stub, "rogue-flood", EndlessSpec());
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&] {
      while (!arena.stop) {
        v1::PlanPathRequest r;
        r.set_name("missions/rogue-flood");
        *r.mutable_state() = oaipp::bench::E1Spec().start();
        r.set_planning_budget_s(60);
        v1::PlanPathResponse path;
        (void)stub->PlanPath(As(kRogueToken, 90).get(), r, &path);
        ++arena.calls;
        Pause(10);
      }
    });
  }
  for (auto& t : threads) t.join();
}

void Oversized(Arena& arena, std::mt19937& rng) {
  auto stub = v1::MissionService::NewStub(arena.channel);
  CreateRogueMission(*stub, "rogue-big", oaipp::bench::E1Spec());
  for (int i = 0; !arena.stop; ++i) {
    v1::CreateMissionRequest create;
    create.set_mission_id(absl::StrCat("rogue-big-", i));
    *create.mutable_spec() = oaipp::bench::E1Spec();
    v1::Mission m;
    switch (rng() % 5) {
      case 0:
        create.mutable_spec()->mutable_planner()->set_population(2147483647);
        break;
      case 1:
        create.mutable_spec()->mutable_flight()->set_max_altitude_m(1300);
        break;
      case 2:
        for (int k = 0; k <= 1000; ++k)
          *create.mutable_spec()->add_obstacles() = create.spec().obstacles(0);
        break;
      case 3: {
        v1::AddMeasurementRequest r = oaipp::bench::E1Measurement(
            "missions/rogue-big", oaipp::bench::E1Spec().start().position_m(), 1.0);
        r.clear_labels();
        for (int k = 0; k < 300000; ++k) {
          auto* b = r.mutable_detections()->add_boxes();
          b->set_x_min_px(1);
          b->set_y_min_px(1);
          b->set_x_max_px(2);
          b->set_y_max_px(2);
          b->set_confidence(0.9);
        }
        v1::AddMeasurementResponse out;
        (void)stub->AddMeasurement(As(kRogueToken, 30).get(), r, &out);
        ++arena.calls;
        continue;
      }
      default:
        create.set_mission_id(std::string(17 << 20, 'x'));
        break;
    }
    (void)stub->CreateMission(As(kRogueToken, 30).get(), create, &m);
    ++arena.calls;
    Pause(20);
  }
}

void Malformed(Arena& arena, std::mt19937& rng) {
  grpc::GenericStub generic(arena.channel);
  const std::vector<std::string> methods = {
      "CreateMission",   "GetMission", "ListMissions", "DeleteMission", "AddMeasurement",
      "UpdateObstacles", "PlanPath",   "GetMap",       "WatchMission",  "NoSuchMethod"};
  while (!arena.stop) {
    std::string bytes(rng() % 4096, '\0');
    for (char& c : bytes) c = static_cast<char>(rng());
    grpc::Slice slice(bytes);
    grpc::ByteBuffer request(&slice, 1), response;
    auto context = As(kRogueToken, 5);
    std::mutex mu;
    std::condition_variable cv;
    bool done = false;
    generic.UnaryCall(context.get(), "/oaipp.v1.MissionService/" + methods[rng() % methods.size()],
                      {}, &request, &response, [&](grpc::Status) {
                        std::lock_guard<std::mutex> lock(mu);
                        done = true;
                        cv.notify_one();
                      });
    std::unique_lock<std::mutex> lock(mu);
    cv.wait(lock, [&] { return done; });
    ++arena.calls;
    Pause(5);
  }
}

// Every call at the good client's missions must be NOT_FOUND with rogue's
// token and UNAUTHENTICATED without a known one.
void Trespasser(Arena& arena, std::mt19937& rng) {
  auto stub = v1::MissionService::NewStub(arena.channel);
  const auto expect = [&](const grpc::Status& status, grpc::StatusCode code, const char* what) {
    ++arena.calls;
    if (status.error_code() != code) {
      arena.failures->Add(absl::StrCat("trespasser ", what, ": code ", status.error_code(),
                                       " (expected ", code, ")"));
    }
  };
  while (!arena.stop) {
    const std::vector<std::string> names = arena.good->names();
    if (names.empty()) {
      Pause(100);
      continue;
    }
    const std::string& name = names[rng() % names.size()];
    const std::string token = rng() % 4 == 0 ? (rng() % 2 ? "" : "forged") : kRogueToken;
    const grpc::StatusCode code =
        token == kRogueToken ? grpc::StatusCode::NOT_FOUND : grpc::StatusCode::UNAUTHENTICATED;
    v1::GetMissionRequest get;
    get.set_name(name);
    v1::Mission m;
    expect(stub->GetMission(As(token, 5).get(), get, &m), code, "GetMission");
    v1::AddMeasurementRequest add =
        oaipp::bench::E1Measurement(name, oaipp::bench::E1Spec().start().position_m(), 0.5);
    v1::AddMeasurementResponse added;
    expect(stub->AddMeasurement(As(token, 5).get(), add, &added), code, "AddMeasurement");
    v1::DeleteMissionRequest del;
    del.set_name(name);
    v1::DeleteMissionResponse deleted;
    expect(stub->DeleteMission(As(token, 5).get(), del, &deleted), code, "DeleteMission");
    v1::WatchMissionRequest w;
    w.set_name(name);
    auto watch_context = As(token, 5);
    auto reader = stub->WatchMission(watch_context.get(), w);
    v1::MissionEvent event;
    while (reader->Read(&event)) {
      arena.failures->Add("trespasser read an event of " + name);
    }
    expect(reader->Finish(), code, "WatchMission");
    Pause(20);
  }
}

void Churn(Arena& arena, std::mt19937& rng) {
  for (int i = 0; !arena.stop; ++i) {
    grpc::ChannelArguments args;
    args.SetInt("churn", i);  // a distinct connection each time
    auto stub = v1::MissionService::NewStub(
        grpc::CreateCustomChannel(arena.address, grpc::InsecureChannelCredentials(), args));
    const std::string id = absl::StrCat("rogue-churn-", rng() % 8);
    CreateRogueMission(*stub, id, oaipp::bench::E1Spec());
    v1::DeleteMissionRequest del;
    del.set_name("missions/" + id);
    v1::DeleteMissionResponse deleted;
    (void)stub->DeleteMission(As(kRogueToken, 5).get(), del, &deleted);
    arena.calls += 2;
    Pause(10);
  }
}

using Abuser = void (*)(Arena&, std::mt19937&);
struct Kind {
  const char* name;
  Abuser run;
};
constexpr Kind kKinds[] = {{"idle-streams", IdleStreams},
                           {"cancelled-plans", CancelledPlans},
                           {"plan-flood", PlanFlood},
                           {"oversized", Oversized},
                           {"malformed", Malformed},
                           {"trespasser", Trespasser},
                           {"churn", Churn}};

}  // namespace

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / absl::StrCat("oaipp-soak-", getpid());
  std::filesystem::create_directories(dir / "data");
  std::ofstream(dir / "tokens") << "good " << oaipp::server::Authenticator::HashToken(kGoodToken)
                                << "\nrogue "
                                << oaipp::server::Authenticator::HashToken(kRogueToken) << "\n";
  const int port = oaipp::server::testing::FreePort();
  const std::vector<std::string> flags = {"--store=sqlite",
                                          "--data_dir=" + (dir / "data").string(),
                                          "--token_file=" + (dir / "tokens").string(),
                                          "--planning_threads=2",
                                          "--planning_queue=16",
                                          "--max_plans_per_tenant=1",
                                          "--max_missions_per_tenant=16",
                                          "--max_streams_per_client=16",
                                          "--max_planning_s=10",
                                          "--log_level=error"};
  oaipp::server::testing::ServerProcess server(port, flags);
  if (!server.Start()) {
    std::fprintf(stderr, "the server did not start\n");
    return 1;
  }
  std::printf("server on %s:", server.address().c_str());
  for (const std::string& f : flags) std::printf(" %s", f.c_str());
  std::printf("\n");
  auto channel = grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials());
  auto stub = v1::MissionService::NewStub(channel);
  Failures failures;

  Latencies alone;
  {
    GoodClient good(stub.get(), &alone, &failures);
    std::printf("phase 1: the good client alone for %d s\n", absl::GetFlag(FLAGS_alone_s));
    std::fflush(stdout);
    good.Fly("alone", Clock::now() + std::chrono::seconds(absl::GetFlag(FLAGS_alone_s)));
  }

  Latencies hostile;
  GoodClient good(stub.get(), &hostile, &failures);
  Arena arena;
  arena.address = server.address();
  arena.channel = grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials());
  arena.good = &good;
  arena.failures = &failures;
  std::vector<std::thread> abusers;
  std::printf("phase 2: the good client beside %d hostile clients for %d s:",
              absl::GetFlag(FLAGS_abusers), absl::GetFlag(FLAGS_hostile_s));
  for (int i = 0; i < absl::GetFlag(FLAGS_abusers); ++i) {
    const Kind& kind = kKinds[i % std::size(kKinds)];
    std::printf(" %s", kind.name);
    abusers.emplace_back([&arena, kind, i] {
      std::mt19937 rng(absl::GetFlag(FLAGS_seed) * 1000 + static_cast<std::uint32_t>(i));
      kind.run(arena, rng);
    });
  }
  std::printf("\n");
  std::fflush(stdout);
  const auto hostile_start = Clock::now();
  good.Fly("hostile", hostile_start + std::chrono::seconds(absl::GetFlag(FLAGS_hostile_s)));
  arena.stop = true;
  for (auto& t : abusers) t.join();

  // The server is still up and serving the good tenant.
  v1::ListMissionsResponse list;
  const grpc::Status after =
      stub->ListMissions(As(kGoodToken, 10).get(), v1::ListMissionsRequest(), &list);
  if (!after.ok()) failures.Add("ListMissions after the soak: " + after.error_message());
  const int server_status = server.Stop(SIGTERM);
  if (!WIFEXITED(server_status) || WEXITSTATUS(server_status) != 0) {
    failures.Add(absl::StrCat("the server did not stop cleanly (wait status ", server_status, ")"));
  }
  std::filesystem::remove_all(dir);

  std::printf("\nthe good client's calls, ms: alone | beside %lld hostile calls\n",
              static_cast<long long>(arena.calls.load()));
  std::printf("%-16s %8s %8s | %8s %8s %10s\n", "method", "p50", "p99", "p50", "p99", "p99 ratio");
  for (const std::string& method : hostile.Methods()) {
    const double a99 = alone.Percentile(method, 0.99), h99 = hostile.Percentile(method, 0.99);
    std::printf("%-16s %8.1f %8.1f | %8.1f %8.1f %10.2f\n", method.c_str(),
                alone.Percentile(method, 0.5), a99, hostile.Percentile(method, 0.5), h99,
                a99 > 0 ? h99 / a99 : 0.0);
  }
  std::printf("errors of the good client: alone %d, hostile %d; failures in all: %d\n",
              alone.Errors(), hostile.Errors(), failures.count());
  return failures.count() == 0 ? 0 : 1;
}

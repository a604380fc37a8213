// The real oaipp-server binary on loopback: start, health SERVING,
// create / measure / plan / delete, SIGTERM, clean exit.
#include <algorithm>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "grpcpp/grpcpp.h"
#include "gtest/gtest.h"
#include "tests/server/server_process.h"
#include "tests/server/service_fixture.h"
// After the project's headers: its system includes clash with Eigen's when first.
#include "httplib.h"

namespace oaipp::server {
namespace {

TEST(ServerBinaryTest, ServesAndStopsCleanlyOnSigterm) {
  // The store in memory: this test is about serving and stopping; the
  // durable store has its own (crash_test).
  // Metrics on: the scrape below once crashed the server (a worker stack of
  // the old HTTP server was too small beside OpenBLAS's thread-local data).
  const int metrics_port = testing::FreePort();
  testing::ServerProcess server(
      testing::FreePort(),
      {"--store=memory", "--metrics_listen=127.0.0.1:" + std::to_string(metrics_port)});
  ASSERT_TRUE(server.Start()) << "oaipp-server did not start on " << server.address();
  auto channel = testing::QuickReconnectChannel(server.address());
  auto health = grpc::health::v1::Health::NewStub(channel);
  bool serving = false;
  for (int attempt = 0; attempt < 100 && !serving; ++attempt) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(200));
    grpc::health::v1::HealthCheckRequest request;
    request.set_service("oaipp.v1.MissionService");
    grpc::health::v1::HealthCheckResponse response;
    serving = health->Check(&context, request, &response).ok() &&
              response.status() == grpc::health::v1::HealthCheckResponse::SERVING;
    if (!serving) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(serving) << "server did not report SERVING on " << server.address();

  auto stub = v1::MissionService::NewStub(channel);
  testing::CreateSmall(*stub, "live");
  {
    grpc::ClientContext context;
    v1::AddMeasurementResponse r;
    ASSERT_TRUE(stub->AddMeasurement(&context,
                                     testing::LabelMeasurement("missions/live", 1, 1, 9, 1, 1), &r)
                    .ok());
    EXPECT_EQ(r.measurements_fused(), 1);
  }
  {
    grpc::ClientContext context;
    v1::PlanPathRequest request;
    request.set_name("missions/live");
    request.mutable_state()->mutable_position_m()->set_x(-4);
    request.mutable_state()->mutable_position_m()->set_y(4);
    request.mutable_state()->mutable_position_m()->set_z(8);
    v1::PlanPathResponse path;
    const grpc::Status st = stub->PlanPath(&context, request, &path);
    ASSERT_TRUE(st.ok()) << st.error_message();
    EXPECT_TRUE(path.collision_free());
  }
  {
    // One call of each made above, counted with status 0 (OK). A call is
    // counted as it finishes on the server, which may trail the client's
    // return by a moment, hence the few tries.
    httplib::Client scraper("127.0.0.1", metrics_port);
    std::string body;
    const std::vector<std::string> want = {
        "oaipp_rpc_calls_total{code=\"0\",method=\"CreateMission\"} 1\n",
        "oaipp_rpc_calls_total{code=\"0\",method=\"AddMeasurement\"} 1\n",
        "oaipp_rpc_calls_total{code=\"0\",method=\"PlanPath\"} 1\n"};
    const auto has_all = [&] {
      return std::all_of(want.begin(), want.end(),
                         [&](const std::string& w) { return absl::StrContains(body, w); });
    };
    for (int attempt = 0; attempt < 50 && !has_all(); ++attempt) {
      if (attempt > 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      const httplib::Result res = scraper.Get("/metrics");
      ASSERT_TRUE(res) << "scrape failed: " << httplib::to_string(res.error());
      ASSERT_EQ(res->status, 200);
      body = res->body;
    }
    for (const std::string& w : want) EXPECT_TRUE(absl::StrContains(body, w)) << w << body;
  }
  {
    grpc::ClientContext context;
    v1::DeleteMissionRequest request;
    request.set_name("missions/live");
    v1::DeleteMissionResponse r;
    ASSERT_TRUE(stub->DeleteMission(&context, request, &r).ok());
  }
  // The client goes away first, as a ground station would.
  stub.reset();
  health.reset();
  channel.reset();
  const int status = server.Stop(SIGTERM);
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

}  // namespace
}  // namespace oaipp::server

// The real oaipp-server binary on loopback: start, health SERVING,
// create / measure / plan / delete, SIGTERM, clean exit.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <random>
#include <thread>

#include "grpc/health/v1/health.grpc.pb.h"
#include "grpcpp/grpcpp.h"
#include "gtest/gtest.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

TEST(ServerBinaryTest, ServesAndStopsCleanlyOnSigterm) {
  // A port unlikely to be taken; the server refuses to start otherwise and
  // the health check below fails loudly.
  std::mt19937 rng(static_cast<unsigned>(getpid()));
  const int port = 20000 + static_cast<int>(rng() % 20000);
  const std::string address = "127.0.0.1:" + std::to_string(port);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string listen = "--listen=" + address;
    // The store in memory: this test is about serving and stopping; the
    // durable store has its own tests (crash_test).
    execl(OAIPP_SERVER_BINARY, OAIPP_SERVER_BINARY, listen.c_str(),
          "--metrics_listen=", "--log_level=warn", "--store=memory", static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait until the port accepts connections, so the channel's first
  // connection attempt succeeds (a refused one backs off for seconds).
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(static_cast<uint16_t>(port));
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool up = connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof(sa)) == 0;
    close(fd);
    if (up) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  // Retry the connection quickly while the server starts.
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 200);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 100);
  auto channel = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
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
  ASSERT_TRUE(serving) << "server did not report SERVING on " << address;

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
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

}  // namespace
}  // namespace oaipp::server

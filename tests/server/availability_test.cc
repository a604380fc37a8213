// The real oaipp-server binary on loopback under a hostile load: streams and
// queued plans must not take the threads other calls need, the stream limit
// is a clear RESOURCE_EXHAUSTED and health reports overload; TLS and mutual
// TLS with certificates made here by openssl; plaintext refused off
// loopback.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "grpcpp/generic/generic_stub.h"
#include "gtest/gtest.h"
#include "oaipp/v1/mission_service.grpc.pb.h"
#include "server/auth.h"
#include "tests/server/server_process.h"
#include "tests/server/service_fixture.h"

namespace oaipp::server {
namespace {

using testing::CreateEndless;
using testing::Eventually;

using testing::FreePort;

bool Serving(const std::shared_ptr<grpc::Channel>& channel) {
  auto health = grpc::health::v1::Health::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(2));
  grpc::health::v1::HealthCheckRequest request;
  request.set_service("oaipp.v1.MissionService");
  grpc::health::v1::HealthCheckResponse response;
  return health->Check(&context, request, &response).ok() &&
         response.status() == grpc::health::v1::HealthCheckResponse::SERVING;
}

// 4 serving threads; 20 idle streams and 12 queued plans. Every other call
// still gets through, and health stays SERVING. Before, each stream and
// each waiting plan held a thread and the rest got "Server Threadpool
// Exhausted".
TEST(AvailabilityTest, IdleStreamsAndQueuedPlansLeaveThreadsForOtherCalls) {
  const int port = FreePort();
  testing::ServerProcess server(
      port, {"--store=memory", "--worker_threads=4", "--planning_threads=1", "--planning_queue=64",
             "--max_streams_per_client=64"});
  ASSERT_TRUE(server.Start());
  auto channel = testing::QuickReconnectChannel(server.address());
  auto stub = v1::MissionService::NewStub(channel);
  CreateEndless(*stub, "busy");

  std::vector<std::unique_ptr<grpc::ClientContext>> watch_contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::MissionEvent>>> watches;
  v1::WatchMissionRequest watch;
  watch.set_name("missions/busy");
  for (int i = 0; i < 20; ++i) {
    watch_contexts.push_back(std::make_unique<grpc::ClientContext>());
    watches.push_back(stub->WatchMission(watch_contexts.back().get(), watch));
  }
  std::vector<std::unique_ptr<grpc::ClientContext>> plan_contexts;
  std::vector<std::thread> plans;
  for (int i = 0; i < 12; ++i) {
    plan_contexts.push_back(std::make_unique<grpc::ClientContext>());
    grpc::ClientContext* context = plan_contexts.back().get();
    plans.emplace_back([&stub, context] {
      v1::PlanPathResponse path;
      (void)stub->PlanPath(context, testing::PlanFromCorner("busy", 2.0), &path);  // cancelled
    });
  }
  absl::SleepFor(absl::Milliseconds(500));  // let them all arrive
  for (int i = 0; i < 10; ++i) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::GetMissionRequest get;
    get.set_name("missions/busy");
    v1::Mission mission;
    const grpc::Status status = stub->GetMission(&context, get, &mission);
    ASSERT_TRUE(status.ok()) << "call " << i << ": " << status.error_message();
  }
  EXPECT_TRUE(Serving(channel));
  for (auto& c : plan_contexts) c->TryCancel();
  for (auto& t : plans) t.join();
  for (auto& c : watch_contexts) c->TryCancel();
  for (auto& w : watches) (void)w->Finish();
}

// Past --max_streams a new stream is RESOURCE_EXHAUSTED with a reason, and
// health says NOT_SERVING until a stream closes.
TEST(AvailabilityTest, TheStreamLimitIsClearAndHealthReportsIt) {
  const int port = FreePort();
  testing::ServerProcess server(port, {"--store=memory", "--max_streams=3"});
  ASSERT_TRUE(server.Start());
  auto channel = testing::QuickReconnectChannel(server.address());
  auto stub = v1::MissionService::NewStub(channel);
  testing::CreateSmall(*stub, "w");
  ASSERT_TRUE(Eventually([&] { return Serving(channel); }));
  v1::WatchMissionRequest watch;
  watch.set_name("missions/w");
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::MissionEvent>>> readers;
  for (int i = 0; i < 3; ++i) {
    contexts.push_back(std::make_unique<grpc::ClientContext>());
    readers.push_back(stub->WatchMission(contexts.back().get(), watch));
  }
  EXPECT_TRUE(Eventually([&] { return !Serving(channel); }));
  grpc::ClientContext fourth_context;
  auto fourth = stub->WatchMission(&fourth_context, watch);
  v1::MissionEvent event;
  EXPECT_FALSE(fourth->Read(&event));
  const grpc::Status refused = fourth->Finish();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(refused.error_message().find("open streams"), std::string::npos)
      << refused.error_message();
  contexts[0]->TryCancel();
  (void)readers[0]->Finish();
  EXPECT_TRUE(Eventually([&] { return Serving(channel); }));
  for (std::size_t i = 1; i < contexts.size(); ++i) contexts[i]->TryCancel();
  for (std::size_t i = 1; i < readers.size(); ++i) (void)readers[i]->Finish();
}

// Runs a shell command; true when it exits 0.
bool Shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return status != -1 && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

std::string ReadAll(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A CA, a server certificate for 127.0.0.1 and a client certificate, made
// with openssl in a temporary folder.
class TlsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           absl::StrCat("oaipp-tls-", getpid(), "-", std::random_device{}());
    std::filesystem::create_directories(dir_);
    const std::string d = dir_.string();
    const std::string quiet = " >/dev/null 2>&1";
    ASSERT_TRUE(Shell("cd " + d +
                      " && openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=test-ca"
                      " -keyout ca.key -out ca.pem" +
                      quiet));
    ASSERT_TRUE(Shell("cd " + d +
                      " && openssl req -newkey rsa:2048 -nodes -subj /CN=localhost"
                      " -keyout server.key -out server.csr" +
                      quiet +
                      " && printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext"
                      " && openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key"
                      " -CAcreateserial -days 2 -extfile server.ext -out server.pem" +
                      quiet));
    ASSERT_TRUE(Shell("cd " + d +
                      " && openssl req -newkey rsa:2048 -nodes -subj /CN=ground-station"
                      " -keyout client.key -out client.csr" +
                      quiet +
                      " && openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key"
                      " -CAcreateserial -days 2 -out client.pem" +
                      quiet));
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string File(const std::string& name) const { return (dir_ / name).string(); }

  // A GetMission of a mission that does not exist: NOT_FOUND means the call
  // reached the service.
  static grpc::StatusCode Probe(const std::shared_ptr<grpc::Channel>& channel) {
    auto stub = v1::MissionService::NewStub(channel);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
    v1::GetMissionRequest get;
    get.set_name("missions/none");
    v1::Mission mission;
    return stub->GetMission(&context, get, &mission).error_code();
  }

  std::filesystem::path dir_;
};

TEST_F(TlsTest, MutualTlsLetsInOnlyClientsWithACertificateFromTheCa) {
  const int port = FreePort();
  testing::ServerProcess server(
      port, {"--store=memory", "--tls_cert=" + File("server.pem"),
             "--tls_key=" + File("server.key"), "--tls_client_ca=" + File("ca.pem")});
  ASSERT_TRUE(server.Start());
  grpc::SslCredentialsOptions with_cert;
  with_cert.pem_root_certs = ReadAll(File("ca.pem"));
  with_cert.pem_cert_chain = ReadAll(File("client.pem"));
  with_cert.pem_private_key = ReadAll(File("client.key"));
  EXPECT_EQ(Probe(grpc::CreateChannel(server.address(), grpc::SslCredentials(with_cert))),
            grpc::StatusCode::NOT_FOUND);
  grpc::SslCredentialsOptions without_cert;
  without_cert.pem_root_certs = ReadAll(File("ca.pem"));
  EXPECT_EQ(Probe(grpc::CreateChannel(server.address(), grpc::SslCredentials(without_cert))),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(Probe(grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials())),
            grpc::StatusCode::UNAVAILABLE);
}

TEST_F(TlsTest, ServerTlsAloneServesClientsThatTrustTheCa) {
  const int port = FreePort();
  testing::ServerProcess server(port, {"--store=memory", "--tls_cert=" + File("server.pem"),
                                       "--tls_key=" + File("server.key")});
  ASSERT_TRUE(server.Start());
  grpc::SslCredentialsOptions trust;
  trust.pem_root_certs = ReadAll(File("ca.pem"));
  EXPECT_EQ(Probe(grpc::CreateChannel(server.address(), grpc::SslCredentials(trust))),
            grpc::StatusCode::NOT_FOUND);
  // A client that does not trust the CA does not get in.
  grpc::SslCredentialsOptions other;
  other.pem_root_certs = ReadAll(File("client.pem"));
  EXPECT_EQ(Probe(grpc::CreateChannel(server.address(), grpc::SslCredentials(other))),
            grpc::StatusCode::UNAVAILABLE);
}

// One unary call with a raw body (bytes that need not parse) and an
// optional authorization header; its status code.
grpc::StatusCode RawUnary(const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
                          const std::string& body, const std::string& authorization) {
  grpc::GenericStub generic(channel);
  grpc::CompletionQueue queue;
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (!authorization.empty()) context.AddMetadata("authorization", authorization);
  grpc::Slice slice(body);
  const grpc::ByteBuffer request(&slice, 1);
  auto call = generic.PrepareUnaryCall(&context, method, request, &queue);
  call->StartCall();
  grpc::ByteBuffer response;
  grpc::Status status;
  call->Finish(&response, &status, nullptr);
  void* tag = nullptr;
  bool ok = false;
  (void)queue.Next(&tag, &ok);
  queue.Shutdown();
  while (queue.Next(&tag, &ok)) {
  }
  return status.error_code();
}

// Under TLS the token is checked on the call's metadata, before its request
// is read: a body that cannot parse is refused UNAUTHENTICATED with a
// missing or unknown token (parsing never ran), and fails to parse with a
// good one (it did). Health answers without a token.
TEST_F(TlsTest, ABadTokenIsRefusedBeforeTheRequestIsRead) {
  {
    std::ofstream tokens(File("tokens"));
    tokens << "alpha " << Authenticator::HashToken("good-token") << "\n";
  }
  testing::ServerProcess server(
      FreePort(), {"--store=memory", "--tls_cert=" + File("server.pem"),
                   "--tls_key=" + File("server.key"), "--token_file=" + File("tokens")});
  ASSERT_TRUE(server.Start());
  grpc::SslCredentialsOptions trust;
  trust.pem_root_certs = ReadAll(File("ca.pem"));
  const auto channel = grpc::CreateChannel(server.address(), grpc::SslCredentials(trust));
  const std::string garbage(64, '\xff');
  const std::string method = "/oaipp.v1.MissionService/AddMeasurement";
  EXPECT_EQ(RawUnary(channel, method, garbage, "Bearer not-a-token"),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(RawUnary(channel, method, garbage, ""), grpc::StatusCode::UNAUTHENTICATED);
  const grpc::StatusCode parsed = RawUnary(channel, method, garbage, "Bearer good-token");
  EXPECT_NE(parsed, grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_NE(parsed, grpc::StatusCode::OK);
  auto health = grpc::health::v1::Health::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  grpc::health::v1::HealthCheckRequest request;
  grpc::health::v1::HealthCheckResponse response;
  EXPECT_TRUE(health->Check(&context, request, &response).ok());
}

// Without TLS the server refuses a non-loopback address (exit 2, before it
// binds anything) unless told to serve in the clear.
TEST(ListenTest, PlaintextOffLoopbackIsRefusedUnlessAllowed) {
  const std::string binary = OAIPP_SERVER_BINARY;
  const std::string common = " --store=memory --metrics_listen= --log_level=off";
  const int status =
      std::system((binary + " --listen=0.0.0.0:" + std::to_string(FreePort()) + common).c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  // (Serving in the clear off loopback with --allow_insecure_remote is not
  // tried here: the tests never listen beyond 127.0.0.1.)
}

// Asks the server's reflection service to list its services (a hand-made
// grpc.reflection.v1alpha.ServerReflectionRequest with list_services set:
// Debian ships no client stubs for it). The answer's bytes, or the status
// when the call failed.
absl::StatusOr<std::string> ListServicesByReflection(
    const std::shared_ptr<grpc::Channel>& channel) {
  grpc::GenericStub generic(channel);
  grpc::CompletionQueue queue;
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  const auto wait = [&queue] {
    void* tag = nullptr;
    bool ok = false;
    return queue.Next(&tag, &ok) && ok;
  };
  auto call = generic.PrepareCall(
      &context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &queue);
  call->StartCall(nullptr);
  wait();
  const std::string request("\x3a\x00", 2);  // field 7 (list_services), empty
  grpc::Slice slice(request);
  grpc::ByteBuffer out(&slice, 1);
  call->Write(out, nullptr);
  wait();
  call->WritesDone(nullptr);
  wait();
  grpc::ByteBuffer in;
  call->Read(&in, nullptr);
  const bool read = wait();
  grpc::Status status;
  call->Finish(&status, nullptr);
  wait();
  queue.Shutdown();
  if (!status.ok()) return absl::Status(static_cast<absl::StatusCode>(status.error_code()), "");
  if (!read) return absl::UnknownError("no answer");
  std::vector<grpc::Slice> slices;
  (void)in.Dump(&slices);
  std::string answer;
  for (const grpc::Slice& piece : slices) {
    answer.append(reinterpret_cast<const char*>(piece.begin()), piece.size());
  }
  return answer;
}

TEST(ReflectionTest, OnByDefaultAndOffByFlag) {
  const int port = FreePort();
  {
    testing::ServerProcess server(port, {"--store=memory"});
    ASSERT_TRUE(server.Start());
    const absl::StatusOr<std::string> answer =
        ListServicesByReflection(testing::QuickReconnectChannel(server.address()));
    ASSERT_TRUE(answer.ok()) << answer.status();
    EXPECT_NE(answer->find("oaipp.v1.MissionService"), std::string::npos);
  }
  testing::ServerProcess server(FreePort(), {"--store=memory", "--reflection=false"});
  ASSERT_TRUE(server.Start());
  const absl::StatusOr<std::string> answer =
      ListServicesByReflection(testing::QuickReconnectChannel(server.address()));
  EXPECT_EQ(answer.status().code(), absl::StatusCode::kUnimplemented) << answer.status();
}

}  // namespace
}  // namespace oaipp::server

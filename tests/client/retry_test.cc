// The client's retries against the real service in-process, with a server
// interceptor that turns the answer of a call that did land into CANCELLED
// or UNKNOWN "Stream removed", as a proxy's reset does when the server
// behind it goes away mid-call.
#include <atomic>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "client/client.h"
#include "grpcpp/support/server_interceptor.h"
#include "gtest/gtest.h"
#include "server/service.h"
#include "tests/server/service_fixture.h"

namespace oaipp::client {
namespace {

constexpr char kAddMeasurement[] = "/oaipp.v1.MissionService/AddMeasurement";

// Replaces the status of the first `count` AddMeasurement answers with
// `status`, after the service has applied them.
class CancelAnswers : public grpc::experimental::Interceptor {
 public:
  CancelAnswers(bool is_add, std::atomic<int>* left, grpc::Status status)
      : is_add_(is_add), left_(left), status_(std::move(status)) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (is_add_ &&
        methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_STATUS) &&
        left_->fetch_sub(1) > 0) {
      methods->ModifySendStatus(status_);
    }
    methods->Proceed();
  }

 private:
  bool is_add_;
  std::atomic<int>* left_;
  grpc::Status status_;
};

class CancelAnswersFactory : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  CancelAnswersFactory(std::atomic<int>* left, grpc::Status status)
      : left_(left), status_(std::move(status)) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override {
    return new CancelAnswers(std::string(info->method()) == kAddMeasurement, left_, status_);
  }

 private:
  std::atomic<int>* left_;
  grpc::Status status_;
};

// The real service behind a CancelAnswers interceptor.
class RetryTest : public ::testing::Test {
 protected:
  void Start(int answers_to_cancel,
             grpc::Status status = grpc::Status(grpc::StatusCode::CANCELLED, "stream reset")) {
    answers_to_cancel_ = answers_to_cancel;
    std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
    creators.push_back(std::make_unique<CancelAnswersFactory>(&answers_to_cancel_, status));
    server_ = std::make_unique<server::testing::InProcessService>(
        server::ServerParts{.registry = {.max_missions = 4, .max_cells_per_mission = 1600},
                            .planning_threads = 1,
                            .planning_queue = 4,
                            .interceptors = std::move(creators)});
  }
  Client Connect(int max_attempts) {
    ClientOptions options;
    options.max_attempts = max_attempts;
    options.first_backoff = absl::Milliseconds(10);
    return Client(server_->channel(), options);
  }

  std::atomic<int> answers_to_cancel_{0};
  std::unique_ptr<server::testing::InProcessService> server_;
};

TEST_F(RetryTest, AMeasurementWhoseAnswerWasCancelledIsAskedAgainAndFusedOnce) {
  Start(2);
  Client client = Connect(8);
  absl::StatusOr<v1::Mission> created = client.CreateMission(server::testing::SmallSpec(), "m");
  ASSERT_TRUE(created.ok()) << created.status();
  absl::StatusOr<v1::AddMeasurementResponse> fused =
      client.AddMeasurement(server::testing::LabelMeasurement("missions/m", 3, 3, 10, 1.0, 1.0));
  ASSERT_TRUE(fused.ok()) << fused.status();
  // Two answers lost, the third (a repeat the service recognises by its
  // request_id) returned: the shot counts once.
  EXPECT_EQ(client.retried_calls(), 2);
  EXPECT_EQ(fused->measurements_fused(), 1);
  EXPECT_EQ(fused->cells_fused(), 9);
  absl::StatusOr<v1::Mission> mission = client.GetMission("missions/m");
  ASSERT_TRUE(mission.ok()) << mission.status();
  EXPECT_EQ(mission->measurements_fused(), 1);
}

TEST_F(RetryTest, ACancelledAnswerIsGivenUpAfterMaxAttempts) {
  Start(1000);
  Client client = Connect(3);
  ASSERT_TRUE(client.CreateMission(server::testing::SmallSpec(), "m").ok());
  absl::StatusOr<v1::AddMeasurementResponse> fused =
      client.AddMeasurement(server::testing::LabelMeasurement("missions/m", 3, 3, 10, 1.0, 1.0));
  EXPECT_EQ(fused.status().code(), absl::StatusCode::kCancelled) << fused.status();
  EXPECT_EQ(client.retried_calls(), 2);
  EXPECT_EQ(answers_to_cancel_.load(), 1000 - 3);
  absl::StatusOr<v1::Mission> mission = client.GetMission("missions/m");
  ASSERT_TRUE(mission.ok()) << mission.status();
  EXPECT_EQ(mission->measurements_fused(), 1);  // applied by the first attempt, once
}

// gRPC reports a stream reset under a call as UNKNOWN "Stream removed"
// (seen through HAProxy in a rolling restart): asked again like CANCELLED,
// and fused once. An UNKNOWN with any other message is the server's own
// answer and is not asked again.
TEST_F(RetryTest, AStreamRemovedUnderTheCallIsAskedAgainAndOtherUnknownsAreNot) {
  for (const std::string& message : {std::string("Stream removed"), std::string("boom")}) {
    SCOPED_TRACE(message);
    const bool removed = message == "Stream removed";
    Start(2, grpc::Status(grpc::StatusCode::UNKNOWN, message));
    Client client = Connect(8);
    ASSERT_TRUE(client.CreateMission(server::testing::SmallSpec(), "m").ok());
    absl::StatusOr<v1::AddMeasurementResponse> fused =
        client.AddMeasurement(server::testing::LabelMeasurement("missions/m", 3, 3, 10, 1.0, 1.0));
    EXPECT_EQ(fused.ok(), removed) << fused.status();
    EXPECT_EQ(client.retried_calls(), removed ? 2 : 0);
    absl::StatusOr<v1::Mission> mission = client.GetMission("missions/m");
    ASSERT_TRUE(mission.ok()) << mission.status();
    EXPECT_EQ(mission->measurements_fused(), 1);  // landed once either way
  }
}

}  // namespace
}  // namespace oaipp::client

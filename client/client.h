// A client library over the generated MissionService stub: a deadline on
// every call, retries of UNAVAILABLE, of CANCELLED (which only the other
// end can cause: the client never cancels its own calls) and of gRPC's
// UNKNOWN "Stream removed" (a stream reset under the call) with the same
// request_id (so a retried mutation is never applied twice), and
// absl::Status errors that keep the server's message. Every call carries
// the routing header kRouteHeader with the mission it is about, so that a
// proxy in front of several servers sends one mission's calls to one of
// them (docs/cluster.md).
//
//   OAIPP_ASSIGN_OR_RETURN(Client client, Client::Connect("127.0.0.1:50051"));
//   OAIPP_ASSIGN_OR_RETURN(v1::Mission m, client.CreateMission(spec));
#pragma once

#include <atomic>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "grpcpp/grpcpp.h"
#include "oaipp/v1/mission_service.grpc.pb.h"

namespace oaipp::client {

struct ClientOptions {
  absl::Duration call_timeout = absl::Seconds(30);  // every call but PlanPath
  absl::Duration plan_timeout = absl::Seconds(60);  // PlanPath (the planner is anytime)
  // Attempts for the failures retried (above), waiting first_backoff, then
  // twice as long each time up to max_backoff: the defaults keep trying for
  // about 9 s, long enough for a proxy to notice a dead server and for
  // another to take its missions over.
  int max_attempts = 8;
  absl::Duration first_backoff = absl::Milliseconds(200);
  absl::Duration max_backoff = absl::Seconds(2);
  // A RESOURCE_EXHAUSTED that names a retry delay (api::kRetryAfterHeader:
  // a take-off plan refused by the server's take-off pacing) is asked again
  // after that delay, for at most this long in all per call. Zero: never.
  absl::Duration max_retry_after = absl::Seconds(60);
  // Who the client is, for a server with --token_file: sent as
  // "authorization: Bearer <token>" on every call. Empty: none.
  std::string token;
  // TLS: the CA bundle that signed the server's certificate (PEM file; empty
  // with no client certificate: plaintext), and for mutual TLS the client's
  // certificate and key.
  std::string tls_ca_file;
  std::string tls_cert_file;
  std::string tls_key_file;
};

class Client {
 public:
  // A plaintext channel to `address` (host:port); does not wait for the
  // server.
  [[nodiscard]] static Client Connect(const std::string& address, ClientOptions options = {});
  // A channel to `address` as `options` ask (TLS when a tls_* file is
  // given). InvalidArgument when a file cannot be read or only one of
  // tls_cert / tls_key is given.
  [[nodiscard]] static absl::StatusOr<std::shared_ptr<grpc::Channel>> OpenChannel(
      const std::string& address, const ClientOptions& options);
  // Uses an existing channel (e.g. an in-process one in tests).
  Client(std::shared_ptr<grpc::Channel> channel, ClientOptions options);

  // OK when the server answers gRPC's health check (the server as a whole)
  // with SERVING within `timeout`. Needs no token.
  [[nodiscard]] absl::Status WaitUntilServing(absl::Duration timeout);

  [[nodiscard]] absl::StatusOr<v1::Mission> CreateMission(const v1::MissionSpec& spec,
                                                          const std::string& mission_id = "");
  [[nodiscard]] absl::StatusOr<v1::Mission> GetMission(const std::string& name);
  [[nodiscard]] absl::Status DeleteMission(const std::string& name);
  [[nodiscard]] absl::StatusOr<v1::AddMeasurementResponse> AddMeasurement(
      v1::AddMeasurementRequest request);
  [[nodiscard]] absl::StatusOr<v1::PlanPathResponse> PlanPath(v1::PlanPathRequest request);
  [[nodiscard]] absl::StatusOr<v1::GetMapResponse> GetMap(const std::string& name, bool cells,
                                                          bool png);
  [[nodiscard]] absl::StatusOr<v1::ExportPathResponse> ExportPath(
      const v1::ExportPathRequest& request);

  // The server that answered the last call (api::kReplicaHeader), or ""
  // when it names none.
  [[nodiscard]] std::string last_replica() const;
  // Attempts that failed as retried (above) and were sent again, since
  // creation.
  [[nodiscard]] std::int64_t retried_calls() const { return retried_calls_.load(); }
  // Calls asked again after the delay a RESOURCE_EXHAUSTED named, since
  // creation (ClientOptions::max_retry_after).
  [[nodiscard]] std::int64_t paced_calls() const { return paced_calls_.load(); }

 private:
  // A request id unique to this client process.
  std::string NextRequestId();
  // route: the mission the call is about (api::kRouteHeader).
  template <typename Request, typename Response, typename Method>
  absl::StatusOr<Response> Call(const char* what, Method method, const Request& request,
                                absl::Duration timeout, const std::string& route);

  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::MissionService::Stub> stub_;
  // Adds what every call carries (the token, the route when not empty).
  void Prepare(grpc::ClientContext& context, const std::string& route = "") const;
  ClientOptions options_;
  std::string id_prefix_;
  std::atomic<std::int64_t> next_id_{1};
  std::atomic<std::int64_t> retried_calls_{0};
  std::atomic<std::int64_t> paced_calls_{0};
  mutable absl::Mutex replica_mu_;
  std::string last_replica_ ABSL_GUARDED_BY(replica_mu_);
};

}  // namespace oaipp::client

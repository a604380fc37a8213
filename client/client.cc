#include "client/client.h"

#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <thread>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "api/limits.h"
#include "api/metadata.h"
#include "api/status.h"
#include "grpc/health/v1/health.grpc.pb.h"

namespace oaipp::client {
namespace {

// Whether a call that ended with `status` is asked again (with the same
// request_id, so that a mutation that did land is not applied twice).
bool AskAgain(const grpc::Status& status) {
  switch (status.error_code()) {
    case grpc::StatusCode::UNAVAILABLE:
      return true;
    // This client never cancels its own attempts, so a CANCELLED came from
    // the other end: a server stopping under it, or a proxy resetting the
    // stream when its backend went away.
    case grpc::StatusCode::CANCELLED:
      return true;
    // gRPC's own transport names a stream removed under a call (a proxy
    // that reset it when its backend closed the connection mid-call, as in
    // a rolling restart) UNKNOWN "Stream removed": a lost answer, not the
    // server's. Any other UNKNOWN is the server's and final.
    case grpc::StatusCode::UNKNOWN:
      return status.error_message() == "Stream removed";
    default:
      return false;
  }
}

}  // namespace

namespace {

// The whole file at `path` into *pem; `what` names the option.
absl::Status ReadPem(const char* what, const std::string& path, std::string* pem) {
  std::ifstream in(path);
  if (!in) return absl::InvalidArgumentError(absl::StrCat(what, ": cannot read '", path, "'"));
  std::stringstream text;
  text << in.rdbuf();
  *pem = text.str();
  return absl::OkStatus();
}

// Replies up to the largest message the server takes: a GetMap with the
// cells of a 1 km^2 field at 2 m (250,000 cells) is 4 MB, gRPC's default.
grpc::ChannelArguments ReplyLimit() {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(static_cast<int>(api::kMaxMessageBytes));
  return args;
}

}  // namespace

Client Client::Connect(const std::string& address, ClientOptions options) {
  return Client(
      grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), ReplyLimit()),
      options);
}

absl::StatusOr<std::shared_ptr<grpc::Channel>> Client::OpenChannel(const std::string& address,
                                                                   const ClientOptions& options) {
  if (options.tls_ca_file.empty() && options.tls_cert_file.empty() &&
      options.tls_key_file.empty()) {
    return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), ReplyLimit());
  }
  if (options.tls_cert_file.empty() != options.tls_key_file.empty()) {
    return absl::InvalidArgumentError("tls_cert and tls_key go together");
  }
  grpc::SslCredentialsOptions ssl;
  absl::Status read;
  if (!options.tls_ca_file.empty()) {
    read.Update(ReadPem("tls_ca", options.tls_ca_file, &ssl.pem_root_certs));
  }
  if (!options.tls_cert_file.empty()) {
    read.Update(ReadPem("tls_cert", options.tls_cert_file, &ssl.pem_cert_chain));
    read.Update(ReadPem("tls_key", options.tls_key_file, &ssl.pem_private_key));
  }
  if (!read.ok()) return read;
  return grpc::CreateCustomChannel(address, grpc::SslCredentials(ssl), ReplyLimit());
}

void Client::Prepare(grpc::ClientContext& context, const std::string& route) const {
  if (!options_.token.empty()) context.AddMetadata("authorization", "Bearer " + options_.token);
  if (!route.empty()) context.AddMetadata(api::kRouteHeader, route);
}

namespace {

// The route of a call about mission `name` ("missions/{id}"): its id.
std::string RouteOf(const std::string& name) {
  constexpr absl::string_view kPrefix = "missions/";
  return absl::StartsWith(name, kPrefix) ? name.substr(kPrefix.size()) : name;
}

}  // namespace

Client::Client(std::shared_ptr<grpc::Channel> channel, ClientOptions options)
    : channel_(std::move(channel)),
      stub_(v1::MissionService::NewStub(channel_)),
      options_(options) {
  std::random_device device;
  id_prefix_ = absl::StrFormat("c%08x", device());
}

std::string Client::NextRequestId() { return absl::StrCat(id_prefix_, "-", next_id_++); }

template <typename Request, typename Response, typename Method>
absl::StatusOr<Response> Client::Call(const char* what, Method method, const Request& request,
                                      absl::Duration timeout, const std::string& route) {
  absl::Duration backoff = options_.first_backoff;
  absl::Duration paced = absl::ZeroDuration();  // waited as the server asked
  bool waited = false;                          // the wait was the server's
  grpc::Status status;
  for (int attempt = 1; attempt <= options_.max_attempts; ++attempt) {
    if (const bool after_wait = std::exchange(waited, false); attempt > 1 && !after_wait) {
      std::this_thread::sleep_for(absl::ToChronoMilliseconds(backoff));
      backoff = std::min(2 * backoff, options_.max_backoff);
    }
    grpc::ClientContext context;
    Prepare(context, route);
    context.set_deadline(absl::ToChronoTime(absl::Now() + timeout));
    Response response;
    status = (stub_.get()->*method)(&context, request, &response);
    const auto& answered = context.GetServerInitialMetadata();
    if (auto it = answered.find(api::kReplicaHeader); it != answered.end()) {
      absl::MutexLock lock(&replica_mu_);
      last_replica_.assign(it->second.data(), it->second.size());
    }
    if (status.ok()) return response;
    if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      // Asked to come back later (take-off pacing): wait as long as the
      // server says, within max_retry_after; this is not a failed attempt.
      const std::optional<std::int64_t> ms = api::RetryAfterMs(context);
      if (ms.has_value() && absl::Milliseconds(*ms) <= options_.max_retry_after - paced) {
        std::this_thread::sleep_for(std::chrono::milliseconds(*ms));
        paced += absl::Milliseconds(*ms);
        ++paced_calls_;
        --attempt;
        waited = true;
        continue;
      }
    }
    if (!AskAgain(status)) break;
    if (attempt < options_.max_attempts) ++retried_calls_;
  }
  return api::FromGrpcStatus(status, what);
}

std::string Client::last_replica() const {
  absl::MutexLock lock(&replica_mu_);
  return last_replica_;
}

absl::Status Client::WaitUntilServing(absl::Duration timeout) {
  const absl::Time until = absl::Now() + timeout;
  while (absl::Now() < until) {
    if (channel_->WaitForConnected(absl::ToChronoTime(absl::Now() + absl::Milliseconds(500)))) {
      // gRPC's health service, the server as a whole (""; the service's own
      // status also says NOT_SERVING while its planning queue is full). It
      // needs no token, so a probe without one (a container's HEALTHCHECK)
      // sees a server that has tenants.
      grpc::ClientContext context;
      context.set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(2)));
      grpc::health::v1::HealthCheckRequest request;
      grpc::health::v1::HealthCheckResponse response;
      if (grpc::health::v1::Health::NewStub(channel_)->Check(&context, request, &response).ok() &&
          response.status() == grpc::health::v1::HealthCheckResponse::SERVING) {
        return absl::OkStatus();
      }
    }
  }
  return absl::UnavailableError("server: not serving within the timeout");
}

absl::StatusOr<v1::Mission> Client::CreateMission(const v1::MissionSpec& spec,
                                                  const std::string& mission_id) {
  v1::CreateMissionRequest request;
  request.set_mission_id(mission_id);
  *request.mutable_spec() = spec;
  request.set_request_id(NextRequestId());
  return Call<v1::CreateMissionRequest, v1::Mission>(
      "CreateMission", &v1::MissionService::Stub::CreateMission, request, options_.call_timeout,
      mission_id.empty() ? request.request_id() : mission_id);
}

absl::StatusOr<v1::Mission> Client::GetMission(const std::string& name) {
  v1::GetMissionRequest request;
  request.set_name(name);
  return Call<v1::GetMissionRequest, v1::Mission>("GetMission",
                                                  &v1::MissionService::Stub::GetMission, request,
                                                  options_.call_timeout, RouteOf(name));
}

absl::Status Client::DeleteMission(const std::string& name) {
  v1::DeleteMissionRequest request;
  request.set_name(name);
  request.set_request_id(NextRequestId());
  return Call<v1::DeleteMissionRequest, v1::DeleteMissionResponse>(
             "DeleteMission", &v1::MissionService::Stub::DeleteMission, request,
             options_.call_timeout, RouteOf(name))
      .status();
}

absl::StatusOr<v1::AddMeasurementResponse> Client::AddMeasurement(
    v1::AddMeasurementRequest request) {
  if (request.request_id().empty()) request.set_request_id(NextRequestId());
  return Call<v1::AddMeasurementRequest, v1::AddMeasurementResponse>(
      "AddMeasurement", &v1::MissionService::Stub::AddMeasurement, request, options_.call_timeout,
      RouteOf(request.name()));
}

absl::StatusOr<v1::PlanPathResponse> Client::PlanPath(v1::PlanPathRequest request) {
  if (request.request_id().empty()) request.set_request_id(NextRequestId());
  return Call<v1::PlanPathRequest, v1::PlanPathResponse>(
      "PlanPath", &v1::MissionService::Stub::PlanPath, request, options_.plan_timeout,
      RouteOf(request.name()));
}

absl::StatusOr<v1::ExportPathResponse> Client::ExportPath(const v1::ExportPathRequest& request) {
  return Call<v1::ExportPathRequest, v1::ExportPathResponse>(
      "ExportPath", &v1::MissionService::Stub::ExportPath, request, options_.call_timeout,
      RouteOf(request.name()));
}

absl::StatusOr<v1::GetMapResponse> Client::GetMap(const std::string& name, bool cells, bool png) {
  v1::GetMapRequest request;
  request.set_name(name);
  request.set_include_cells(cells);
  request.set_include_png(png);
  return Call<v1::GetMapRequest, v1::GetMapResponse>("GetMap", &v1::MissionService::Stub::GetMap,
                                                     request, options_.call_timeout, RouteOf(name));
}

}  // namespace oaipp::client

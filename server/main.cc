// oaipp-server: the OA-IPP planning service.
//
//   oaipp-server --listen=127.0.0.1:50051 --metrics_listen=127.0.0.1:9464 --data_dir=./data
//
// Missions are kept in --data_dir/missions.db (SQLite), or in PostgreSQL
// with --store=postgresql://..., and come back after a restart or a crash;
// --store=memory keeps them in memory only.
//
// Health checking (grpc.health.v1) is on, and server reflection unless
// --reflection=false. TLS (--tls_cert, --tls_key; mutual with
// --tls_client_ca) and bearer tokens (--token_file) say who gets in; without
// TLS the server listens only on loopback unless --allow_insecure_remote.
// SIGTERM or SIGINT: stop accepting calls, let in-flight calls finish (up to
// --shutdown_grace_s), exit 0.
#include <string>

#include "absl/flags/parse.h"
#include "google/protobuf/stubs/logging.h"
#include "server/flags/flags.h"
#include "server/library_settings.h"
#include "server/server.h"
#include "server/stop_signals.h"
#include "spdlog/spdlog.h"

namespace {

// 2 for a bad setting (the operator's to fix), 1 for anything else.
int ExitCode(const absl::Status& status) {
  return status.code() == absl::StatusCode::kInvalidArgument ? 2 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  oaipp::server::SetServerFlagsUsage(
      "OA-IPP planning service (oaipp.v1.MissionService)\n\n"
      "  oaipp-server --listen=127.0.0.1:50051 --data_dir=./data\n\n"
      "--help lists the server's flags by group; --helpfull adds gRPC's and Abseil's.");
  absl::ParseCommandLine(argc, argv);
  const oaipp::server::ServerOptions options = oaipp::server::ServerOptionsFromFlags();
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  if (absl::Status valid = options.Validate(); !valid.ok()) {
    spdlog::error("bad flags: {}", std::string(valid.message()));
    return 2;
  }
  spdlog::set_level(spdlog::level::from_str(options.log_level));
  // Before any thread starts: the numeric libraries' threads.
  const absl::StatusOr<oaipp::server::NumericSetup> numeric =
      oaipp::server::SetUpNumericLibraries();
  if (!numeric.ok()) {
    spdlog::error("{}", std::string(numeric.status().message()));
    return 1;
  }
  spdlog::info("{}", numeric->summary);
  if (!numeric->warning.empty()) spdlog::warn("{}", numeric->warning);
  // Protobuf writes a line to stderr for every request it cannot parse (a
  // string field that is not UTF-8, say), so any client could flood the
  // log; the caller is told by its status, and the line becomes debug.
  google::protobuf::SetLogHandler(
      [](google::protobuf::LogLevel, const char*, int, const std::string& message) {
        spdlog::debug("protobuf: {}", message.substr(0, 200));
      });

  // SIGTERM and SIGINT drain the server from here on, whichever thread
  // receives them (server/stop_signals.h says why a mask is not enough).
  absl::StatusOr<oaipp::server::StopSignals> stop_signals = oaipp::server::StopSignals::Install();
  if (!stop_signals.ok()) {
    spdlog::error("{}", std::string(stop_signals.status().message()));
    return 1;
  }

  absl::StatusOr<std::unique_ptr<oaipp::server::Server>> server =
      oaipp::server::Server::Start(options);
  if (!server.ok()) {
    spdlog::error("{}", std::string(server.status().message()));
    return ExitCode(server.status());
  }
  const int signal = stop_signals->Wait();
  spdlog::info("signal {}: no new calls; finishing the ones in flight", signal);
  (*server)->Shutdown(absl::Seconds(options.shutdown_grace_s));
  server->reset();
  spdlog::info("oaipp-server stopped");
  return 0;
}

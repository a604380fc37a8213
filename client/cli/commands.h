// What the oaipp-client commands (client/cli/client_main.cc,
// eval_command.cc) share: the flags that reach the server and name the
// output folder, and the helpers that read them.
#pragma once

#include <memory>
#include <string>

#include "absl/flags/declare.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/client.h"
#include "sim/scenario.h"

ABSL_DECLARE_FLAG(std::string, server);
ABSL_DECLARE_FLAG(std::string, out);

namespace oaipp::client::cli {

// Prints "error: <status>" to stderr; returns the exit status 1.
int Fail(const absl::Status& status);
// How to reach the server: --token (or OAIPP_TOKEN) and the TLS flags.
[[nodiscard]] ClientOptions Options();
// A channel to --server with Options().
[[nodiscard]] absl::StatusOr<std::shared_ptr<grpc::Channel>> OpenChannel();
// The scenario file at `path`, its prior map file and map files
// (search_files) read, with --replan_on_detection and --detector_noise
// (--detector_false_positives) applied; the map files' dropped lines go to
// stderr.
[[nodiscard]] absl::StatusOr<v1::Scenario> LoadScenario(const std::string& path);

// `oaipp-client eval EXPERIMENT`: its exit status.
int Eval(const std::string& experiment);
// `oaipp-client eval E8` (client/cli/e8_command.cc): its exit status.
int EvalE8();

}  // namespace oaipp::client::cli

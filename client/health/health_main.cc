// oaipp-health: exit 0 when an oaipp-server answers gRPC's health check
// (the server as a whole) with SERVING, 1 otherwise. The probe of the
// server-only container image: it links the RPC client library and nothing
// of the simulator, the renderer or OpenCV, and needs no token.
//
//   oaipp-health [--server=127.0.0.1:50051] [--tls_ca=ca.pem] [--timeout_s=5]

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/client.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051", "address of the oaipp-server (host:port)");
ABSL_FLAG(std::string, tls_ca, "", "PEM CA bundle that signed the server's certificate (TLS)");
ABSL_FLAG(std::string, tls_cert, "", "PEM client certificate, for a server that asks for one");
ABSL_FLAG(std::string, tls_key, "", "PEM private key of --tls_cert");
ABSL_FLAG(double, timeout_s, 5.0, "seconds to wait for SERVING, in (0, 300]");

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "oaipp-health [--server=HOST:PORT] [--tls_ca=PEM]: exit 0 when the server is serving");
  const std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  if (args.size() != 1) {
    std::fprintf(stderr, "oaipp-health takes no arguments, only flags (--help)\n");
    return 2;
  }
  const double timeout_s = absl::GetFlag(FLAGS_timeout_s);
  if (!(timeout_s > 0.0 && timeout_s <= 300.0)) {
    std::fprintf(stderr, "--timeout_s: must be in (0, 300]\n");
    return 2;
  }
  oaipp::client::ClientOptions options;
  options.tls_ca_file = absl::GetFlag(FLAGS_tls_ca);
  options.tls_cert_file = absl::GetFlag(FLAGS_tls_cert);
  options.tls_key_file = absl::GetFlag(FLAGS_tls_key);
  const std::string server = absl::GetFlag(FLAGS_server);
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel =
      oaipp::client::Client::OpenChannel(server, options);
  if (!channel.ok()) {
    std::fprintf(stderr, "%s\n", channel.status().ToString().c_str());
    return 2;
  }
  oaipp::client::Client client(*channel, options);
  const absl::Status up = client.WaitUntilServing(absl::Seconds(timeout_s));
  if (!up.ok()) {
    std::fprintf(stderr, "%s: %s\n", server.c_str(), up.ToString().c_str());
    return 1;
  }
  std::printf("%s: serving\n", server.c_str());
  return 0;
}

#include "server/metrics_http.h"

#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "httplib.h"
#include "prometheus/text_serializer.h"
#include "server/http_serving.h"

namespace oaipp::server {
namespace {

// Scrapes are rare and short; two threads let one slow reader not hold up
// the next scrape.
constexpr int kMetricsThreads = 2;
constexpr const char* kTextFormat = "text/plain; version=0.0.4; charset=utf-8";

absl::Status BadListen(const std::string& listen, const char* reason) {
  return absl::InvalidArgumentError(
      absl::StrCat("metrics_listen: ", reason, " (got \"", listen.substr(0, 64), "\")"));
}

}  // namespace

MetricsHttp::MetricsHttp(std::shared_ptr<prometheus::Registry> registry)
    : registry_(std::move(registry)), http_(std::make_unique<httplib::Server>()) {}

MetricsHttp::~MetricsHttp() { Stop(); }

std::string MetricsHttp::Body() const {
  return prometheus::TextSerializer().Serialize(registry_->Collect());
}

absl::Status MetricsHttp::Start(const std::string& listen) {
  if (stopping_ || port_ != 0) {
    return absl::FailedPreconditionError("metrics_listen: the endpoint was started or stopped");
  }
  std::string host = "0.0.0.0";
  std::string port_text = listen;
  if (const size_t colon = listen.rfind(':'); colon != std::string::npos) {
    host = listen.substr(0, colon);
    port_text = listen.substr(colon + 1);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
      host = host.substr(1, host.size() - 2);
    }
    if (host.empty()) return BadListen(listen, "empty host");
  }
  int port = 0;
  if (!absl::SimpleAtoi(port_text, &port) || port < 0 || port > 65535) {
    return BadListen(listen, "port must be a number in [0, 65535]");
  }

  http_->new_task_queue = [] { return new httplib::ThreadPool(kMetricsThreads); };
  http_->set_payload_max_length(1 << 10);
  // One request per connection: an idle keep-alive scraper would hold one
  // of the two threads for httplib's 5 s idle timeout.
  http_->set_keep_alive_max_count(1);
  http_->Get("/metrics", [this](const httplib::Request&, httplib::Response& res) {
    res.set_content(Body(), kTextFormat);
  });
  port_ = BindExclusive(*http_, host, port);
  if (port_ == 0) {
    return absl::UnavailableError(
        absl::StrCat("metrics_listen: cannot listen on ", listen.substr(0, 64)));
  }
  address_ =
      absl::StrCat(absl::StrContains(host, ':') ? absl::StrCat("[", host, "]") : host, ":", port_);
  listener_.Start(http_.get());
  return absl::OkStatus();
}

void MetricsHttp::Stop() {
  if (stopping_.exchange(true)) return;
  listener_.Stop(http_.get());
}

}  // namespace oaipp::server

// The /metrics endpoint: what a Prometheus scrape reads, and the
// --metrics_listen values it refuses.
#include "server/metrics_http.h"

#include <memory>
#include <string>

#include "absl/strings/match.h"
#include "gtest/gtest.h"
#include "httplib.h"
#include "prometheus/counter.h"
#include "prometheus/registry.h"

namespace oaipp::server {
namespace {

TEST(MetricsHttpTest, ServesTheRegistryInTheTextFormat) {
  auto registry = std::make_shared<prometheus::Registry>();
  auto& family = prometheus::BuildCounter().Name("test_calls_total").Help("h").Register(*registry);
  family.Add({{"method", "PlanPath"}}).Increment(3);
  MetricsHttp http(registry);
  ASSERT_TRUE(http.Start("127.0.0.1:0").ok());
  ASSERT_GT(http.port(), 0);

  httplib::Client client("127.0.0.1", http.port());
  const httplib::Result res = client.Get("/metrics");
  ASSERT_TRUE(res) << httplib::to_string(res.error());
  EXPECT_EQ(res->status, 200);
  EXPECT_TRUE(absl::StartsWith(res->get_header_value("Content-Type"), "text/plain; version=0.0.4"));
  EXPECT_TRUE(absl::StrContains(res->body, "# TYPE test_calls_total counter\n")) << res->body;
  EXPECT_TRUE(absl::StrContains(res->body, "test_calls_total{method=\"PlanPath\"} 3\n"))
      << res->body;

  // The registry is read at every scrape.
  family.Add({{"method", "PlanPath"}}).Increment(2);
  const httplib::Result again = client.Get("/metrics");
  ASSERT_TRUE(again);
  EXPECT_TRUE(absl::StrContains(again->body, "test_calls_total{method=\"PlanPath\"} 5\n"));

  const httplib::Result other = client.Get("/");
  ASSERT_TRUE(other);
  EXPECT_EQ(other->status, 404);
  http.Stop();
  http.Stop();  // idempotent
}

TEST(MetricsHttpTest, RefusesMalformedAddressesNamingTheFlag) {
  for (const char* bad :
       {"127.0.0.1:x", "127.0.0.1:70000", ":9464", "127.0.0.1:-1", "localhost:"}) {
    MetricsHttp http(std::make_shared<prometheus::Registry>());
    const absl::Status st = http.Start(bad);
    EXPECT_EQ(st.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_TRUE(absl::StartsWith(st.message(), "metrics_listen: ")) << st.message();
  }
}

TEST(MetricsHttpTest, ABarePortBindsEveryIpv4Address) {
  MetricsHttp http(std::make_shared<prometheus::Registry>());
  ASSERT_TRUE(http.Start("0").ok());
  EXPECT_EQ(http.address(), "0.0.0.0:" + std::to_string(http.port()));
  httplib::Client client("127.0.0.1", http.port());
  const httplib::Result res = client.Get("/metrics");
  ASSERT_TRUE(res) << httplib::to_string(res.error());
  EXPECT_EQ(res->status, 200);
  // Once stopped it does not start again.
  http.Stop();
  EXPECT_EQ(http.Start("127.0.0.1:0").code(), absl::StatusCode::kFailedPrecondition);
}

TEST(MetricsHttpTest, APortInUseIsUnavailable) {
  MetricsHttp first(std::make_shared<prometheus::Registry>());
  ASSERT_TRUE(first.Start("127.0.0.1:0").ok());
  MetricsHttp second(std::make_shared<prometheus::Registry>());
  const absl::Status st = second.Start("127.0.0.1:" + std::to_string(first.port()));
  EXPECT_EQ(st.code(), absl::StatusCode::kUnavailable) << st;
  EXPECT_TRUE(absl::StartsWith(st.message(), "metrics_listen: cannot listen on 127.0.0.1:"));
}

}  // namespace
}  // namespace oaipp::server

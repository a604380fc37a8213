// The live view's HTTP side, in process: tenants see only their missions,
// a missing token is refused, the picture data follows a measurement, the
// event stream says what happened, and the view will not serve beyond
// loopback without tokens.
#include "server/web_view.h"

#include <chrono>
#include <cmath>
#include <string>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "api/spec.h"
#include "gtest/gtest.h"
#include "httplib.h"
#include "nlohmann/json.hpp"
#include "server/auth.h"
#include "server/registry.h"

namespace oaipp::server {
namespace {

using nlohmann::json;

class WebViewTest : public ::testing::Test {
 protected:
  WebViewTest()
      : auth_(*Authenticator::FromText(absl::StrCat("alpha ", Authenticator::HashToken("token-a"),
                                                    "\nbravo ", Authenticator::HashToken("token-b"),
                                                    "\n"))),
        registry_({.max_missions = 8, .max_cells_per_mission = 1600}),
        view_(&registry_, &auth_) {
    const api::MissionConfig config = *api::MissionSpecToConfig(v1::MissionSpec());
    alpha_ = *registry_.Create("survey", config, "", "", "alpha");
    (void)*registry_.Create("other", config, "", "", "bravo");
    EXPECT_TRUE(view_.Start("127.0.0.1", 0).ok());
  }

  httplib::Result Get(const std::string& path) {
    httplib::Client client("127.0.0.1", view_.port());
    client.set_read_timeout(10, 0);
    return client.Get(path.c_str());
  }

  Authenticator auth_;
  MissionRegistry registry_;
  WebView view_;
  std::shared_ptr<Mission> alpha_;
};

TEST_F(WebViewTest, EachTokenSeesItsOwnTenantOnly) {
  httplib::Result page = Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_TRUE(absl::StrContains(page->body, "OA-IPP mission view"));

  httplib::Result none = Get("/api/missions");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 401);

  httplib::Result a = Get("/api/missions?token=token-a");
  ASSERT_TRUE(a);
  ASSERT_EQ(a->status, 200);
  const json missions = json::parse(a->body).at("missions");
  ASSERT_EQ(missions.size(), 1u);
  EXPECT_EQ(missions[0].at("id"), "survey");

  // Bravo's mission is not there for alpha, in the same words as a missing one.
  httplib::Result other = Get("/api/missions/other?token=token-a");
  ASSERT_TRUE(other);
  EXPECT_EQ(other->status, 404);
  httplib::Result missing = Get("/api/missions/nope?token=token-a");
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  httplib::Result wrong = Get("/api/missions/survey?token=not-a-token");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 401);
  EXPECT_FALSE(absl::StrContains(wrong->body, "not-a-token"));
}

TEST_F(WebViewTest, ThePictureDataFollowsAMeasurement) {
  // One cell seen with a person (label 1), its neighbour without.
  api::MeasurementInput input;
  input.mission_time_s = 2.0;
  input.pose.p_WC = Vec3(0.2, 0.2, 10.0);
  const int seen = 20 * 40 + 20;
  input.labels = CellLabels{{seen, seen + 1}, {1.0, 0.0}};
  ASSERT_TRUE(alpha_->AddMeasurement(input, "m-1").ok());
  ASSERT_TRUE(alpha_->AddMeasurement(input, "m-2").ok());

  httplib::Result r = Get("/api/missions/survey?token=token-a");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  const json m = json::parse(r->body);
  EXPECT_EQ(m.at("measurements_fused"), 2);
  EXPECT_EQ(m.at("sequence"), 2);
  EXPECT_EQ(m.at("field").at("nx"), 40);
  ASSERT_EQ(m.at("mean").size(), 1600u);
  ASSERT_EQ(m.at("std").size(), 1600u);
  EXPECT_EQ(m.at("detections"), json::array({seen}));
  ASSERT_EQ(m.at("flown").size(), 2u);
  EXPECT_NEAR(m.at("flown")[0][2].get<double>(), 10.0, 1e-9);
  // The map itself, read apart: found = cells whose mean is >= 0.5; std = sqrt(P_ii).
  json found = json::array();
  alpha_->ReadMap([&](const GpMap& map) {
    for (int i = 0; i < map.num_cells(); ++i) {
      if (map.Mean()(i) >= 0.5) found.push_back(i);
    }
    EXPECT_NEAR(m.at("std")[seen].get<double>(), std::sqrt(map.Variance(seen)), 1e-4);
    EXPECT_NEAR(m.at("mean")[seen].get<double>(), map.Mean()(seen), 1e-4);
  });
  EXPECT_EQ(m.at("found"), found);
  EXPECT_GT(m.at("mean")[seen].get<double>(), m.at("mean")[seen + 1].get<double>());
}

TEST_F(WebViewTest, TheEventStreamNamesWhatHappened) {
  httplib::Client client("127.0.0.1", view_.port());
  client.set_read_timeout(10, 0);
  std::string received;
  std::thread measure([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    api::MeasurementInput input;
    input.mission_time_s = 1.0;
    input.pose.p_WC = Vec3(0, 0, 10);
    input.labels = CellLabels{{20 * 40 + 20}, {0.0}};
    EXPECT_TRUE(alpha_->AddMeasurement(input, "e-1").ok());
  });
  // Reads until the first event arrives (or 15 s pass), then hangs up.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  (void)client.Get("/api/missions/survey/events?token=token-a",
                   [&](const char* data, std::size_t length) {
                     received.append(data, length);
                     return !absl::StrContains(received, "measurement_fused") &&
                            std::chrono::steady_clock::now() < give_up;
                   });
  measure.join();
  EXPECT_TRUE(absl::StrContains(received, "event: mission")) << received;
  EXPECT_TRUE(absl::StrContains(received, R"("kind":"measurement_fused")")) << received;
  EXPECT_TRUE(absl::StrContains(received, R"("sequence":1)")) << received;
}

TEST(WebViewStartTest, BeyondLoopbackOnlyWithTokens) {
  MissionRegistry registry({.max_missions = 1, .max_cells_per_mission = 1600});
  Authenticator anyone;
  WebView view(&registry, &anyone);
  const absl::Status s = view.Start("0.0.0.0", 0);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StartsWith(s.message(), "web_address: 0.0.0.0 is not loopback")) << s;
}

}  // namespace
}  // namespace oaipp::server

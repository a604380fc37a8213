// The live view's HTTP side, in process: tenants see only their missions,
// a missing token is refused and one in a URL too, a login hands out an
// HttpOnly session cookie, a foreign Host or Origin is refused, the picture
// data follows a measurement, the event stream says what happened, and the
// view will not serve beyond loopback without tokens and TLS.
#include "server/web_view.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

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
    EXPECT_TRUE(view_.Start(WebViewOptions{}).ok());
  }

  // GET with a bearer token (none when empty) and extra headers.
  httplib::Result Get(const std::string& path, const std::string& token = "",
                      httplib::Headers headers = {}) {
    httplib::Client client("127.0.0.1", view_.port());
    client.set_read_timeout(10, 0);
    if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
    return client.Get(path.c_str(), headers);
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

  httplib::Result a = Get("/api/missions", "token-a");
  ASSERT_TRUE(a);
  ASSERT_EQ(a->status, 200);
  const json missions = json::parse(a->body).at("missions");
  ASSERT_EQ(missions.size(), 1u);
  EXPECT_EQ(missions[0].at("id"), "survey");

  // Bravo's mission is not there for alpha, in the same words as a missing one.
  httplib::Result other = Get("/api/missions/other", "token-a");
  ASSERT_TRUE(other);
  EXPECT_EQ(other->status, 404);
  httplib::Result missing = Get("/api/missions/nope", "token-a");
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  httplib::Result wrong = Get("/api/missions/survey", "not-a-token");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 401);
  EXPECT_FALSE(absl::StrContains(wrong->body, "not-a-token"));
}

// The page's way in: a token in the Authorization header of POST
// /api/session buys an HttpOnly, SameSite=Strict cookie, which then stands
// for the token (the event stream included) until DELETE /api/session. A
// token in a URL is refused whatever it is, and not echoed.
TEST_F(WebViewTest, ALoginGivesAnHttpOnlyCookieAndTokensStayOutOfUrls) {
  httplib::Client client("127.0.0.1", view_.port());
  client.set_read_timeout(10, 0);
  httplib::Result refused =
      client.Post("/api/session", {{"Authorization", "Bearer nope"}}, "", "text/plain");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 401);
  EXPECT_FALSE(refused->has_header("Set-Cookie"));
  httplib::Result login =
      client.Post("/api/session", {{"Authorization", "Bearer token-a"}}, "", "text/plain");
  ASSERT_TRUE(login);
  ASSERT_EQ(login->status, 204);
  const std::string cookie = login->get_header_value("Set-Cookie");
  EXPECT_TRUE(absl::StartsWith(cookie, "oaipp_session=")) << cookie;
  EXPECT_TRUE(absl::StrContains(cookie, "HttpOnly")) << cookie;
  EXPECT_TRUE(absl::StrContains(cookie, "SameSite=Strict")) << cookie;
  EXPECT_FALSE(absl::StrContains(cookie, "token-a"));
  const std::string session = cookie.substr(0, cookie.find(';'));
  EXPECT_EQ(session.size(), std::string("oaipp_session=").size() + 64);  // 32 random bytes

  httplib::Result listed = Get("/api/missions", "", {{"Cookie", "theme=dark; " + session}});
  ASSERT_TRUE(listed);
  ASSERT_EQ(listed->status, 200);
  EXPECT_EQ(json::parse(listed->body).at("missions")[0].at("id"), "survey");
  httplib::Result forged =
      Get("/api/missions", "", {{"Cookie", "oaipp_session=" + std::string(64, 'a')}});
  ASSERT_TRUE(forged);
  EXPECT_EQ(forged->status, 401);

  httplib::Result in_url = Get("/api/missions?token=token-a");
  ASSERT_TRUE(in_url);
  EXPECT_EQ(in_url->status, 400);
  EXPECT_TRUE(absl::StrContains(in_url->body, "token in a URL is refused"));
  EXPECT_FALSE(absl::StrContains(in_url->body, "token-a"));

  httplib::Result logout = client.Delete("/api/session", {{"Cookie", session}});
  ASSERT_TRUE(logout);
  EXPECT_EQ(logout->status, 204);
  httplib::Result after = Get("/api/missions", "", {{"Cookie", session}});
  ASSERT_TRUE(after);
  EXPECT_EQ(after->status, 401);
}

// DNS rebinding and cross-site scripts: a request naming another Host, or
// sent from a page of another Origin, is refused before any route runs,
// with a valid token or not; the view's own names pass.
TEST_F(WebViewTest, AForeignHostOrOriginIsRefused) {
  const std::string port = std::to_string(view_.port());
  for (const std::string& host :
       std::vector<std::string>{"evil.example:" + port, "evil.example", "127.0.0.2:" + port}) {
    httplib::Result r = Get("/api/missions", "token-a", {{"Host", host}});
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 421) << host;
    httplib::Result page = Get("/", "", {{"Host", host}});
    ASSERT_TRUE(page);
    EXPECT_EQ(page->status, 421) << host;
  }
  httplib::Result origin =
      Get("/api/missions", "token-a", {{"Origin", "http://evil.example:" + port}});
  ASSERT_TRUE(origin);
  EXPECT_EQ(origin->status, 403);
  for (const std::string& host :
       std::vector<std::string>{"localhost:" + port, "127.0.0.1:" + port, "LOCALHOST:" + port}) {
    httplib::Result ok =
        Get("/api/missions", "token-a", {{"Host", host}, {"Origin", "http://" + host}});
    ASSERT_TRUE(ok);
    EXPECT_EQ(ok->status, 200) << host;
  }
}

// A team's picture data: a line per UAV of the team, in the spec's order,
// each holding only what that UAV reported (one that has not is empty).
TEST_F(WebViewTest, EachUavOfATeamHasItsOwnLines) {
  v1::MissionSpec spec;
  for (const auto& [id, x] :
       {std::pair{"west", -8.0}, std::pair{"east", 8.0}, std::pair{"north", 0.0}}) {
    v1::TeamMember& m = *spec.add_team();
    m.set_uav_id(id);
    m.mutable_start()->mutable_position_m()->set_x(x);
    m.mutable_start()->mutable_position_m()->set_y(std::string(id) == "north" ? 8.0 : 0.0);
    m.mutable_start()->mutable_position_m()->set_z(10.0);
  }
  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(spec);
  ASSERT_TRUE(config.ok()) << config.status();
  absl::StatusOr<std::shared_ptr<Mission>> team =
      registry_.Create("team", *config, "", "", "alpha");
  ASSERT_TRUE(team.ok()) << team.status();
  for (const auto& [uav, x] :
       {std::pair{"east", 7.0}, std::pair{"west", -7.0}, std::pair{"east", 6.0}}) {
    api::MeasurementInput input;
    input.mission_time_s = 1.0;
    input.pose.p_WC = Vec3(x, 0.0, 10.0);
    input.labels = CellLabels{{20 * 40 + 20}, {0.0}};
    input.uav_id = uav;
    ASSERT_TRUE((*team)->AddMeasurement(input, absl::StrCat(uav, x)).ok());
  }
  httplib::Result r = Get("/api/missions/team", "token-a");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  const json uavs = json::parse(r->body).at("uavs");
  ASSERT_EQ(uavs.size(), 3u);
  EXPECT_EQ(uavs[0].at("uav_id"), "west");
  EXPECT_EQ(uavs[1].at("uav_id"), "east");
  EXPECT_EQ(uavs[2].at("uav_id"), "north");
  ASSERT_EQ(uavs[0].at("flown").size(), 1u);
  EXPECT_NEAR(uavs[0].at("flown")[0][0].get<double>(), -7.0, 1e-9);
  ASSERT_EQ(uavs[1].at("flown").size(), 2u);
  EXPECT_NEAR(uavs[1].at("flown")[1][0].get<double>(), 6.0, 1e-9);
  EXPECT_TRUE(uavs[2].at("flown").empty());
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

  httplib::Result r = Get("/api/missions/survey", "token-a");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  const json m = json::parse(r->body);
  EXPECT_EQ(m.at("measurements_fused"), 2);
  EXPECT_EQ(m.at("sequence"), 2);
  EXPECT_EQ(m.at("field").at("nx"), 40);
  ASSERT_EQ(m.at("mean").size(), 1600u);
  ASSERT_EQ(m.at("std").size(), 1600u);
  EXPECT_EQ(m.at("detections"), json::array({seen}));
  ASSERT_EQ(m.at("uavs").size(), 1u);  // one UAV, without a team: uav_id ""
  EXPECT_EQ(m.at("uavs")[0].at("uav_id"), "");
  ASSERT_EQ(m.at("uavs")[0].at("flown").size(), 2u);
  EXPECT_NEAR(m.at("uavs")[0].at("flown")[0][2].get<double>(), 10.0, 1e-9);
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

// The search area, the fence and the no-fly zones come with the picture
// data as rings in metres: the area's outer ring and hole as given, a
// circular fence as 64 points on its circle, a zone's footprint; and the
// home as a point.
TEST_F(WebViewTest, TheAreaTheFenceAndTheZonesAreInThePictureData) {
  v1::MissionSpec spec;
  v1::AreaPolygon& area = *spec.add_search_areas();
  for (const double v : {-10.0, -10.0, 10.0, -10.0, 10.0, 10.0, -10.0, 10.0}) {
    area.mutable_outer()->add_xy_m(v);
  }
  v1::Ring& hole = *area.add_holes();
  for (const double v : {-2.0, -2.0, -2.0, 2.0, 2.0, 2.0, 2.0, -2.0}) hole.add_xy_m(v);
  v1::Circle& circle = *spec.mutable_fence()->mutable_circle();
  circle.set_x_m(1.0);
  circle.set_y_m(-1.0);
  circle.set_radius_m(14.0);
  v1::Obstacle& zone = *spec.add_no_fly_zones();
  zone.set_id("school");
  zone.mutable_box()->mutable_centre_m()->set_x(6);
  zone.mutable_box()->mutable_centre_m()->set_y(6);
  zone.mutable_box()->mutable_centre_m()->set_z(30);
  zone.mutable_box()->mutable_size_m()->set_x(2);
  zone.mutable_box()->mutable_size_m()->set_y(4);
  zone.mutable_box()->mutable_size_m()->set_z(20);
  spec.mutable_home()->mutable_position_m()->set_x(-3.5);
  spec.mutable_home()->mutable_position_m()->set_y(4.25);
  spec.mutable_home()->mutable_position_m()->set_z(8);
  const absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(spec);
  ASSERT_TRUE(config.ok()) << config.status();
  ASSERT_TRUE(registry_.Create("fenced", *config, "", "", "alpha").ok());
  httplib::Result r = Get("/api/missions/fenced", "token-a");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  const json m = json::parse(r->body);
  ASSERT_EQ(m.at("search_area").size(), 2u);  // the outer ring and the hole
  EXPECT_EQ(m.at("search_area")[0].size(), 4u);
  EXPECT_EQ(m.at("search_area")[1].size(), 4u);
  ASSERT_EQ(m.at("fence").size(), 1u);
  ASSERT_EQ(m.at("fence")[0].size(), 64u);
  for (const json& p : m.at("fence")[0]) {
    EXPECT_NEAR(std::hypot(p[0].get<double>() - 1.0, p[1].get<double>() + 1.0), 14.0, 1e-3);
  }
  ASSERT_EQ(m.at("no_fly_zones").size(), 1u);
  ASSERT_EQ(m.at("no_fly_zones")[0].size(), 4u);
  for (const json& p : m.at("no_fly_zones")[0]) {
    EXPECT_EQ(std::abs(p[0].get<double>() - 6.0), 1.0);
    EXPECT_EQ(std::abs(p[1].get<double>() - 6.0), 2.0);
  }
  EXPECT_EQ(m.at("home")[0].get<double>(), -3.5);
  EXPECT_EQ(m.at("home")[1].get<double>(), 4.25);
  // Without any: empty lists, no home.
  const json plain = json::parse(Get("/api/missions/survey", "token-a")->body);
  EXPECT_TRUE(plain.at("home").is_null());
  EXPECT_TRUE(plain.at("search_area").empty());
  EXPECT_TRUE(plain.at("fence").empty());
  EXPECT_TRUE(plain.at("no_fly_zones").empty());
}

TEST_F(WebViewTest, TheEventStreamNamesWhatHappened) {
  httplib::Client client("127.0.0.1", view_.port());
  client.set_read_timeout(10, 0);
  std::string received;
  bool measured = false;
  // Reads until the first event arrives (or 15 s pass), then hangs up. The
  // stream greets once the server has subscribed it to the mission (events
  // are not replayed), so the measurement is made after the greeting, not
  // after a guess at how long subscribing takes.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  (void)client.Get("/api/missions/survey/events", {{"Authorization", "Bearer token-a"}},
                   [&](const char* data, std::size_t length) {
                     received.append(data, length);
                     if (!measured && absl::StrContains(received, ": connected")) {
                       measured = true;
                       api::MeasurementInput input;
                       input.mission_time_s = 1.0;
                       input.pose.p_WC = Vec3(0, 0, 10);
                       input.labels = CellLabels{{20 * 40 + 20}, {0.0}};
                       EXPECT_TRUE(alpha_->AddMeasurement(input, "e-1").ok());
                     }
                     return !absl::StrContains(received, "measurement_fused") &&
                            std::chrono::steady_clock::now() < give_up;
                   });
  EXPECT_TRUE(measured) << "the stream never greeted: " << received;
  EXPECT_TRUE(absl::StrContains(received, "event: mission")) << received;
  EXPECT_TRUE(absl::StrContains(received, R"("kind":"measurement_fused")")) << received;
  EXPECT_TRUE(absl::StrContains(received, R"("sequence":1)")) << received;
}

// A field of more than 160 cells a side (200 x 170 cells at 1 m, on the
// sparse map) is shown in blocks of 2 x 2 cells: each block the mean of its
// cells' means and the root mean square of their standard deviations, as
// computed here from the map itself; a detection marks its block.
TEST(WebViewBlocksTest, ALargeFieldIsShownInBlocks) {
  const Authenticator auth =
      *Authenticator::FromText(absl::StrCat("alpha ", Authenticator::HashToken("token-a"), "\n"));
  MissionRegistry registry({.max_missions = 2, .max_cells_per_mission = 40000});
  WebView view(&registry, &auth);
  v1::MissionSpec spec;
  spec.mutable_field()->set_x_min_m(0);
  spec.mutable_field()->set_y_min_m(0);
  spec.mutable_field()->set_x_max_m(200);
  spec.mutable_field()->set_y_max_m(170);
  spec.mutable_field()->set_resolution_m(1.0);
  const std::shared_ptr<Mission> big =
      *registry.Create("big", *api::MissionSpecToConfig(spec), "", "", "alpha");
  ASSERT_EQ(big->config().map_backend, api::MapBackend::kSparse);
  ASSERT_TRUE(view.Start(WebViewOptions{}).ok());
  const int seen = 101 * 200 + 151;  // row 101, column 151: block (50, 75)
  api::MeasurementInput input;
  input.mission_time_s = 1.0;
  input.pose.p_WC = Vec3(151.5, 101.5, 10.0);
  input.labels = CellLabels{{seen, seen - 1, seen - 200}, {1.0, 1.0, 1.0}};
  ASSERT_TRUE(big->AddMeasurement(input, "").ok());
  ASSERT_TRUE(big->AddMeasurement(input, "").ok());

  httplib::Client client("127.0.0.1", view.port());
  client.set_read_timeout(30, 0);
  httplib::Result r = client.Get("/api/missions/big", {{"Authorization", "Bearer token-a"}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const json m = json::parse(r->body);
  EXPECT_EQ(m.at("field").at("nx"), 100);
  EXPECT_EQ(m.at("field").at("ny"), 85);
  EXPECT_EQ(m.at("field").at("resolution_m"), 2.0);
  ASSERT_EQ(m.at("mean").size(), 8500u);
  ASSERT_EQ(m.at("std").size(), 8500u);
  const int block = 50 * 100 + 75;
  EXPECT_EQ(m.at("detections"), json::array({block}));
  ASSERT_TRUE(big->ReadMapView([&](const api::MapView& map) {
                   for (const int b : {0, block, 8499}) {
                     const int row = b / 100, col = b % 100;
                     double mean = 0.0, variance = 0.0;
                     for (const int cell :
                          {2 * row * 200 + 2 * col, 2 * row * 200 + 2 * col + 1,
                           (2 * row + 1) * 200 + 2 * col, (2 * row + 1) * 200 + 2 * col + 1}) {
                       mean += (*map.mean)[cell] / 4.0;
                       variance += (*map.variances)[cell] / 4.0;
                     }
                     EXPECT_NEAR(m.at("mean")[b].get<double>(), mean, 1e-4) << b;
                     EXPECT_NEAR(m.at("std")[b].get<double>(), std::sqrt(variance), 1e-4) << b;
                   }
                 })
                  .ok());
  view.Stop();
}

TEST(WebViewStartTest, BeyondLoopbackOnlyWithTokensAndTls) {
  MissionRegistry registry({.max_missions = 1, .max_cells_per_mission = 1600});
  Authenticator anyone;
  WebView view(&registry, &anyone);
  const absl::Status s = view.Start({.address = "0.0.0.0"});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StartsWith(s.message(), "web_address: 0.0.0.0 is not loopback")) << s;
  EXPECT_TRUE(absl::StrContains(s.message(), "--token_file")) << s;

  Authenticator tokens =
      *Authenticator::FromText(absl::StrCat("alpha ", Authenticator::HashToken("t"), "\n"));
  WebView with_tokens(&registry, &tokens);
  const absl::Status plain = with_tokens.Start({.address = "0.0.0.0", .host_names = {"ground"}});
  EXPECT_EQ(plain.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StrContains(plain.message(), "--tls_cert and --tls_key")) << plain;
  const absl::Status nameless =
      with_tokens.Start({.address = "0.0.0.0", .tls_cert = "c.pem", .tls_key = "k.pem"});
  EXPECT_EQ(nameless.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StartsWith(nameless.message(), "web_hosts:")) << nameless;
}

// With the server's certificate the view serves HTTPS (on loopback here;
// the same holds off it), and its session cookie is Secure.
TEST(WebViewStartTest, WithTlsTheViewServesHttpsAndSecureCookies) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / absl::StrCat("oaipp-web-tls-", getpid());
  std::filesystem::create_directories(dir);
  const std::string d = dir.string();
  ASSERT_EQ(std::system(("cd " + d +
                         " && openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=localhost"
                         " -addext subjectAltName=IP:127.0.0.1 -keyout key.pem -out cert.pem"
                         " >/dev/null 2>&1")
                            .c_str()),
            0);
  MissionRegistry registry({.max_missions = 1, .max_cells_per_mission = 1600});
  Authenticator tokens =
      *Authenticator::FromText(absl::StrCat("alpha ", Authenticator::HashToken("t"), "\n"));
  WebView view(&registry, &tokens);
  ASSERT_TRUE(
      view.Start({.address = "127.0.0.1", .tls_cert = d + "/cert.pem", .tls_key = d + "/key.pem"})
          .ok());
  httplib::SSLClient client("127.0.0.1", view.port());
  client.set_ca_cert_path((d + "/cert.pem").c_str());
  client.enable_server_certificate_verification(true);
  client.set_read_timeout(10, 0);
  httplib::Result page = client.Get("/");
  ASSERT_TRUE(page) << httplib::to_string(page.error());
  EXPECT_EQ(page->status, 200);
  httplib::Result login =
      client.Post("/api/session", {{"Authorization", "Bearer t"}}, "", "text/plain");
  ASSERT_TRUE(login);
  EXPECT_EQ(login->status, 204);
  EXPECT_TRUE(absl::StrContains(login->get_header_value("Set-Cookie"), "; Secure"));
  httplib::Client plain("127.0.0.1", view.port());
  plain.set_read_timeout(5, 0);
  httplib::Result cleartext = plain.Get("/");
  EXPECT_TRUE(!cleartext || cleartext->status != 200);
  view.Stop();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace oaipp::server

#include "server/web_view.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <utility>
#include <vector>

#include "absl/container/flat_hash_map.h"
#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "api/ground_outlines.h"
#include "api/map.h"
#include "core/common/status_macros.h"
#include "httplib.h"
#include "nlohmann/json.hpp"
#include "openssl/rand.h"
#include "server/http_serving.h"
#include "server/web/index_html.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {
namespace {

using nlohmann::json;

constexpr int kThreads = WebView::kMaxStreams + 4;  // streams hold a thread each
constexpr const char* kJson = "application/json";
// A large field's map is shown in blocks, at most this many a side.
constexpr int kMaxShownSide = 160;
constexpr const char* kSessionCookie = "oaipp_session";
// Numbers in the JSON: enough digits for a picture, a quarter of the bytes.
double Short(double v) { return std::round(v * 1e4) / 1e4; }

json Point(const Vec3& p) { return json::array({Short(p.x()), Short(p.y()), Short(p.z())}); }

bool IsLoopback(const std::string& address) {
  return address == "127.0.0.1" || address == "::1" || address == "localhost" ||
         absl::StartsWith(address, "127.");
}

void Error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(json{{"error", message}}.dump(), kJson);
}

// The value of the session cookie the request carries, if any.
std::optional<std::string> SessionId(const httplib::Request& req) {
  for (absl::string_view cookie :
       absl::StrSplit(req.get_header_value("Cookie"), ';', absl::SkipWhitespace())) {
    cookie = absl::StripAsciiWhitespace(cookie);
    if (absl::ConsumePrefix(&cookie, kSessionCookie) && absl::ConsumePrefix(&cookie, "=")) {
      return std::string(cookie);
    }
  }
  return std::nullopt;
}

const char* EventKind(const MissionEventData& e) {
  if (std::holds_alternative<MissionEventData::MeasurementFused>(e.event)) {
    return "measurement_fused";
  }
  if (std::holds_alternative<MissionEventData::ObstaclesChanged>(e.event)) {
    return "obstacles_changed";
  }
  if (std::holds_alternative<MissionEventData::PathPlanned>(e.event)) return "path_planned";
  if (std::holds_alternative<MissionEventData::MemberRemoved>(e.event)) {
    return "team_member_removed";
  }
  return "mission_deleted";
}

}  // namespace

WebView::WebView(MissionRegistry* registry, const Authenticator* auth)
    : registry_(registry), auth_(auth) {}

WebView::~WebView() { Stop(); }

absl::Status WebView::Start(const WebViewOptions& options) {
  const std::string& address = options.address;
  const bool loopback = IsLoopback(address);
  if (!loopback && (auth_ == nullptr || !auth_->enabled())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "web_address: ", address.substr(0, 64),
        " is not loopback; the view shows mission data, so serve it beyond this machine only "
        "with --token_file"));
  }
  tls_ = !options.tls_cert.empty() && !options.tls_key.empty();
  if (!loopback && !tls_) {
    return absl::InvalidArgumentError(absl::StrCat(
        "web_address: ", address.substr(0, 64),
        " is not loopback; the view's session and tokens would cross the network in the clear, "
        "so serve it beyond this machine only with --tls_cert and --tls_key"));
  }
  const bool wildcard = address == "0.0.0.0" || address == "::" || address == "[::]";
  if (wildcard && options.host_names.empty()) {
    return absl::InvalidArgumentError(
        "web_hosts: name the host names the view is reached by (it binds a wildcard address, "
        "and answers only requests whose Host is one of its names)");
  }
  if (tls_) {
    http_ = std::make_unique<httplib::SSLServer>(options.tls_cert.c_str(), options.tls_key.c_str());
    if (!http_->is_valid()) {
      return absl::UnavailableError("web_port: cannot serve HTTPS with --tls_cert and --tls_key");
    }
  } else {
    http_ = std::make_unique<httplib::Server>();
  }
  http_->new_task_queue = [] { return new httplib::ThreadPool(kThreads); };
  http_->set_payload_max_length(1 << 16);
  http_->set_keep_alive_max_count(100);
  Routes();
  port_ = BindExclusive(*http_, address, options.port);
  if (port_ == 0) {
    return absl::UnavailableError(
        absl::StrCat("web_port: cannot listen on ", address.substr(0, 64), ":", options.port));
  }
  std::vector<std::string> names = options.host_names;
  if (!wildcard) names.push_back(address);
  if (loopback) {
    for (const char* name : {"127.0.0.1", "localhost", "[::1]"}) names.emplace_back(name);
  }
  for (const std::string& name : names) {
    const std::string lower = absl::AsciiStrToLower(name);
    hosts_.insert(lower);
    // A bare name also answers with the view's port.
    if (lower.find(':') == std::string::npos || absl::StartsWith(lower, "[")) {
      if (!absl::StrContains(lower, "]:")) hosts_.insert(absl::StrCat(lower, ":", port_));
    }
  }
  listener_.Start(http_.get());
  spdlog::info("web view: {}://{}:{}/", tls_ ? "https" : "http", address, port_);
  return absl::OkStatus();
}

bool WebView::HostAllowed(const std::string& host) const {
  return hosts_.contains(absl::AsciiStrToLower(host));
}

bool WebView::OriginAllowed(const std::string& origin) const {
  const std::string scheme = tls_ ? "https://" : "http://";
  if (!absl::StartsWith(origin, scheme)) return false;
  return HostAllowed(origin.substr(scheme.size()));
}

std::string WebView::NewSession(const std::string& tenant) {
  unsigned char bytes[32];
  if (RAND_bytes(bytes, sizeof(bytes)) != 1) return std::string();
  const std::string id = absl::BytesToHexString(
      absl::string_view(reinterpret_cast<const char*>(bytes), sizeof(bytes)));
  const absl::Time now = absl::Now();
  absl::MutexLock lock(&sessions_mu_);
  absl::erase_if(sessions_, [&](const auto& entry) { return entry.second.expires <= now; });
  if (sessions_.size() >= static_cast<std::size_t>(kMaxSessions)) {
    auto oldest = std::min_element(
        sessions_.begin(), sessions_.end(),
        [](const auto& a, const auto& b) { return a.second.expires < b.second.expires; });
    sessions_.erase(oldest);
  }
  sessions_[id] = Session{tenant, now + kSessionLifetime};
  return id;
}

std::optional<std::string> WebView::SessionTenant(const std::string& id) {
  absl::MutexLock lock(&sessions_mu_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) return std::nullopt;
  if (it->second.expires <= absl::Now()) {
    sessions_.erase(it);
    return std::nullopt;
  }
  return it->second.tenant;
}

void WebView::Stop() {
  if (stopping_.exchange(true)) return;
  listener_.Stop(http_.get());
}

std::string WebView::MissionsJson(const std::string& tenant) const {
  json missions = json::array();
  for (const auto& [number, mission] : registry_->ListAfter(0, 1000, tenant)) {
    const MissionSnapshot s = mission->Snapshot();
    missions.push_back({{"id", std::string(PublicId(s.id))},
                        {"measurements_fused", s.measurements_fused},
                        {"paths_planned", s.paths_planned},
                        {"trace", Short(s.trace)},
                        {"mission_time_s", Short(s.mission_time_s)},
                        {"finished", mission->finished()}});
  }
  return json{{"missions", std::move(missions)}}.dump();
}

absl::StatusOr<std::string> WebView::MissionJson(const std::string& id,
                                                 const std::string& tenant) const {
  absl::StatusOr<std::shared_ptr<Mission>> found =
      registry_->GetHeld(absl::StrCat("missions/", id), tenant);
  if (!found.ok()) return found.status();
  const Mission& mission = **found;
  // The event number first: a change after it shows up as a newer event,
  // so the page never misses one.
  const std::int64_t sequence = mission.events().last_sequence();
  const MissionSnapshot s = mission.Snapshot();
  const MissionTrack track = mission.Track();
  // A large field is shown in blocks of k x k cells, at most
  // kMaxShownSide a side: each block's mean of the means and root-mean-square
  // standard deviation; found cells and detections by their block.
  int nx = 0, ny = 0, k = 1;
  double x_min = 0.0, y_min = 0.0, resolution = 0.0;
  std::vector<double> mean_sum, variance_sum;
  std::vector<int> cells_in;
  std::set<int> found_blocks;
  const auto block_of = [&](int cell) {
    return (cell / nx) / k * ((nx + k - 1) / k) + (cell % nx) / k;
  };
  OAIPP_RETURN_IF_ERROR(mission.ReadMapView([&](const api::MapView& map) {
    nx = map.grid->nx();
    ny = map.grid->ny();
    x_min = map.grid->min_W().x();
    y_min = map.grid->min_W().y();
    resolution = map.grid->resolution_m();
    k = (std::max(nx, ny) + kMaxShownSide - 1) / kMaxShownSide;
    const std::size_t blocks =
        static_cast<std::size_t>((nx + k - 1) / k) * static_cast<std::size_t>((ny + k - 1) / k);
    mean_sum.assign(blocks, 0.0);
    variance_sum.assign(blocks, 0.0);
    cells_in.assign(blocks, 0);
    for (int i = 0; i < nx * ny; ++i) {
      const auto b = static_cast<std::size_t>(block_of(i));
      const double m = (*map.mean)[i];
      mean_sum[b] += m;
      variance_sum[b] += std::max(0.0, (*map.variances)[i]);
      ++cells_in[b];
      if (m >= kDetectedLabel) found_blocks.insert(static_cast<int>(b));
    }
  }));
  json mean = json::array();
  json std_dev = json::array();
  for (std::size_t b = 0; b < mean_sum.size(); ++b) {
    mean.push_back(Short(mean_sum[b] / cells_in[b]));
    std_dev.push_back(Short(std::sqrt(variance_sum[b] / cells_in[b])));
  }
  json found_cells = std::vector<int>(found_blocks.begin(), found_blocks.end());
  json detections = json::array();
  if (k == 1) {
    detections = track.detected_cells;
  } else {
    std::set<int> detected;
    for (int cell : track.detected_cells) {
      if (cell >= 0 && cell < nx * ny) detected.insert(block_of(cell));
    }
    detections = std::vector<int>(detected.begin(), detected.end());
  }
  // The world as the map picture draws it (api/ground_outlines.h), rings
  // as [x, y] lists; obstacles with their tops.
  const GroundOutlines ground = api::GroundOutlinesOf(s.config, s.obstacles);
  const auto ring = [](const std::vector<Vec2>& from) {
    json points = json::array();
    for (const Vec2& c : from) points.push_back({Short(c.x()), Short(c.y())});
    return points;
  };
  const auto rings = [&](const std::vector<std::vector<Vec2>>& from) {
    json out = json::array();
    for (const std::vector<Vec2>& r : from) out.push_back(ring(r));
    return out;
  };
  json obstacles = json::array();
  for (std::size_t i = 0; i < s.obstacles.size(); ++i) {
    const Obstacle& o = s.obstacles[i];
    const double top = BoundingBox(o.shape).max_W.z();
    obstacles.push_back(
        {{"id", o.id}, {"polygon", ring(ground.obstacle_footprints[i])}, {"top_m", Short(top)}});
  }
  json area = rings(ground.search_area_rings);
  json fence = rings(ground.fence_rings);
  json no_fly = rings(ground.no_fly_footprints);
  json home = nullptr;
  if (ground.home.has_value()) home = {Short(ground.home->x()), Short(ground.home->y())};
  // Every UAV's own lines, in the spec's team order (its colour on the page).
  json uavs = json::array();
  const auto add_uav = [&](const std::string& uav_id) {
    const auto it = track.uavs.find(uav_id);
    json flown = json::array();
    json planned = json::array();
    if (it != track.uavs.end()) {
      for (const Vec3& p : it->second.flown_W) flown.push_back(Point(p));
      for (const Vec3& p : it->second.planned_W) planned.push_back(Point(p));
    }
    uavs.push_back(
        {{"uav_id", uav_id}, {"flown", std::move(flown)}, {"planned", std::move(planned)}});
  };
  if (s.config.team.empty()) add_uav("");
  for (const api::TeamMember& member : s.config.team) add_uav(member.uav_id);
  json geo = nullptr;
  if (s.config.geo_origin.has_value()) {
    geo = {{"latitude_deg", s.config.geo_origin->latitude_deg},
           {"longitude_deg", s.config.geo_origin->longitude_deg},
           {"altitude_m", s.config.geo_origin->altitude_m}};
  }
  const json out = {{"id", id},
                    {"sequence", sequence},
                    {"trace", Short(s.trace)},
                    {"measurements_fused", s.measurements_fused},
                    {"paths_planned", s.paths_planned},
                    {"mission_time_s", Short(s.mission_time_s)},
                    {"finished", mission.finished()},
                    {"field",
                     {{"nx", (nx + k - 1) / k},
                      {"ny", (ny + k - 1) / k},
                      {"x_min_m", x_min},
                      {"y_min_m", y_min},
                      {"resolution_m", resolution * k},
                      {"cells_per_block", k}}},
                    {"mean", std::move(mean)},
                    {"std", std::move(std_dev)},
                    {"obstacles", std::move(obstacles)},
                    {"search_area", std::move(area)},
                    {"fence", std::move(fence)},
                    {"no_fly_zones", std::move(no_fly)},
                    {"home", std::move(home)},
                    {"uavs", std::move(uavs)},
                    {"detections", std::move(detections)},
                    {"found", std::move(found_cells)},
                    {"geo_origin", std::move(geo)}};
  return out.dump();
}

void WebView::Routes() {
  // Before any route: a Host or an Origin that is not this view's, and a
  // token in the URL, are refused.
  http_->set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (!HostAllowed(req.get_header_value("Host"))) {
      Error(res, 421, "Host: not a name of this view (--web_hosts lists more)");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.has_header("Origin") && !OriginAllowed(req.get_header_value("Origin"))) {
      Error(res, 403, "Origin: not this view's");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.has_param("token")) {
      Error(res, 400,
            "token: a token in a URL is refused (it ends up in logs and history); send it in an "
            "Authorization header, or log in with POST /api/session");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });

  // The caller's tenant, or an answer already written (401): by its
  // Authorization header, else by its session cookie.
  auto tenant_of = [this](const httplib::Request& req,
                          httplib::Response& res) -> std::optional<std::string> {
    if (auth_ == nullptr || !auth_->enabled()) return std::string();
    if (req.has_header("Authorization")) {
      const std::string header = req.get_header_value("Authorization");
      absl::StatusOr<std::string> tenant = auth_->TenantOfHeader(&header);
      if (tenant.ok()) return *tenant;
      Error(res, 401, std::string(tenant.status().message()));
      return std::nullopt;
    }
    if (const std::optional<std::string> id = SessionId(req)) {
      if (std::optional<std::string> tenant = SessionTenant(*id)) return tenant;
    }
    Error(res, 401, "authentication: log in (POST /api/session with an Authorization header)");
    return std::nullopt;
  };

  // Logs in: the token in the Authorization header for an HttpOnly cookie.
  http_->Post("/api/session", [this](const httplib::Request& req, httplib::Response& res) {
    if (auth_ == nullptr || !auth_->enabled()) {
      res.status = 204;  // no tokens here: nothing to log in to
      return;
    }
    const std::string header = req.get_header_value("Authorization");
    absl::StatusOr<std::string> tenant = auth_->TenantOfHeader(header.empty() ? nullptr : &header);
    if (!tenant.ok()) {
      Error(res, 401, std::string(tenant.status().message()));
      return;
    }
    const std::string id = NewSession(*tenant);
    if (id.empty()) {
      Error(res, 503, "no session: the random source failed");
      return;
    }
    res.set_header(
        "Set-Cookie",
        absl::StrCat(kSessionCookie, "=", id, "; Path=/; HttpOnly; SameSite=Strict; Max-Age=",
                     absl::ToInt64Seconds(kSessionLifetime), tls_ ? "; Secure" : ""));
    res.set_header("Cache-Control", "no-store");
    res.status = 204;
  });
  http_->Delete("/api/session", [this](const httplib::Request& req, httplib::Response& res) {
    if (const std::optional<std::string> id = SessionId(req)) {
      absl::MutexLock lock(&sessions_mu_);
      sessions_.erase(*id);
    }
    res.set_header("Set-Cookie", absl::StrCat(kSessionCookie, "=; Path=/; Max-Age=0"));
    res.status = 204;
  });

  http_->Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_header("Content-Security-Policy",
                   "default-src 'self'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
                   "img-src 'self' data:");
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_content(web::kIndexHtml, "text/html; charset=utf-8");
  });

  http_->Get("/api/missions",
             [this, tenant_of](const httplib::Request& req, httplib::Response& res) {
               const std::optional<std::string> tenant = tenant_of(req, res);
               if (!tenant.has_value()) return;
               res.set_header("Cache-Control", "no-store");
               res.set_content(MissionsJson(*tenant), kJson);
             });

  http_->Get(R"(/api/missions/([a-z0-9-]{1,63}))",
             [this, tenant_of](const httplib::Request& req, httplib::Response& res) {
               const std::optional<std::string> tenant = tenant_of(req, res);
               if (!tenant.has_value()) return;
               absl::StatusOr<std::string> body = MissionJson(req.matches[1].str(), *tenant);
               if (!body.ok()) {
                 Error(res, body.status().code() == absl::StatusCode::kNotFound ? 404 : 400,
                       std::string(body.status().message()));
                 return;
               }
               res.set_header("Cache-Control", "no-store");
               res.set_content(*body, kJson);
             });

  http_->Get(
      R"(/api/missions/([a-z0-9-]{1,63})/events)",
      [this, tenant_of](const httplib::Request& req, httplib::Response& res) {
        const std::optional<std::string> tenant = tenant_of(req, res);
        if (!tenant.has_value()) return;
        absl::StatusOr<std::shared_ptr<Mission>> mission =
            registry_->GetHeld(absl::StrCat("missions/", req.matches[1].str()), *tenant);
        if (!mission.ok()) {
          Error(res, 404, std::string(mission.status().message()));
          return;
        }
        if (streams_.fetch_add(1) >= kMaxStreams) {
          streams_.fetch_sub(1);
          Error(res, 503, absl::StrCat("too many open event streams (", kMaxStreams, ")"));
          return;
        }
        std::shared_ptr<EventQueue> queue = (*mission)->events().Subscribe();
        auto greeted = std::make_shared<bool>(false);
        auto idle = std::make_shared<int>(0);
        res.set_header("Cache-Control", "no-store");
        res.set_chunked_content_provider(
            "text/event-stream",
            [this, queue, greeted, idle](std::size_t, httplib::DataSink& sink) {
              if (!*greeted) {
                *greeted = true;
                const std::string hello = "retry: 2000\n: connected\n\n";
                return sink.write(hello.data(), hello.size());
              }
              if (stopping_.load()) {
                sink.done();
                return true;
              }
              // Wakes at least once a second to notice a stop or a closed page.
              std::optional<MissionEventData> event = queue->Pop(absl::Now() + absl::Seconds(1));
              if (!event.has_value()) {
                if (queue->closed()) {
                  sink.done();
                  return true;
                }
                if (++*idle % 5 != 0) return true;
                const std::string ping = ": keep-alive\n\n";
                return sink.write(ping.data(), ping.size());
              }
              const std::string message = absl::StrCat(
                  "event: mission\ndata: ",
                  json{{"sequence", event->sequence}, {"kind", EventKind(*event)}}.dump(), "\n\n");
              if (!sink.write(message.data(), message.size())) return false;
              if (std::holds_alternative<MissionEventData::Deleted>(event->event)) sink.done();
              return true;
            },
            [this, queue, mission = *mission](bool) {
              mission->events().Unsubscribe(queue);
              streams_.fetch_sub(1);
            });
      });
}

}  // namespace oaipp::server

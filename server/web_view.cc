#include "server/web_view.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "api/map.h"
#include "httplib.h"
#include "nlohmann/json.hpp"
#include "server/http_serving.h"
#include "server/web/index_html.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {
namespace {

using nlohmann::json;

constexpr int kThreads = WebView::kMaxStreams + 4;  // streams hold a thread each
constexpr const char* kJson = "application/json";
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

const char* EventKind(const MissionEventData& e) {
  if (std::holds_alternative<MissionEventData::MeasurementFused>(e.event)) {
    return "measurement_fused";
  }
  if (std::holds_alternative<MissionEventData::ObstaclesChanged>(e.event)) {
    return "obstacles_changed";
  }
  if (std::holds_alternative<MissionEventData::PathPlanned>(e.event)) return "path_planned";
  return "mission_deleted";
}

}  // namespace

WebView::WebView(MissionRegistry* registry, const Authenticator* auth)
    : registry_(registry), auth_(auth), http_(std::make_unique<httplib::Server>()) {}

WebView::~WebView() { Stop(); }

absl::Status WebView::Start(const std::string& address, int port) {
  if (!IsLoopback(address) && (auth_ == nullptr || !auth_->enabled())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "web_address: ", address.substr(0, 64),
        " is not loopback; the view shows mission data, so serve it beyond this machine only "
        "with --token_file"));
  }
  http_->new_task_queue = [] { return new httplib::ThreadPool(kThreads); };
  http_->set_payload_max_length(1 << 16);
  http_->set_keep_alive_max_count(100);
  Routes();
  port_ = BindExclusive(*http_, address, port);
  if (port_ == 0) {
    return absl::UnavailableError(
        absl::StrCat("web_port: cannot listen on ", address.substr(0, 64), ":", port));
  }
  listener_.Start(http_.get());
  spdlog::info("web view: http://{}:{}/", address, port_);
  return absl::OkStatus();
}

void WebView::Stop() {
  if (stopping_.exchange(true)) return;
  listener_.Stop(http_.get());
}

std::string WebView::MissionsJson(const std::string& tenant) const {
  json missions = json::array();
  for (const auto& [number, mission] : registry_->ListAfter(0, 1000, tenant)) {
    const MissionSnapshot s = mission->Snapshot();
    missions.push_back({{"id", std::string(MissionRegistry::PublicId(s.id))},
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
  const std::int64_t sequence = mission.last_event_sequence();
  const MissionSnapshot s = mission.Snapshot();
  const MissionTrack track = mission.Track();
  v1::GetMapResponse grid;
  json mean = json::array();
  json std_dev = json::array();
  json found_cells = json::array();
  mission.ReadMap([&](const GpMap& map) {
    api::MapToProto(map, /*include_cells=*/false, &grid);
    for (int i = 0; i < map.num_cells(); ++i) {
      const double m = map.Mean()(i);
      mean.push_back(Short(m));
      std_dev.push_back(Short(std::sqrt(std::max(0.0, map.Variance(i)))));
      if (m >= kDetectedLabel) found_cells.push_back(i);
    }
  });
  json obstacles = json::array();
  for (const Obstacle& o : s.obstacles) {
    json polygon = json::array();
    for (const Vec2& c : GroundFootprint(o.shape)) {
      polygon.push_back({Short(c.x()), Short(c.y())});
    }
    const double top = std::visit(
        [](const auto& shape) {
          using T = std::decay_t<decltype(shape)>;
          if constexpr (std::is_same_v<T, Box>) {
            return shape.centre_W.z() + 0.5 * shape.size_m.z();
          } else {
            return shape.centre_W.z() + 0.5 * shape.height_m;
          }
        },
        o.shape);
    obstacles.push_back({{"id", o.id}, {"polygon", std::move(polygon)}, {"top_m", Short(top)}});
  }
  json flown = json::array();
  for (const Vec3& p : track.flown_W) flown.push_back(Point(p));
  json planned = json::array();
  for (const Vec3& p : track.planned_W) planned.push_back(Point(p));
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
                     {{"nx", grid.nx()},
                      {"ny", grid.ny()},
                      {"x_min_m", grid.x_min_m()},
                      {"y_min_m", grid.y_min_m()},
                      {"resolution_m", grid.resolution_m()}}},
                    {"mean", std::move(mean)},
                    {"std", std::move(std_dev)},
                    {"obstacles", std::move(obstacles)},
                    {"planned", std::move(planned)},
                    {"flown", std::move(flown)},
                    {"detections", track.detected_cells},
                    {"found", std::move(found_cells)},
                    {"geo_origin", std::move(geo)}};
  return out.dump();
}

void WebView::Routes() {
  // The caller's tenant, or an answer already written (401).
  auto tenant_of = [this](const httplib::Request& req,
                          httplib::Response& res) -> std::optional<std::string> {
    if (auth_ == nullptr || !auth_->enabled()) return std::string();
    std::string header = req.get_header_value("Authorization");
    if (header.empty() && req.has_param("token")) {
      header = absl::StrCat("Bearer ", req.get_param_value("token"));
    }
    absl::StatusOr<std::string> tenant = auth_->TenantOfHeader(header.empty() ? nullptr : &header);
    if (!tenant.ok()) {
      Error(res, 401, std::string(tenant.status().message()));
      return std::nullopt;
    }
    return *tenant;
  };

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
        std::shared_ptr<EventQueue> queue = (*mission)->Subscribe();
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
              mission->Unsubscribe(queue);
              streams_.fetch_sub(1);
            });
      });
}

}  // namespace oaipp::server

#include "server/service.h"

#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <span>

#include "absl/strings/cord.h"
#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "api/export.h"
#include "api/geodetic.h"
#include "api/geometry.h"
#include "api/ground_outlines.h"
#include "api/map.h"
#include "api/measurement.h"
#include "api/metadata.h"
#include "api/plan.h"
#include "api/spec.h"
#include "api/status.h"
#include "core/common/status_macros.h"
#include "google/protobuf/util/time_util.h"
#include "render/map_render.h"
#include "server/service_internal.h"
#include "server/store/fingerprint.h"
#include "spdlog/spdlog.h"

namespace oaipp::server {
namespace {

using api::ConfigToMissionSpec;
using api::MapToProto;
using api::MeasurementFromProto;
using api::MeasurementInput;
using api::MissionConfig;
using api::MissionSpecToConfig;
using api::ObstacleChangeFromProto;
using api::ObstacleToProto;
using api::PlannedPathToProto;
using api::ToGrpcStatus;
using api::ToProto;
using api::UavStateFromProto;

using google::protobuf::util::TimeUtil;

// ListMissions page tokens: where the last page ended, signed with the
// registry's key (HMAC-SHA256, MissionRegistry::PageTokenKey) and in
// URL-safe base64. A token this server (or, sharing a store, its cluster)
// did not make is refused. Where the listing comes from the registry, the
// position is the creation number of the last mission shown (numbers are
// never reused, so deleting missions between pages neither hides nor
// repeats one); from a shared store, its create time and key.
struct PagePosition {
  std::int64_t number = 0;   // "n": the registry's listing
  std::int64_t time_us = 0;  // "t": the store's listing ...
  std::string key = {};      // ... (time, key)
  bool from_store = false;
};

std::string Signature(const std::string& key, absl::string_view body) {
  unsigned char mac[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()),
       reinterpret_cast<const unsigned char*>(body.data()), body.size(), mac, &size);
  // 128 bits are plenty against forgery.
  return absl::BytesToHexString(
      absl::string_view(reinterpret_cast<const char*>(mac), std::min(size, 16u)));
}

std::string PageToken(const std::string& key, const PagePosition& at) {
  const std::string body = at.from_store
                               ? absl::StrCat("t.", at.time_us, ".", absl::BytesToHexString(at.key))
                               : absl::StrCat("n.", at.number);
  return absl::WebSafeBase64Escape(absl::StrCat(body, ".", Signature(key, body)));
}

absl::StatusOr<PagePosition> ParsePageToken(const std::string& key, const std::string& token,
                                            bool from_store) {
  const absl::Status bad = absl::InvalidArgumentError(
      "page_token: not a token this server gave out (pass next_page_token unchanged)");
  std::string decoded;
  if (token.size() > 1024 || !absl::WebSafeBase64Unescape(token, &decoded)) return bad;
  const std::size_t dot = decoded.rfind('.');
  if (dot == std::string::npos) return bad;
  const std::string body = decoded.substr(0, dot);
  if (decoded.substr(dot + 1) != Signature(key, body)) return bad;
  const std::vector<absl::string_view> parts = absl::StrSplit(body, '.');
  PagePosition at{.from_store = from_store};
  if (!from_store && parts.size() == 2 && parts[0] == "n" &&
      absl::SimpleAtoi(parts[1], &at.number) && at.number >= 0) {
    return at;
  }
  if (from_store && parts.size() == 3 && parts[0] == "t" &&
      absl::SimpleAtoi(parts[1], &at.time_us)) {
    at.key = absl::HexStringToBytes(parts[2]);
    return at;
  }
  // Signed but of the other kind: a server that joined or left a cluster.
  return absl::InvalidArgumentError(
      "page_token: from a listing of another kind (start again without a page_token)");
}

void FillMission(const Mission& mission, v1::Mission* out) {
  const MissionSnapshot s = mission.Snapshot();
  out->set_name(absl::StrCat("missions/", PublicId(s.id)));
  *out->mutable_spec() = ConfigToMissionSpec(s.config);
  for (const Obstacle& o : s.obstacles) *out->add_obstacles() = ObstacleToProto(o);
  out->set_trace(s.trace);
  out->set_measurements_fused(s.measurements_fused);
  out->set_trace_measurements_fused(s.trace_measurements_fused);
  out->set_paths_planned(s.paths_planned);
  out->set_mission_time_s(s.mission_time_s);
  out->set_map_bytes(s.memory_bytes);
  *out->mutable_create_time() = TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(s.create_time));
  for (const std::string& id : s.removed_uav_ids) out->add_removed_uav_ids(id);
  for (const std::string& id : s.landed_uav_ids) out->add_landed_uav_ids(id);
}

}  // namespace

void MissionServiceImpl::TagReplica(grpc::ServerContextBase* context) const {
  if (!limits_.replica_id.empty())
    context->AddInitialMetadata(api::kReplicaHeader, limits_.replica_id);
}

absl::StatusOr<std::string> MissionServiceImpl::TenantOf(
    const grpc::ServerContextBase& context) const {
  if (auth_ == nullptr) return std::string();
  return auth_->TenantOf(context);
}

bool MissionServiceImpl::Overloaded() const { return admission_.Overloaded(); }

int MissionServiceImpl::open_streams() const { return admission_.open_streams(); }

grpc::Status MissionServiceImpl::CreateMission(grpc::ServerContext* context,
                                               const v1::CreateMissionRequest* request,
                                               v1::Mission* response) {
  return Call(context, "CreateMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_RETURN_IF_ERROR(service_internal::CheckRequestId(request->request_id()));
    OAIPP_ASSIGN_OR_RETURN(MissionConfig config, MissionSpecToConfig(request->spec()));
    OAIPP_ASSIGN_OR_RETURN(
        std::shared_ptr<Mission> mission,
        registry_->Create(request->mission_id(), std::move(config), request->request_id(),
                          RequestFingerprint(*request), tenant));
    FillMission(*mission, response);
    if (metrics_ != nullptr) {
      metrics_->SetMissions(static_cast<double>(registry_->size()),
                            static_cast<double>(registry_->MemoryBytes()));
    }
    spdlog::info("mission event=created name={} tenant={}", response->name(), tenant);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::GetMission(grpc::ServerContext* context,
                                            const v1::GetMissionRequest* request,
                                            v1::Mission* response) {
  return Call(context, "GetMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Get(request->name(), tenant));
    FillMission(*mission, response);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::ListMissions(grpc::ServerContext* context,
                                              const v1::ListMissionsRequest* request,
                                              v1::ListMissionsResponse* response) {
  return Call(context, "ListMissions", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    if (request->page_size() < 0 || request->page_size() > 1000) {
      return absl::InvalidArgumentError(
          absl::StrCat("page_size: must be in [0, 1000], got ", request->page_size()));
    }
    const std::size_t size = request->page_size() == 0 ? 50 : request->page_size();
    OAIPP_ASSIGN_OR_RETURN(const std::string key, registry_->PageTokenKey());
    const bool from_store = registry_->shares_store();
    PagePosition after{.from_store = from_store};
    if (!request->page_token().empty()) {
      OAIPP_ASSIGN_OR_RETURN(after, ParsePageToken(key, request->page_token(), from_store));
    }
    if (from_store) {
      // A cluster's replica lists every mission of the tenant in the store,
      // whoever holds it: those it holds in full, the others by name, spec
      // and creation time (GetMission gives the rest, and moves the mission
      // here).
      OAIPP_ASSIGN_OR_RETURN(
          std::vector<MissionRegistry::Listed> listed,
          registry_->ListStored(tenant, after.time_us, after.key, static_cast<int>(size) + 1));
      for (std::size_t i = 0; i < listed.size() && i < size; ++i) {
        v1::Mission* out = response->add_missions();
        if (listed[i].held != nullptr) {
          FillMission(*listed[i].held, out);
          continue;
        }
        const MissionListing& stored = listed[i].stored;
        out->set_name(absl::StrCat("missions/", PublicId(stored.id)));
        if (!out->mutable_spec()->ParseFromString(stored.spec)) {
          return absl::DataLossError(absl::StrCat(out->name(), ": its stored spec does not parse"));
        }
        *out->mutable_create_time() = TimeUtil::MicrosecondsToTimestamp(stored.create_time_unix_us);
      }
      if (listed.size() > size) {
        const MissionListing& last = listed[size - 1].stored;
        response->set_next_page_token(PageToken(
            key, {.time_us = last.create_time_unix_us, .key = last.id, .from_store = true}));
      }
      return absl::OkStatus();
    }
    const auto missions = registry_->ListAfter(after.number, size + 1, tenant);
    for (std::size_t i = 0; i < missions.size() && i < size; ++i) {
      FillMission(*missions[i].second, response->add_missions());
    }
    if (missions.size() > size) {
      response->set_next_page_token(PageToken(key, {.number = missions[size - 1].first}));
    }
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::DeleteMission(grpc::ServerContext* context,
                                               const v1::DeleteMissionRequest* request,
                                               v1::DeleteMissionResponse*) {
  return Call(context, "DeleteMission", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_RETURN_IF_ERROR(service_internal::CheckRequestId(request->request_id()));
    OAIPP_RETURN_IF_ERROR(registry_->Delete(request->name(), request->request_id(), tenant));
    if (metrics_ != nullptr) {
      metrics_->SetMissions(static_cast<double>(registry_->size()),
                            static_cast<double>(registry_->MemoryBytes()));
    }
    spdlog::info("mission event=deleted name={} tenant={}", request->name(), tenant);
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::UpdateObstacles(grpc::ServerContext* context,
                                                 const v1::UpdateObstaclesRequest* request,
                                                 v1::UpdateObstaclesResponse* response) {
  return Call(context, "UpdateObstacles", [&]() -> absl::Status {
    return Mutate(
        *context, *request, RecordKind::kObstacles,
        [&](const std::shared_ptr<Mission>& mission, const v1::UpdateObstaclesRequest& local,
            const RequestKey& key, const PersistFn& persist) -> absl::Status {
          OAIPP_ASSIGN_OR_RETURN(ObstacleChange change, ObstacleChangeFromProto(local));
          OAIPP_ASSIGN_OR_RETURN(ObstacleResult result,
                                 mission->UpdateObstacles(change, key, persist));
          response->set_obstacle_count(result.obstacle_count);
          response->set_esdf_voxels_recomputed(result.esdf_voxels_recomputed);
          return absl::OkStatus();
        });
  });
}

grpc::Status MissionServiceImpl::AddMeasurement(grpc::ServerContext* context,
                                                const v1::AddMeasurementRequest* request,
                                                v1::AddMeasurementResponse* response) {
  return Call(context, "AddMeasurement", [&]() -> absl::Status {
    return Mutate(
        *context, *request, RecordKind::kMeasurement,
        [&](const std::shared_ptr<Mission>& mission, const v1::AddMeasurementRequest& local,
            const RequestKey& key, const PersistFn& persist) -> absl::Status {
          OAIPP_ASSIGN_OR_RETURN(MeasurementInput input, MeasurementFromProto(local));
          OAIPP_ASSIGN_OR_RETURN(MeasurementResult result,
                                 mission->AddMeasurement(input, key, persist));
          FillMeasurementResponse(result, response);
          (void)settlers_.Submit(mission->id(), [mission] { mission->SettleMap(); });
          return absl::OkStatus();
        });
  });
}

grpc::Status MissionServiceImpl::RemoveTeamMember(grpc::ServerContext* context,
                                                  const v1::RemoveTeamMemberRequest* request,
                                                  v1::RemoveTeamMemberResponse* response) {
  return Call(context, "RemoveTeamMember", [&]() -> absl::Status {
    return Mutate(
        *context, *request, RecordKind::kTeam,
        [&](const std::shared_ptr<Mission>& mission, const v1::RemoveTeamMemberRequest& local,
            const RequestKey& key, const PersistFn& persist) -> absl::Status {
          OAIPP_ASSIGN_OR_RETURN(
              TeamResult result,
              mission->RemoveMember(local.uav_id(), local.landed(), key, persist));
          for (const std::string& id : result.flying_uav_ids) response->add_flying_uav_ids(id);
          spdlog::info("mission event=team_member_removed name={} uav_id={} landed={}",
                       local.name(), local.uav_id(), local.landed());
          return absl::OkStatus();
        });
  });
}

grpc::Status MissionServiceImpl::ExportPath(grpc::ServerContext* context,
                                            const v1::ExportPathRequest* request,
                                            v1::ExportPathResponse* response) {
  return Call(context, "ExportPath", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Get(request->name(), tenant));
    if (!request->has_path()) {
      return absl::InvalidArgumentError("path: required (a PlanPath answer of this mission)");
    }
    OAIPP_ASSIGN_OR_RETURN(const api::ExportOptions options, api::ExportOptionsFromProto(*request));
    const MissionSnapshot snapshot = mission->Snapshot();
    OAIPP_ASSIGN_OR_RETURN(
        *response, api::ExportPath(snapshot.config, snapshot.obstacles, request->path(), options));
    return absl::OkStatus();
  });
}

grpc::Status MissionServiceImpl::GetMap(grpc::ServerContext* context,
                                        const v1::GetMapRequest* request,
                                        v1::GetMapResponse* response) {
  return Call(context, "GetMap", [&]() -> absl::Status {
    OAIPP_ASSIGN_OR_RETURN(const std::string tenant, TenantOf(*context));
    OAIPP_ASSIGN_OR_RETURN(std::shared_ptr<Mission> mission,
                           registry_->Get(request->name(), tenant));
    render::MapLayers layers;
    if (request->include_prior()) {
      // The config never changes: no lock needed.
      const api::MissionConfig& config = mission->config();
      const Eigen::VectorXd prior = config.PriorMean(mission->grid().num_cells());
      response->mutable_prior_mean()->Assign(prior.data(), prior.data() + prior.size());
    }
    const std::span<const std::uint8_t> area = mission->config().SearchMask();  // never changes
    OAIPP_RETURN_IF_ERROR(mission->ReadMapView([&](const api::MapView& map) {
      MapToProto(map, request->include_cells(), response);
      response->set_search_area_trace(map.trace);
      if (!area.empty()) {
        double trace = 0.0;
        for (Eigen::Index i = 0; i < map.variances->size(); ++i) {
          if (area[static_cast<std::size_t>(i)] != 0) trace += (*map.variances)[i];
        }
        response->set_search_area_trace(trace);
        if (request->include_cells())
          response->set_search_area(reinterpret_cast<const char*>(area.data()), area.size());
      }
      if (!request->include_png()) return;
      // Copied under the lock, drawn outside it.
      layers.mean.assign(map.mean->begin(), map.mean->end());
      layers.std_dev.resize(static_cast<std::size_t>(map.variances->size()));
      for (Eigen::Index i = 0; i < map.variances->size(); ++i) {
        layers.std_dev[static_cast<std::size_t>(i)] = std::sqrt(std::max(0.0, (*map.variances)[i]));
      }
    }));
    if (!request->include_png()) return absl::OkStatus();
    const MissionSnapshot snapshot = mission->Snapshot();
    render::Overlay overlay(api::GroundOutlinesOf(snapshot.config, snapshot.obstacles));
    const render::MapGrid grid{.nx = response->nx(),
                               .ny = response->ny(),
                               .resolution_m = response->resolution_m(),
                               .x_min_m = response->x_min_m(),
                               .y_min_m = response->y_min_m()};
    OAIPP_ASSIGN_OR_RETURN(
        std::string png,
        render::RenderMapPng(grid, layers, overlay,
                             {.mission = absl::StrCat("missions/", PublicId(snapshot.id)),
                              .mission_time_s = snapshot.mission_time_s,
                              .trace = response->trace()}));
    response->set_png(std::move(png));
    return absl::OkStatus();
  });
}

}  // namespace oaipp::server

#include "api/internal/home_spec.h"

#include "absl/strings/str_cat.h"
#include "api/geometry.h"
#include "api/internal/checks.h"
#include "core/common/status_macros.h"

namespace oaipp::api::internal {

absl::Status FillHome(const v1::MissionSpec& spec, MissionConfig& c) {
  if (!spec.has_home()) return absl::OkStatus();
  const v1::Home& h = spec.home();
  if (!spec.team().empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "spec.home: not available with a team yet (spec.team has ", spec.team_size(),
        " members); each member would need its own way home kept clear of the others"));
  }
  if (!h.has_position_m()) {
    return absl::InvalidArgumentError("spec.home.position_m: required (or position_geo)");
  }
  HomeConfig home{.home_W = FromProto(h.position_m()),
                  .reserve_s = h.has_reserve_s() ? h.reserve_s() : 0.0,
                  .landing_speed_m_s = h.has_landing_speed_m_s() ? h.landing_speed_m_s() : 1.0};
  if (!AllFinite(home.home_W)) {
    return absl::InvalidArgumentError("spec.home.position_m: must be finite");
  }
  if (const Aabb volume = c.FlightVolume(); !volume.Contains(home.home_W)) {
    return absl::InvalidArgumentError(
        absl::StrCat("spec.home.position_m: ", Describe(home.home_W),
                     " lies outside the flight volume ", Describe(volume.min_W), " .. ",
                     Describe(volume.max_W), " (the way home ends there, at rest)"));
  }
  if (!(home.reserve_s >= 0.0 && home.reserve_s < c.budget_s)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "spec.home.reserve_s: must be in [0, budget_s = ", c.budget_s, "), got ", home.reserve_s));
  }
  OAIPP_RETURN_IF_ERROR(CheckPositive("spec.home.landing_speed_m_s", home.landing_speed_m_s));
  c.planner.home = home;
  return absl::OkStatus();
}

void WriteHome(const MissionConfig& c, v1::MissionSpec* spec) {
  if (!c.planner.home.has_value()) return;
  const HomeConfig& home = *c.planner.home;
  v1::Home& h = *spec->mutable_home();
  *h.mutable_position_m() = ToProto(home.home_W);
  h.set_reserve_s(home.reserve_s);
  h.set_landing_speed_m_s(home.landing_speed_m_s);
}

}  // namespace oaipp::api::internal

// Errors carry their field paths as data (core/common/field_error.h): the
// API's names, and a team member's own limits, come from the data, and
// whatever a message repeats of the input stays as it was.
#include "api/status.h"

#include <cmath>
#include <optional>
#include <string>

#include "absl/strings/cord.h"
#include "core/common/field_error.h"
#include "core/common/geometry.h"
#include "gtest/gtest.h"

namespace oaipp::api {
namespace {

TEST(FieldErrorTest, TheMessageIsRenderedFromTheTemplateAndTheFields) {
  const absl::Status status =
      FieldError(absl::StatusCode::kInvalidArgument, "$0: faster than $1 (costs $$5)",
                 {"state.velocity_W_m_s", "limits.max_speed_m_s"});
  EXPECT_EQ(status.message(), "state.velocity_W_m_s: faster than limits.max_speed_m_s (costs $5)");
  const std::optional<FieldErrorData> data = FieldErrorOf(status);
  ASSERT_TRUE(data.has_value());
  EXPECT_EQ(data->format, "$0: faster than $1 (costs $$5)");
  ASSERT_EQ(data->fields.size(), 2U);
  EXPECT_EQ(data->fields[1], "limits.max_speed_m_s");
  EXPECT_FALSE(FieldErrorOf(absl::InvalidArgumentError("state.position_W: x")).has_value());
}

TEST(FieldErrorTest, AMembersLimitIsNamedFromTheDataNotTheText) {
  absl::Status status = FieldError(absl::StatusCode::kInvalidArgument, "$0: faster than $1",
                                   {"state.velocity_W_m_s", "limits.max_speed_m_s"});
  status.SetPayload("type.oaipp.dev/other", absl::Cord("kept"));
  const absl::Status mission = WithApiFieldNames(status);
  EXPECT_EQ(mission.message(), "state.velocity_m_s: faster than spec.flight.max_speed_m_s");
  const absl::Status member = WithApiFieldNames(status, 1);
  EXPECT_EQ(member.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(member.message(), "state.velocity_m_s: faster than spec.team[1].flight.max_speed_m_s");
  EXPECT_EQ(FieldErrorOf(member)->fields[1], "spec.team[1].flight.max_speed_m_s");
  EXPECT_EQ(member.GetPayload("type.oaipp.dev/other"), absl::Cord("kept"));
  // Renaming twice changes nothing more: API names are not the core's.
  EXPECT_EQ(WithApiFieldNames(member).message(), member.message());
}

TEST(FieldErrorTest, InputInTheMessageIsNeverTakenForAField) {
  // A teammate or obstacle named like a template's placeholder.
  const absl::Status status =
      FieldError(absl::StatusCode::kFailedPrecondition,
                 "$0: 1 m from UAV '" + EscapeForFieldError("$1 limits.max_speed_m_s") + "'",
                 {"state.position_W"});
  EXPECT_EQ(WithApiFieldNames(status, 0).message(),
            "state.position_m: 1 m from UAV '$1 limits.max_speed_m_s'");
}

TEST(FieldErrorTest, CoreChecksNameTheirFieldAsData) {
  const absl::Status status =
      CheckFinite("spec.obstacles[2].box.centre_W", Vec3(1, std::nan(""), 0));
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(FieldErrorOf(status)->fields.at(0), "spec.obstacles[2].box.centre_W");
  EXPECT_EQ(WithApiFieldNames(status).message().substr(0, 33), "spec.obstacles[2].box.centre_m: m");
  EXPECT_EQ(ApiFieldName("esdf.voxel_size_m"), "spec.flight.esdf_voxel_m");
  EXPECT_EQ(ApiFieldName("limits.uav_radius_m", 3), "spec.team[3].flight.uav_radius_m");
  EXPECT_EQ(ApiFieldName("spec.sensor.rate_hz"), "spec.sensor.rate_hz");
}

}  // namespace
}  // namespace oaipp::api

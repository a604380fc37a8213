// Validation helpers shared by the api/ conversions: each returns OK or
// InvalidArgument whose message starts with `field`, the API's path of the
// value ("spec.flight.max_speed_m_s", "add[2].id").
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "core/common/geometry.h"
#include "oaipp/v1/mission_service.pb.h"

namespace oaipp::api::internal {

// Longest obstacle id the API accepts, characters.
inline constexpr std::size_t kMaxIdLength = 128;

// `value` when the optional field is set (`has`), else `fallback`.
template <typename T>
[[nodiscard]] T OrDefault(bool has, T value, T fallback) {
  return has ? value : fallback;
}

// `status` with `prefix` put before its message; OK stays OK.
[[nodiscard]] absl::Status Prefixed(absl::string_view prefix, const absl::Status& status);

[[nodiscard]] absl::Status CheckFiniteVector(absl::string_view field, const v1::Vector3& v);
// Each component finite and within [-bound, bound].
[[nodiscard]] absl::Status CheckBoundedVector(absl::string_view field, const v1::Vector3& v,
                                              double bound);
// 0 < value <= bound.
[[nodiscard]] absl::Status CheckPositiveAtMost(absl::string_view field, double value, double bound);
[[nodiscard]] absl::Status CheckNonNegative(absl::string_view field, double value);
[[nodiscard]] absl::Status CheckUnitInterval(absl::string_view field, double value);
// lo < value < hi.
[[nodiscard]] absl::Status CheckOpenInterval(absl::string_view field, double value, double lo,
                                             double hi);
// lo <= value <= hi.
[[nodiscard]] absl::Status CheckIntRange(absl::string_view field, std::int64_t value,
                                         std::int64_t lo, std::int64_t hi);
[[nodiscard]] absl::Status CheckAtLeast(absl::string_view field, std::int64_t value,
                                        std::int64_t lo);
// 1 .. kMaxIdLength characters.
[[nodiscard]] absl::Status CheckId(absl::string_view field, const std::string& id);
// "(x, y, z)" for messages.
[[nodiscard]] std::string Describe(const Vec3& v);

}  // namespace oaipp::api::internal

#include "api/internal/checks.h"

#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.h"

namespace oaipp::api::internal {

absl::Status Prefixed(absl::string_view prefix, const absl::Status& status) {
  if (status.ok()) return status;
  return absl::Status(status.code(), absl::StrCat(prefix, status.message()));
}

absl::Status CheckFiniteVector(absl::string_view field, const v1::Vector3& v) {
  OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat(field, ".x"), v.x()));
  OAIPP_RETURN_IF_ERROR(CheckFinite(absl::StrCat(field, ".y"), v.y()));
  return CheckFinite(absl::StrCat(field, ".z"), v.z());
}

absl::Status CheckBoundedVector(absl::string_view field, const v1::Vector3& v, double bound) {
  for (const auto& [axis, value] : {std::pair{".x", v.x()}, {".y", v.y()}, {".z", v.z()}}) {
    if (!(std::abs(value) <= bound)) {  // true for NaN
      return absl::InvalidArgumentError(
          absl::StrCat(field, axis, ": must be finite and within +-", bound, ", got ", value));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckPositiveAtMost(absl::string_view field, double value, double bound) {
  if (value > 0.0 && value <= bound) return absl::OkStatus();  // false for NaN
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be positive and at most ", bound, ", got ", value));
}

absl::Status CheckNonNegative(absl::string_view field, double value) {
  if (std::isfinite(value) && value >= 0.0) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, ": must be >= 0 and finite, got ", value));
}

absl::Status CheckUnitInterval(absl::string_view field, double value) {
  if (value >= 0.0 && value <= 1.0) return absl::OkStatus();  // false for NaN
  return absl::InvalidArgumentError(absl::StrCat(field, ": must be in [0, 1], got ", value));
}

absl::Status CheckOpenInterval(absl::string_view field, double value, double lo, double hi) {
  if (value > lo && value < hi) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be in (", lo, ", ", hi, "), got ", value));
}

absl::Status CheckIntRange(absl::string_view field, std::int64_t value, std::int64_t lo,
                           std::int64_t hi) {
  if (value >= lo && value <= hi) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be in [", lo, ", ", hi, "], got ", value));
}

absl::Status CheckAtLeast(absl::string_view field, std::int64_t value, std::int64_t lo) {
  if (value >= lo) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, ": must be >= ", lo, ", got ", value));
}

absl::Status CheckId(absl::string_view field, const std::string& id) {
  if (!id.empty() && id.size() <= kMaxIdLength) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": must be 1..", kMaxIdLength, " characters, got ", id.size()));
}

std::string Describe(const Vec3& v) {
  return absl::StrCat("(", v.x(), ", ", v.y(), ", ", v.z(), ")");
}

}  // namespace oaipp::api::internal

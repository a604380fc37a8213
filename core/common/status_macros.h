// Small helpers for absl::Status plumbing.
//
// Abseil 20220623 ships neither RETURN_IF_ERROR nor ASSIGN_OR_RETURN, so the
// project keeps these two tiny macros. Usage:
//
//   absl::StatusOr<Esdf> BuildEsdf(...) {
//     OAIPP_RETURN_IF_ERROR(ValidateConfig(config));
//     OAIPP_ASSIGN_OR_RETURN(auto grid, MakeGrid(config));
//     ...
//   }
#pragma once

#include "absl/status/status.h"
#include "absl/status/statusor.h"

#define OAIPP_STATUS_CONCAT_INNER_(a, b) a##b
#define OAIPP_STATUS_CONCAT_(a, b) OAIPP_STATUS_CONCAT_INNER_(a, b)

// The status variable gets a name of its own per use, so that a use inside
// a lambda passed to another use does not shadow it.
#define OAIPP_RETURN_IF_ERROR(expr) \
  OAIPP_RETURN_IF_ERROR_IMPL_(OAIPP_STATUS_CONCAT_(oaipp_status_, __COUNTER__), expr)

#define OAIPP_RETURN_IF_ERROR_IMPL_(status, expr)     \
  do {                                                \
    if (absl::Status status = (expr); !status.ok()) { \
      return status;                                  \
    }                                                 \
  } while (false)

#define OAIPP_ASSIGN_OR_RETURN(lhs, expr) \
  OAIPP_ASSIGN_OR_RETURN_IMPL_(OAIPP_STATUS_CONCAT_(oaipp_statusor_, __LINE__), lhs, expr)

#define OAIPP_ASSIGN_OR_RETURN_IMPL_(tmp, lhs, expr) \
  auto tmp = (expr);                                 \
  if (!tmp.ok()) return std::move(tmp).status();     \
  lhs = std::move(tmp).value()

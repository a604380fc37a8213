// An error about input fields, with the fields as data. The message is a
// template whose $0, $1, ... are field paths ("$0: faster than $1" with
// state.velocity_W_m_s and limits.max_speed_m_s); the template and the
// paths travel in the status's payload, so a caller that knows a field by
// another name (the API's spec.flight.max_speed_m_s, or a team member's
// spec.team[1].flight.max_speed_m_s) renames it without reading the text.
//
//   return FieldError(absl::StatusCode::kInvalidArgument, "$0: faster than $1",
//                     {"state.velocity_W_m_s", "limits.max_speed_m_s"});
//   status = RenameErrorFields(status, [](absl::string_view f) { return ApiName(f); });
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/cord.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"

namespace oaipp {

// `text` (input a message repeats) with each $ doubled, to go in a format.
[[nodiscard]] inline std::string EscapeForFieldError(absl::string_view text) {
  std::string out;
  for (const char c : text) {
    if (c == '$') out.push_back('$');
    out.push_back(c);
  }
  return out;
}

// The payload's type URL.
inline constexpr absl::string_view kFieldErrorPayload = "type.oaipp.dev/oaipp.FieldError";

struct FieldErrorData {
  std::string format;               // "$0: faster than $1"
  std::vector<std::string> fields;  // what $0, $1, ... stand for
};

// `format` with $i replaced by fields[i] and $$ by $ (a $ not followed by
// a listed index is kept as it is).
[[nodiscard]] inline std::string RenderFieldError(const FieldErrorData& data) {
  std::string out;
  out.reserve(data.format.size() + 32);
  for (std::size_t i = 0; i < data.format.size(); ++i) {
    const char c = data.format[i];
    if (c == '$' && i + 1 < data.format.size() && data.format[i + 1] == '$') {
      out.push_back('$');
      ++i;
      continue;
    }
    if (c == '$' && i + 1 < data.format.size() && data.format[i + 1] >= '0' &&
        data.format[i + 1] <= '9') {
      const auto index = static_cast<std::size_t>(data.format[i + 1] - '0');
      if (index < data.fields.size()) {
        out += data.fields[index];
        ++i;
        continue;
      }
    }
    out.push_back(c);
  }
  return out;
}

// A status of `code` whose message is `format` rendered with `fields` (at
// most ten; none may hold a NUL byte), carrying both as data.
[[nodiscard]] inline absl::Status FieldError(absl::StatusCode code, std::string format,
                                             std::vector<std::string> fields) {
  FieldErrorData data{std::move(format), std::move(fields)};
  absl::Status status(code, RenderFieldError(data));
  std::string payload = data.format;
  for (const std::string& field : data.fields) {
    payload.push_back('\0');
    payload += field;
  }
  status.SetPayload(kFieldErrorPayload, absl::Cord(std::move(payload)));
  return status;
}

// The fields and template `status` carries, or nullopt for a status made
// otherwise.
[[nodiscard]] inline std::optional<FieldErrorData> FieldErrorOf(const absl::Status& status) {
  const auto payload = status.GetPayload(kFieldErrorPayload);
  if (!payload.has_value()) return std::nullopt;
  const std::vector<std::string> parts = absl::StrSplit(std::string(*payload), '\0');
  FieldErrorData data;
  data.format = parts.front();
  data.fields.assign(parts.begin() + 1, parts.end());
  return data;
}

// `status` with each field it carries as data renamed by `rename` (the
// message rendered again; its code and other payloads kept). A status
// without fields comes back unchanged.
[[nodiscard]] inline absl::Status RenameErrorFields(
    const absl::Status& status, const std::function<std::string(absl::string_view)>& rename) {
  std::optional<FieldErrorData> data = FieldErrorOf(status);
  if (!data.has_value()) return status;
  for (std::string& field : data->fields) field = rename(field);
  absl::Status out = FieldError(status.code(), data->format, data->fields);
  status.ForEachPayload([&](absl::string_view url, const absl::Cord& payload) {
    if (url != kFieldErrorPayload) out.SetPayload(url, payload);
  });
  return out;
}

}  // namespace oaipp

// Scenario files: JSON in protobuf's mapping of oaipp.v1.Scenario
// (proto/oaipp/v1/scenario.proto), so the schema is the proto.
//
//   OAIPP_ASSIGN_OR_RETURN(v1::Scenario s, LoadScenarioFile("client/scenarios/e1.json"));
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "oaipp/v1/scenario.pb.h"

namespace oaipp::sim {

// InvalidArgument "SOURCE:LINE:COLUMN: ..." for malformed JSON, and
// "SOURCE: FIELD: ..." for JSON that does not fit the schema (unknown field,
// wrong type).
[[nodiscard]] absl::StatusOr<v1::Scenario> ParseScenario(absl::string_view json,
                                                         absl::string_view source);
// Reads and parses a file; NotFound when it cannot be read.
[[nodiscard]] absl::StatusOr<v1::Scenario> LoadScenarioFile(const std::string& path);

}  // namespace oaipp::sim

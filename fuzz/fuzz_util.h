// Checks shared by the fuzz targets: a failed check prints what broke and
// aborts, which libFuzzer reports as a crash and saves the input for.
//
//   OAIPP_FUZZ_CHECK(again.ok(), again.status().ToString());
//   CheckError(status, {absl::StatusCode::kInvalidArgument}, "MeasurementFromProto");
#pragma once

#include <cstdint>
#include <initializer_list>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace oaipp::fuzz {

// Prints "fuzz check failed: <what>: <detail>" to stderr and aborts.
[[noreturn]] void Fail(absl::string_view what, absl::string_view detail);

// Aborts with the condition's text and `detail` (anything convertible to
// absl::string_view) when `condition` is false.
#define OAIPP_FUZZ_CHECK(condition, detail)                      \
  do {                                                           \
    if (!(condition)) ::oaipp::fuzz::Fail(#condition, (detail)); \
  } while (false)

// api::EchoInput(input, max_bytes) for several caps, checked against its
// documented form: in double quotes, only printable ASCII, the first
// max_bytes of `input` recoverable exactly from the \xNN escapes, and
// "... (N bytes)" inside the quotes exactly when the input was cut.
void CheckEchoInput(absl::string_view input);

// api::SafeMessage(message, max_bytes) for several caps: only printable
// ASCII, at most 4 output bytes per kept input byte plus the cut note, the
// note exactly when the message was cut, and unchanged when nothing needed
// escaping or cutting.
void CheckSafeMessage(absl::string_view message);

// For a failed conversion: the code is one of `allowed` (the codes the
// function documents), the message is not empty, the message passes
// CheckSafeMessage (the server sends it through api::SafeMessage), and it
// crosses api::ToGrpcStatus and api::FromGrpcStatus unchanged. OK passes.
void CheckError(const absl::Status& status, std::initializer_list<absl::StatusCode> allowed,
                absl::string_view where);

// True when a and b are equal to within a few ulps, for angles that pass
// through degrees and back (the conversions document "a few ulps"). Values
// below 1e-300 in magnitude count as equal: there a double has lost most of
// its precision and the degree round trip cannot keep relative accuracy.
[[nodiscard]] bool NearlyEqualAngle(double a, double b);

}  // namespace oaipp::fuzz

#include "fuzz/fuzz_util.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "api/status.h"

namespace oaipp::fuzz {
namespace {

// Caps tried on every input: the defaults the server uses and small ones,
// so that cutting is exercised on short inputs too.
constexpr std::size_t kEchoCaps[] = {64, 0, 1, 3};
constexpr std::size_t kMessageCaps[] = {1024, 0, 1, 7};

bool Printable(char c) {
  const auto b = static_cast<unsigned char>(c);
  return b >= 0x20 && b < 0x7f;
}

bool AllPrintable(absl::string_view s) { return std::all_of(s.begin(), s.end(), Printable); }

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// The note both functions append inside their output when they cut.
std::string CutNote(std::size_t full_size) { return absl::StrCat("... (", full_size, " bytes)"); }

void CheckEchoInputWithCap(absl::string_view input, std::size_t cap) {
  const std::string out = api::EchoInput(input, cap);
  const std::string where = absl::StrCat("EchoInput(cap ", cap, ") of ", input.size(), " bytes");
  OAIPP_FUZZ_CHECK(AllPrintable(out), where);
  OAIPP_FUZZ_CHECK(out.size() >= 2 && out.front() == '"' && out.back() == '"', where);
  absl::string_view body(out);
  body.remove_prefix(1);
  body.remove_suffix(1);
  const bool cut = input.size() > cap;
  if (cut) {
    const std::string note = CutNote(input.size());
    OAIPP_FUZZ_CHECK(absl::EndsWith(body, note), where);
    body.remove_suffix(note.size());
  }
  const absl::string_view kept = input.substr(0, cap);
  OAIPP_FUZZ_CHECK(body.size() <= 4 * kept.size(), where);
  // Quotes and backslashes are always escaped, so the body decodes
  // unambiguously back to what was kept.
  std::string decoded;
  for (std::size_t i = 0; i < body.size(); ++i) {
    const char c = body[i];
    OAIPP_FUZZ_CHECK(c != '"', where);
    if (c != '\\') {
      decoded.push_back(c);
      continue;
    }
    OAIPP_FUZZ_CHECK(i + 3 < body.size() && body[i + 1] == 'x', where);
    const int hi = HexDigit(body[i + 2]);
    const int lo = HexDigit(body[i + 3]);
    OAIPP_FUZZ_CHECK(hi >= 0 && lo >= 0, where);
    const char byte = static_cast<char>(hi * 16 + lo);
    // Only bytes that need it are escaped.
    OAIPP_FUZZ_CHECK(!Printable(byte) || byte == '"' || byte == '\\', where);
    decoded.push_back(byte);
    i += 3;
  }
  OAIPP_FUZZ_CHECK(decoded == kept, where);
}

void CheckSafeMessageWithCap(absl::string_view message, std::size_t cap) {
  const std::string out = api::SafeMessage(message, cap);
  const std::string where =
      absl::StrCat("SafeMessage(cap ", cap, ") of ", message.size(), " bytes");
  OAIPP_FUZZ_CHECK(AllPrintable(out), where);
  const absl::string_view kept = message.substr(0, cap);
  const bool cut = message.size() > cap;
  const std::string note = cut ? CutNote(message.size()) : std::string();
  OAIPP_FUZZ_CHECK(out.size() <= 4 * kept.size() + note.size(), where);
  OAIPP_FUZZ_CHECK(absl::EndsWith(out, note), where);
  if (AllPrintable(kept)) OAIPP_FUZZ_CHECK(out == absl::StrCat(kept, note), where);
}

}  // namespace

void Fail(absl::string_view what, absl::string_view detail) {
  std::fprintf(stderr, "fuzz check failed: %.*s: %.*s\n", static_cast<int>(what.size()),
               what.data(), static_cast<int>(detail.size()), detail.data());
  std::fflush(stderr);
  std::abort();
}

void CheckEchoInput(absl::string_view input) {
  for (const std::size_t cap : kEchoCaps) CheckEchoInputWithCap(input, cap);
}

void CheckSafeMessage(absl::string_view message) {
  for (const std::size_t cap : kMessageCaps) CheckSafeMessageWithCap(message, cap);
}

void CheckError(const absl::Status& status, std::initializer_list<absl::StatusCode> allowed,
                absl::string_view where) {
  if (status.ok()) return;
  const std::string detail = absl::StrCat(where, ": ", status.ToString());
  OAIPP_FUZZ_CHECK(std::find(allowed.begin(), allowed.end(), status.code()) != allowed.end(),
                   detail);
  OAIPP_FUZZ_CHECK(!status.message().empty(), detail);
  CheckSafeMessage(status.message());
  const grpc::Status wire = api::ToGrpcStatus(status);
  OAIPP_FUZZ_CHECK(static_cast<int>(wire.error_code()) == static_cast<int>(status.code()), detail);
  OAIPP_FUZZ_CHECK(wire.error_message() == status.message(), detail);
  const absl::Status back = api::FromGrpcStatus(wire);
  OAIPP_FUZZ_CHECK(back.code() == status.code() && back.message() == status.message(), detail);
  const absl::Status named = api::FromGrpcStatus(wire, "Rpc");
  OAIPP_FUZZ_CHECK(named.message() == absl::StrCat("Rpc: ", status.message()), detail);
}

bool NearlyEqualAngle(double a, double b) {
  if (a == b) return true;
  const double diff = std::abs(a - b);
  const double scale = std::max(std::abs(a), std::abs(b));
  return diff <= 16 * std::numeric_limits<double>::epsilon() * scale || diff <= 1e-300;
}

}  // namespace oaipp::fuzz

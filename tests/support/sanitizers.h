// Whether this test build runs under a sanitizer, for the cases that do
// less there: the sanitizer builds run 10-20 times slower, so a case that
// checks one code path on hundreds of random inputs checks it on a tenth of
// them there, and the Release build, which runs all of them, carries the
// full count (RELEASE in the case's oaipp_add_test, tests/CMakeLists.txt).
#pragma once

namespace oaipp::testing {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

// `count` in an optimised build, a tenth of it (at least 1) under a sanitizer.
constexpr int UnlessSanitized(int count) { return kSanitized ? (count + 9) / 10 : count; }

}  // namespace oaipp::testing

// The minimum over [0, 1] of a function convex there (a signed distance
// along a segment of a convex shape), by golden-section search down to
// 1e-10 m of a segment `length_m` long.
#pragma once

#include <algorithm>

namespace oaipp {

template <typename F>
[[nodiscard]] double MinimumOfConvex(const F& f, double length_m) {
  constexpr double kInvPhi = 0.6180339887498949;
  double lo = 0.0;
  double hi = 1.0;
  double x1 = hi - kInvPhi * (hi - lo);
  double x2 = lo + kInvPhi * (hi - lo);
  double f1 = f(x1);
  double f2 = f(x2);
  while ((hi - lo) * length_m > 1e-10 && hi - lo > 1e-15) {
    if (f1 <= f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - kInvPhi * (hi - lo);
      f1 = f(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + kInvPhi * (hi - lo);
      f2 = f(x2);
    }
  }
  return std::min({f(0.0), f(1.0), f1, f2});
}

}  // namespace oaipp

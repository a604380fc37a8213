#include "sim/random_world.h"

#include <cmath>
#include <random>
#include <vector>

#include "absl/strings/str_cat.h"
#include "api/spec.h"

namespace oaipp::sim {
namespace {

struct Rect {
  double x0, y0, x1, y1;
  [[nodiscard]] Rect Grown(double d) const { return {x0 - d, y0 - d, x1 + d, y1 + d}; }
  [[nodiscard]] bool Overlaps(const Rect& o) const {
    return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1;
  }
  // Horizontal distance from (x, y) to the rectangle (0 inside).
  [[nodiscard]] double Distance(double x, double y) const {
    const double dx = std::max({x0 - x, 0.0, x - x1});
    const double dy = std::max({y0 - y, 0.0, y - y1});
    return std::hypot(dx, dy);
  }
};

}  // namespace

std::string BuildingKindName(BuildingKind kind) {
  return kind == BuildingKind::kLowRise ? "low-rise" : "high-rise";
}

absl::StatusOr<v1::Scenario> RandomWorld(const v1::Scenario& base,
                                         const RandomWorldOptions& options) {
  if (options.count < 0 || options.count > 40) {
    return absl::InvalidArgumentError(
        absl::StrCat("count: must be in [0, 40], got ", options.count));
  }
  if (!(options.gap_m >= 0.0) || !std::isfinite(options.gap_m)) {
    return absl::InvalidArgumentError("gap_m: must be >= 0 and finite");
  }
  if (!(options.start_clearance_m >= 0.0) || !std::isfinite(options.start_clearance_m)) {
    return absl::InvalidArgumentError("start_clearance_m: must be >= 0 and finite");
  }
  v1::MissionSpec spec = base.mission();
  spec.clear_obstacles();
  absl::StatusOr<api::MissionConfig> config = api::MissionSpecToConfig(spec);
  if (!config.ok()) return config.status();

  const double side = 4.0;
  const double height = options.kind == BuildingKind::kLowRise ? 13.0 : 26.0;
  const Vec2 lo = config->field_min_W, hi = config->field_max_W;
  if (hi.x() - lo.x() < side || hi.y() - lo.y() < side) {
    return absl::FailedPreconditionError("the field is smaller than one building");
  }
  std::vector<Rect> keep_out;  // targets, grown by the gap
  for (const v1::Target& t : base.targets()) {
    keep_out.push_back(
        Rect{t.x_min_m(), t.y_min_m(), t.x_max_m(), t.y_max_m()}.Grown(options.gap_m));
  }
  const Vec3 start = config->start.position_W;
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> ux(lo.x() + side / 2, hi.x() - side / 2);
  std::uniform_real_distribution<double> uy(lo.y() + side / 2, hi.y() - side / 2);
  // Sequential placement can jam at high density: start over (the RNG runs
  // on, so the same seed still gives the same world) a bounded number of
  // times.
  constexpr int kRestarts = 200, kDraws = 2000;
  for (int restart = 0; restart < kRestarts; ++restart) {
    std::vector<Rect> placed;
    for (int b = 0; b < options.count; ++b) {
      for (int draw = 0; draw < kDraws; ++draw) {
        const double cx = ux(rng), cy = uy(rng);
        const Rect r{cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2};
        if (r.Distance(start.x(), start.y()) < options.start_clearance_m) continue;
        bool free = true;
        for (const Rect& k : keep_out) free = free && !r.Overlaps(k);
        for (const Rect& p : placed) free = free && !r.Overlaps(p.Grown(options.gap_m));
        if (!free) continue;
        placed.push_back(r);
        break;
      }
      if (static_cast<int>(placed.size()) <= b) break;  // jammed: start over
    }
    if (static_cast<int>(placed.size()) < options.count) continue;
    v1::Scenario out = base;
    out.mutable_mission()->clear_obstacles();
    for (std::size_t b = 0; b < placed.size(); ++b) {
      v1::Obstacle& o = *out.mutable_mission()->add_obstacles();
      o.set_id(absl::StrCat(BuildingKindName(options.kind), "-", b + 1));
      v1::Vector3& c = *o.mutable_box()->mutable_centre_m();
      c.set_x(0.5 * (placed[b].x0 + placed[b].x1));
      c.set_y(0.5 * (placed[b].y0 + placed[b].y1));
      c.set_z(height / 2);
      v1::Vector3& size = *o.mutable_box()->mutable_size_m();
      size.set_x(side);
      size.set_y(side);
      size.set_z(height);
    }
    return out;
  }
  return absl::FailedPreconditionError(absl::StrCat("no free place for ", options.count,
                                                    " buildings after ", kRestarts,
                                                    " attempts: lower count or gap_m"));
}

}  // namespace oaipp::sim

// When each UAV's fused shots were taken, for counting a teammate's shots
// still to come exactly once (docs/teams.md "Shots still to come"): a
// planned shot is in the map when a shot of that UAV fused so far was taken
// within half a camera period of its planned time (a camera stamps a shot a
// little before or after it was due), and still to come otherwise. The rule
// reads a set, not the latest time, so a shot delivered late, after a later
// one of the same UAV, counts as still to come until it arrives and as in
// the map from then on, whatever the order of delivery.
//
//   FusedShots shots;
//   shots.Add("b", 12.0);
//   bool in_map = shots.Fused("b", 12.1, /*half_period_s=*/3.3);   // true
//
// Not thread-safe: the mission holds it under its state lock and hands
// copies to plans.
#pragma once

#include <limits>
#include <map>
#include <string>
#include <vector>

namespace oaipp::server {

class FusedShots {
 public:
  // A shot of `uav_id` taken at mission time t_s was fused.
  void Add(const std::string& uav_id, double t_s);
  // Whether a shot of `uav_id` planned for t_s is in the map.
  [[nodiscard]] bool Fused(const std::string& uav_id, double t_s, double half_period_s) const;
  // The latest fused shot of `uav_id` (-infinity: none).
  [[nodiscard]] double Latest(const std::string& uav_id) const;
  // Lets go of times before t_s, which no plan can ask about any more (a
  // plan asks about shots at or after its own start).
  void Prune(double t_s);

  // Snapshots: the times kept per UAV, and what a snapshot written before
  // times were kept gives instead, the latest time alone, before which
  // every shot is taken as fused (as those builds counted).
  [[nodiscard]] std::map<std::string, std::vector<double>> Times() const;
  void Restore(std::map<std::string, std::vector<double>> times,
               const std::map<std::string, double>& legacy_latest);

 private:
  struct Shots {
    double fused_through_s = -std::numeric_limits<double>::infinity();  // legacy snapshots
    std::vector<double> times_s;                                        // sorted
  };
  std::map<std::string, Shots> shots_;
};

}  // namespace oaipp::server

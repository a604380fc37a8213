// Who left a team: the members taken out (RemoveTeamMember), in the order
// removed, and those of them that landed. Its own lock, a leaf: every plan
// asks it, and Snapshot() reads it without waiting for a plan or a change.
//
//   TeamRoster roster;
//   roster.Remove("b", /*landed=*/false);
//   roster.Removed("b");  // true; roster.Landed("b") is false until Remove("b", true)
#pragma once

#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"

namespace oaipp::server {

class TeamRoster {
 public:
  [[nodiscard]] bool Removed(const std::string& uav_id) const;
  [[nodiscard]] bool Landed(const std::string& uav_id) const;
  // Takes `uav_id` out (once: a second removal only adds that it landed).
  void Remove(const std::string& uav_id, bool landed);
  // In the order removed, and of those, the ones that landed.
  [[nodiscard]] std::vector<std::string> removed() const;
  [[nodiscard]] std::vector<std::string> landed() const;
  // Recovery: the lists as a snapshot held them (checked by the caller).
  void Restore(std::vector<std::string> removed, std::vector<std::string> landed);

 private:
  mutable absl::Mutex mu_;
  std::vector<std::string> removed_ ABSL_GUARDED_BY(mu_);
  std::vector<std::string> landed_ ABSL_GUARDED_BY(mu_);
};

}  // namespace oaipp::server

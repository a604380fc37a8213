// Which replica a proxy sends a mission's calls to: HAProxy's consistent
// hashing of the routing header (deploy/cluster/haproxy.cfg.in: `balance
// hdr(x-oaipp-mission)`, `hash-type consistent` with its default hash, sdbm
// with avalanche, and servers of weight 1 placed by their `id`). A replica
// computes it to know which missions would come to it if their holder died
// (its warm standbys, docs/cluster.md).
//
//   HashRing ring({1, 2, 3});  // the proxies' server ids of the live replicas
//   int id = ring.Pick(HashRing::RouteHash("m-17"));  // 0 for an empty ring
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "absl/strings/string_view.h"

namespace oaipp::server {

class HashRing {
 public:
  // The ring of the servers with these ids (positive; others are ignored).
  explicit HashRing(const std::vector<int>& ids);

  // The hash a proxy computes of a routing header's value.
  [[nodiscard]] static std::uint32_t RouteHash(absl::string_view route);
  // The id of the server whose point on the ring is nearest to `hash`
  // (the earlier one on a tie, wrapping around); 0 when the ring is empty.
  [[nodiscard]] int Pick(std::uint32_t hash) const;

 private:
  // (point, server id), sorted by point.
  std::vector<std::pair<std::uint32_t, int>> points_;
};

}  // namespace oaipp::server

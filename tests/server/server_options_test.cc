// A replica's ring id: given, or read from the end of its replica id (a
// StatefulSet pod's name) plus one; refused where it cannot mean anything.
// Likewise how long a replica may say nothing before it is silent.
#include "server/server_options.h"

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace oaipp::server {
namespace {

using ::testing::HasSubstr;

ServerOptions Replica(std::string replica_id) {
  ServerOptions o;
  o.cluster = true;
  o.store = "postgresql://localhost/oaipp";
  o.replica_id = std::move(replica_id);
  return o;
}

TEST(ServerOptionsTest, TheRingIdComesFromThePodsOrdinal) {
  ServerOptions o = Replica("oaipp-server-0");
  o.ring_id_from_ordinal = true;
  EXPECT_TRUE(o.Validate().ok()) << o.Validate();
  EXPECT_EQ(o.EffectiveRingId(), 1);
  o.replica_id = "oaipp-server-17";
  EXPECT_EQ(o.EffectiveRingId(), 18);
  o = Replica("oaipp-server-0");
  o.ring_id = 4;
  EXPECT_EQ(o.EffectiveRingId(), 4);
}

TEST(ServerOptionsTest, ARingIdThatCannotMeanAnythingIsRefusedNamingItsFlag) {
  ServerOptions o = Replica("replica");
  o.ring_id_from_ordinal = true;
  EXPECT_THAT(std::string(o.Validate().message()),
              HasSubstr("--ring_id_from_ordinal: needs a --replica_id that ends in a number"));
  o.replica_id = "r-1234567";  // seven digits
  EXPECT_THAT(std::string(o.Validate().message()), HasSubstr("--ring_id_from_ordinal: needs"));
  o.replica_id = "r-1";
  o.ring_id = 2;
  EXPECT_THAT(std::string(o.Validate().message()),
              HasSubstr("--ring_id_from_ordinal: conflicts with --ring_id"));
  o = Replica("r-1");
  o.ring_id = -1;
  EXPECT_THAT(std::string(o.Validate().message()), HasSubstr("--ring_id: must be 0 (none)"));
  o = ServerOptions();
  o.ring_id = 3;
  EXPECT_THAT(std::string(o.Validate().message()),
              HasSubstr("--ring_id: is for a replica of a cluster"));
  o.ring_id = 0;
  o.ring_id_from_ordinal = true;
  o.replica_id = "r-1";
  EXPECT_THAT(std::string(o.Validate().message()),
              HasSubstr("--ring_id_from_ordinal: is for a replica of a cluster"));
}

TEST(ServerOptionsTest, ASilenceOutOfRangeOrWithoutAClusterIsRefusedNamingItsFlag) {
  ServerOptions o = Replica("r-1");
  o.silent_after = absl::Seconds(2);
  EXPECT_TRUE(o.Validate().ok()) << o.Validate();
  o.silent_after = absl::Milliseconds(49);
  EXPECT_THAT(std::string(o.Validate().message()),
              HasSubstr("--silent_after: must be in [50ms, 60s], got 49ms"));
  o.silent_after = absl::Seconds(61);
  EXPECT_THAT(std::string(o.Validate().message()), HasSubstr("--silent_after: must be in"));
  o.silent_after = -absl::Seconds(1);
  EXPECT_THAT(std::string(o.Validate().message()), HasSubstr("--silent_after: must be in"));
  o = ServerOptions();
  o.silent_after = absl::Seconds(2);
  EXPECT_THAT(std::string(o.Validate().message()),
              HasSubstr("--silent_after: is for a replica of a cluster"));
  o.silent_after = absl::Milliseconds(500);  // the default, given
  EXPECT_TRUE(o.Validate().ok()) << o.Validate();
}

}  // namespace
}  // namespace oaipp::server

// The eviction and idle-timeout policy both servers use (common/idle_clients.hpp).
#include "common/idle_clients.hpp"

#include <gtest/gtest.h>

namespace candp2 {
namespace {

TEST(IdleClients, EvictsTheOneIdleLongest) {
  IdleClients c;
  EXPECT_EQ(c.longest_idle(), std::nullopt);
  c.touch(7, Time(100));
  c.touch(3, Time(200));
  c.touch(9, Time(50));
  EXPECT_EQ(c.longest_idle(), 9u);
  c.touch(9, Time(300));  // traffic makes it the most recent
  EXPECT_EQ(c.longest_idle(), 7u);
  c.remove(7);
  EXPECT_EQ(c.longest_idle(), 3u);
  EXPECT_EQ(c.size(), 2u);
}

TEST(IdleClients, TimeoutZeroNeverExpires) {
  IdleClients c(Duration(0));
  c.touch(1, Time(0));
  EXPECT_TRUE(c.expired(Time(1'000'000'000)).empty());
  EXPECT_EQ(c.next_expiry(), std::nullopt);
}

TEST(IdleClients, ExpiresAfterTheTimeoutSinceTheLastTraffic) {
  IdleClients c(seconds(60));
  c.touch(1, seconds(0));
  c.touch(2, seconds(10));
  EXPECT_EQ(c.next_expiry(), seconds(60));
  EXPECT_TRUE(c.expired(seconds(59)).empty());
  EXPECT_EQ(c.expired(seconds(60)), std::vector<IdleClients::Id>{1});
  c.touch(1, seconds(61));
  EXPECT_EQ(c.next_expiry(), seconds(70));
  EXPECT_EQ(c.expired(seconds(70)), std::vector<IdleClients::Id>{2});
}

}  // namespace
}  // namespace candp2

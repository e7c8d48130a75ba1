// candp2d's simulated clock (daemon/sim_clock.hpp, docs/daemon.md "Host stalls").
#include "daemon/sim_clock.hpp"

#include <gtest/gtest.h>

namespace candp2::daemon {
namespace {

TEST(SimClock, LatenessWithinTheToleranceStaysIn) {
  SimClock c(milliseconds(50));
  EXPECT_EQ(c.now(Time(milliseconds(1049)), Time(milliseconds(1000))), Time(milliseconds(1049)));
  EXPECT_EQ(c.now(Time(milliseconds(1050)), Time(milliseconds(1000))), Time(milliseconds(1050)));
  EXPECT_EQ(c.stalls().count, 0u);
}

TEST(SimClock, AStallIsTakenOutWholeAndCounted) {
  SimClock c(milliseconds(50));
  Duration stall{0};
  // Due at 1000 ms, the loop back at 1300 ms: the world goes on at its deadline.
  EXPECT_EQ(c.now(Time(milliseconds(1300)), Time(milliseconds(1000)), &stall),
            Time(milliseconds(1000)));
  EXPECT_EQ(stall, milliseconds(300));
  EXPECT_EQ(c.to_loop(Time(milliseconds(1010))), Time(milliseconds(1310)));
  // The next deadline (simulated 1010) met on time: no stall, the offset stays.
  EXPECT_EQ(c.now(Time(milliseconds(1311)), Time(milliseconds(1010)), &stall),
            Time(milliseconds(1011)));
  EXPECT_EQ(stall, Duration(0));
  // A second stall, 200 ms.
  EXPECT_EQ(c.now(Time(milliseconds(1510)), Time(milliseconds(1010))), Time(milliseconds(1010)));
  EXPECT_EQ(c.stalls().count, 2u);
  EXPECT_EQ(c.stalls().total, milliseconds(500));
  EXPECT_EQ(c.stalls().longest, milliseconds(300));
}

TEST(SimClock, NothingDueOrToleranceZeroIsNoStall) {
  SimClock c(milliseconds(50));
  EXPECT_EQ(c.now(Time(seconds(10)), std::nullopt), Time(seconds(10)));
  SimClock off(Duration(0));
  EXPECT_EQ(off.now(Time(seconds(10)), Time(seconds(1))), Time(seconds(10)));
  EXPECT_EQ(c.stalls().count + off.stalls().count, 0u);
}

}  // namespace
}  // namespace candp2::daemon

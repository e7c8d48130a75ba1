// common/ring.hpp: a first-in first-out queue in one array (docs/can-bus.md "Performance": the
// CAN transmit and receive queues).
#include "common/ring.hpp"

#include <gtest/gtest.h>

namespace candp2 {
namespace {

TEST(Ring, FirstInFirstOutAcrossTheEndOfItsArray) {
  Ring<int> r;
  EXPECT_TRUE(r.empty());
  for (int i = 0; i < 6; ++i) r.push_back(i);  // 8 long
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(r.front(), i);
    r.pop_front();
  }
  for (int i = 6; i < 12; ++i) r.push_back(i);  // wraps: items at 5..7 and 0..3
  EXPECT_EQ(r.size(), 7u);
  for (int i = 5; i < 12; ++i) {
    EXPECT_EQ(r.front(), i);
    r.pop_front();
  }
  EXPECT_TRUE(r.empty());
}

TEST(Ring, GrowsWhileWrappedAndKeepsTheOrder) {
  Ring<int> r;
  for (int i = 0; i < 8; ++i) r.push_back(i);
  for (int i = 0; i < 3; ++i) r.pop_front();
  for (int i = 8; i < 11; ++i) r.push_back(i);   // full and wrapped: the head is not at 0
  for (int i = 11; i < 40; ++i) r.push_back(i);  // grows twice
  EXPECT_EQ(r.size(), 37u);
  for (int i = 3; i < 40; ++i) {
    ASSERT_EQ(r.front(), i);
    r.pop_front();
  }
  EXPECT_TRUE(r.empty());
}

TEST(Ring, ClearEmptiesAndTheRingIsUsedAgain) {
  Ring<int> r;
  for (int i = 0; i < 5; ++i) r.push_back(i);
  r.pop_front();
  r.clear();
  EXPECT_TRUE(r.empty());
  EXPECT_EQ(r.size(), 0u);
  r.push_back(42);
  EXPECT_EQ(r.front(), 42);
  EXPECT_EQ(r.size(), 1u);
}

}  // namespace
}  // namespace candp2

// common/ring.hpp: a first-in first-out queue in one array (docs/can-bus.md "Performance": the
// CAN transmit and receive queues).
#include "common/ring.hpp"

#include <gtest/gtest.h>

namespace candp2 {
namespace {

// Pushes from..to-1.
void push(Ring<int>& r, int from, int to) {
  for (int i = from; i < to; ++i) r.push_back(i);
}

// Takes from..to-1 from the front, in this order.
void expect_front_to_back(Ring<int>& r, int from, int to) {
  for (int i = from; i < to; ++i) {
    ASSERT_EQ(r.front(), i);
    r.pop_front();
  }
}

TEST(Ring, FirstInFirstOutAcrossTheEndOfItsArray) {
  Ring<int> r;
  EXPECT_TRUE(r.empty());
  push(r, 0, 6);  // 8 long
  expect_front_to_back(r, 0, 5);
  push(r, 6, 12);  // wraps: items at 5..7 and 0..3
  EXPECT_EQ(r.size(), 7u);
  expect_front_to_back(r, 5, 12);
  EXPECT_TRUE(r.empty());
}

TEST(Ring, GrowsWhileWrappedAndKeepsTheOrder) {
  Ring<int> r;
  push(r, 0, 8);
  for (int i = 0; i < 3; ++i) r.pop_front();
  push(r, 8, 11);   // full and wrapped: the head is not at 0
  push(r, 11, 40);  // grows twice
  EXPECT_EQ(r.size(), 37u);
  expect_front_to_back(r, 3, 40);
  EXPECT_TRUE(r.empty());
}

TEST(Ring, ClearEmptiesAndTheRingIsUsedAgain) {
  Ring<int> r;
  push(r, 0, 5);
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

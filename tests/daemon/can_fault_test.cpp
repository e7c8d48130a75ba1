// The fault layer between a gateway and its CAN channel (faults/can_fault.hpp, docs/faults.md).
#include "faults/can_fault.hpp"

#include <gtest/gtest.h>

namespace candp2::faults {
namespace {

using can::BusState;

TEST(CanFaultLayer, RealStatePassesThroughUntilForced) {
  CanFaultLayer f;
  EXPECT_EQ(f.forced_code(), 0);
  EXPECT_EQ(f.state(BusState::ErrorPassive), BusState::ErrorPassive);
  EXPECT_EQ(f.rx_lost(4), 4u);
  EXPECT_TRUE(f.pass_tx());
  EXPECT_TRUE(f.pass_rx());
}

TEST(CanFaultLayer, ForcedStatesOverrideTheChannel) {
  CanFaultLayer f;
  // Holding register 8193: 1 warning, 2 error-passive, 3 bus-off (manual table 3.4.5 byte 8).
  ASSERT_TRUE(f.force(1));
  EXPECT_EQ(f.state(BusState::Ok), BusState::Warning);
  ASSERT_TRUE(f.force(2));
  EXPECT_EQ(f.state(BusState::Ok), BusState::ErrorPassive);
  EXPECT_TRUE(f.pass_tx());  // error-passive still transmits
  EXPECT_TRUE(f.pass_rx());
  ASSERT_TRUE(f.force(3));
  EXPECT_EQ(f.state(BusState::Ok), BusState::BusOff);
  EXPECT_EQ(f.forced_code(), 3);
  EXPECT_FALSE(f.force(4));  // refused, unchanged
  EXPECT_EQ(f.forced_code(), 3);
  ASSERT_TRUE(f.force(0));
  EXPECT_EQ(f.state(BusState::Warning), BusState::Warning);  // the real state again
}

TEST(CanFaultLayer, BusOffSendsAndReceivesNothingAndQueuesNothing) {
  CanFaultLayer f;
  f.force(3);
  for (int i = 0; i < 5; ++i) EXPECT_FALSE(f.pass_tx());
  for (int i = 0; i < 2; ++i) EXPECT_FALSE(f.pass_rx());
  EXPECT_EQ(f.tx_suppressed(), 5u);
  EXPECT_EQ(f.rx_suppressed(), 2u);
  EXPECT_EQ(f.rx_lost(0), 0u);  // off the bus: nothing lost by the controller
  f.force(0);
  EXPECT_TRUE(f.pass_tx());
  EXPECT_TRUE(f.pass_rx());
  EXPECT_EQ(f.tx_suppressed(), 5u);
}

TEST(CanFaultLayer, DropBudgetCountsInIrqLost) {
  CanFaultLayer f;
  f.drop_next(3);
  EXPECT_EQ(f.drop_remaining(), 3u);
  EXPECT_FALSE(f.pass_rx());
  EXPECT_FALSE(f.pass_rx());
  EXPECT_EQ(f.drop_remaining(), 1u);
  EXPECT_EQ(f.rx_lost(10), 12u);  // docs/dp-slave.md "Diagnosis": IRQ_LOST = channel losses +
                                  // dropped
  EXPECT_FALSE(f.pass_rx());
  EXPECT_TRUE(f.pass_rx());
  EXPECT_EQ(f.rx_dropped(), 3u);
  EXPECT_TRUE(f.pass_tx());  // the budget only concerns reception
  // Bus-off takes precedence: the budget is not used up while off the bus.
  f.drop_next(1);
  f.force(3);
  EXPECT_FALSE(f.pass_rx());
  EXPECT_EQ(f.drop_remaining(), 1u);
  f.drop_next(0);
  EXPECT_EQ(f.drop_remaining(), 0u);
}

}  // namespace
}  // namespace candp2::faults

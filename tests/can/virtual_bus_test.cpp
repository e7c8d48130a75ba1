#include "can/virtual_bus.hpp"

#include <gtest/gtest.h>

namespace candp2::can {
namespace {

Frame F(const char* text) {
  return *parse_candump(text).frame;
}

TEST(VirtualBus, OthersReceiveInSendOrderSenderDoesNot) {
  VirtualBus bus;
  auto a = bus.endpoint("a");
  auto b = bus.endpoint("b");
  auto c = bus.endpoint("c");
  a->send(F("001#01"));
  b->send(F("002#02"));
  a->send(F("003#03"));
  EXPECT_EQ(format_candump(*b->receive()), "001#01");
  EXPECT_EQ(format_candump(*b->receive()), "003#03");
  EXPECT_FALSE(b->receive());
  EXPECT_EQ(format_candump(*c->receive()), "001#01");
  EXPECT_EQ(format_candump(*c->receive()), "002#02");
  EXPECT_EQ(format_candump(*c->receive()), "003#03");
  EXPECT_EQ(format_candump(*a->receive()), "002#02");
  EXPECT_FALSE(a->receive());
}

TEST(VirtualBus, ReceiveOwnWhenAsked) {
  VirtualBus bus;
  auto a = bus.endpoint("a", /*receive_own=*/true);
  a->send(F("123#R"));
  auto f = a->receive();
  ASSERT_TRUE(f);
  EXPECT_TRUE(f->remote);
}

TEST(VirtualBus, BoundedQueueCountsLostFrames) {
  VirtualBus bus({.rx_queue_limit = 2});
  auto a = bus.endpoint("a");
  auto b = bus.endpoint("b");
  for (int i = 0; i < 5; ++i) a->send(F("100#00"));
  EXPECT_EQ(b->pending(), 2u);
  EXPECT_EQ(b->rx_lost(), 3u);
}

TEST(VirtualBus, BusOffStopsTraffic) {
  VirtualBus bus;
  auto a = bus.endpoint("a");
  auto b = bus.endpoint("b");
  bus.set_bus_state(BusState::BusOff);
  EXPECT_EQ(a->bus_state(), BusState::BusOff);
  a->send(F("100#00"));
  EXPECT_EQ(a->tx_dropped(), 1u);
  EXPECT_FALSE(b->receive());
  bus.set_bus_state(BusState::Warning);
  a->send(F("100#00"));
  EXPECT_TRUE(b->receive());
  EXPECT_EQ(b->bus_state(), BusState::Warning);
}

TEST(VirtualBus, PerEndpointOverrideAndInjectedLoss) {
  VirtualBus bus;
  auto a = bus.endpoint("a");
  a->set_bus_state_override(BusState::ErrorPassive);
  EXPECT_EQ(a->bus_state(), BusState::ErrorPassive);
  a->inject_rx_lost(7);
  EXPECT_EQ(a->rx_lost(), 7u);
}

TEST(VirtualBus, TapSeesFramesWithInjectedTime) {
  VirtualBus bus;
  std::vector<std::string> seen;
  bus.add_tap([&](const Frame& f, Time t, std::string_view who) {
    seen.push_back(std::to_string(t.count()) + " " + std::string(who) + " " + format_candump(f));
  });
  auto a = bus.endpoint("gw");
  bus.set_now(Time{1500});
  a->send(F("181#01"));
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0], "1500 gw 181#01");
}

TEST(VirtualBus, EndpointDetachesOnDestruction) {
  VirtualBus bus;
  auto a = bus.endpoint("a");
  { auto b = bus.endpoint("b"); }
  a->send(F("100#00"));  // must not touch the destroyed endpoint
  EXPECT_EQ(bus.frames_sent(), 1u);
}

}  // namespace
}  // namespace candp2::can

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

namespace candp2::can {
namespace {

// docs/can-bus.md "The bus in time": with a bit rate the frame waits for the bus and its end.
TEST(VirtualBusInTime, DeliveredAtTheEndTappedAtTheStart) {
  VirtualBus bus;
  Time now{0};
  bus.use_clock(&now);
  bus.set_bitrate(125000, Time(0));
  auto a = bus.endpoint("a");
  auto b = bus.endpoint("b");
  std::vector<std::string> taps;
  bus.add_tap([&](const Frame& f, Time t, std::string_view sender) {
    taps.push_back(std::to_string(t.count()) + " " + std::string(sender) + " " + format_candump(f));
  });
  a->send(*parse_candump("123#1122334455667788").frame);
  b->send(*parse_candump("080#").frame);
  EXPECT_FALSE(b->receive());  // nothing is on the bus before it is advanced
  EXPECT_EQ(bus.next_deadline(), Time(0));
  bus.advance(now);
  EXPECT_EQ(taps, (std::vector<std::string>{"0 b 080#"}));
  EXPECT_FALSE(a->receive());  // 080# is on the bus until 408 µs (51 bits)
  EXPECT_EQ(bus.next_deadline(), Time(408));
  now = Time(408);
  bus.advance(now);
  EXPECT_EQ(format_candump(*a->receive()), "080#");
  EXPECT_FALSE(b->receive());  // the sender does not get its own frame
  now = Time(408 + 896);
  bus.advance(now);
  EXPECT_EQ(format_candump(*b->receive()), "123#1122334455667788");
  EXPECT_EQ(taps.back(), "408 a 123#1122334455667788");
  EXPECT_EQ(bus.frames_sent(), 2u);
  EXPECT_EQ(bus.timed()->frames(), 2u);
}

// docs/can-bus.md "Performance": the frames that end in an advance are one change without a state
// (the plant then looks only at the endpoints that hold frames: each one they reached, also one
// whose full queue counted one lost); a change of state says so. An ideal bus's changes all do.
TEST(VirtualBusInTime, FramesEndedAreOneChangeWithoutStateAndReachedEndpointsHoldThem) {
  VirtualBus bus({.rx_queue_limit = 1});
  Time now{0};
  bus.use_clock(&now);
  bus.set_bitrate(125000, Time(0));
  std::vector<bool> hooks;
  bus.on_changed([&](bool state) { hooks.push_back(state); });
  auto a = bus.endpoint("a");
  auto b = bus.endpoint("b");
  auto c = bus.endpoint("c");
  hooks.clear();
  const std::uint64_t states = bus.state_changes();
  a->send(F("123#11"));
  a->send(F("124#22"));
  EXPECT_TRUE(hooks.empty());  // requests: nothing reached anybody yet
  now = Time(10000);           // both frames end by then
  bus.advance(now);
  EXPECT_EQ(hooks, (std::vector<bool>{false}));
  EXPECT_EQ(bus.state_changes(), states);
  EXPECT_EQ(a->pending(), 0u);  // the sender holds nothing
  EXPECT_EQ(b->pending(), 1u);  // the second frame found the queue full
  EXPECT_EQ(b->rx_lost(), 1u);
  EXPECT_EQ(c->pending(), 1u);
  a->set_bus_state_override(BusState::Warning);
  EXPECT_EQ(hooks, (std::vector<bool>{false, true}));

  VirtualBus ideal({.rx_queue_limit = 0});  // a queue holds at least one frame
  std::vector<bool> ideal_hooks;
  ideal.on_changed([&](bool state) { ideal_hooks.push_back(state); });
  auto x = ideal.endpoint("x");
  auto y = ideal.endpoint("y");
  ideal_hooks.clear();
  x->send(F("001#01"));
  x->send(F("002#02"));
  EXPECT_EQ(ideal_hooks, (std::vector<bool>{true, true}));
  EXPECT_EQ(y->pending(), 1u);
  EXPECT_EQ(y->rx_lost(), 1u);
}

// A gateway's frame lost past its full queue counts in IRQ_LOST (rx_lost, manual §3.4.2 "receive
// or send"); another node's in tx_dropped.
TEST(VirtualBusInTime, LostPastTheQueueCountedWhereTheDeviceCountsIt) {
  VirtualBus bus;
  bus.set_bitrate(125000, Time(0));
  auto gw = bus.endpoint("gw");
  gw->set_tx_queue({2, true});
  auto node = bus.endpoint("node");
  node->set_tx_queue({1, false});
  const std::uint64_t before = bus.changes();
  for (int i = 0; i < 3; ++i) gw->send(*parse_candump("001#").frame);
  node->send(*parse_candump("002#").frame);
  node->send(*parse_candump("002#").frame);
  EXPECT_EQ(gw->rx_lost(), 1u);
  EXPECT_EQ(gw->tx_dropped(), 0u);
  EXPECT_EQ(node->tx_dropped(), 1u);
  EXPECT_EQ(node->rx_lost(), 0u);
  EXPECT_GT(bus.changes(), before);  // the controller's count changed: the plant looks again
  EXPECT_EQ(bus.timed()->lost(), 2u);
}

// docs/can-bus.md "Error confinement": an endpoint's state is the worse of the forced one and its
// node's; a node at its own bit rate other than the bus's gets nothing and its frames are errors;
// a node that does not acknowledge leaves a sender alone.
// A 125 kbit/s bus on its own clock, advanced event by event (at most `events`).
struct Clocked {
  VirtualBus bus;
  Time now{0};
  Clocked() {
    bus.use_clock(&now);
    bus.set_bitrate(125000, Time(0));
  }
  void run(int events) {
    for (int k = 0; k < events && bus.next_deadline(); ++k) {
      now = *bus.next_deadline();
      bus.advance(now);
    }
  }
};

TEST(VirtualBusInTime, AnEndpointsStateIsTheWorseOfForcedAndConfinement) {
  Clocked c;
  VirtualBus& bus = c.bus;
  auto a = bus.endpoint("a");
  auto b = bus.endpoint("b");
  auto tester = bus.endpoint("tester");
  tester->set_acknowledges(false);
  a->set_bus_state_override(BusState::Warning);
  EXPECT_EQ(a->bus_state(), BusState::Warning);  // forced, confinement ok
  a->set_bus_state_override(std::nullopt);
  b->set_own_bitrate(125000);  // its Set_Prm says the bus's rate: no effect
  a->set_own_bitrate(250000);  // another rate: a node at a wrong bit rate
  const std::uint64_t before = bus.changes();
  b->send(*parse_candump("080#").frame);
  c.run(200);
  EXPECT_GT(bus.changes(), before);
  // b's frame: nobody acknowledges (a at a wrong rate, the tester listen-only): ACK errors to
  // error passive; a's REC rises with each, the tester's too, and neither gets the frame.
  EXPECT_EQ(b->bus_state(), BusState::ErrorPassive);
  EXPECT_EQ(b->confinement()->tec, 128u);
  EXPECT_GE(a->confinement()->rec, 16u);
  EXPECT_FALSE(a->receive());
  EXPECT_FALSE(tester->receive());
  EXPECT_EQ(bus.frames_sent(), 0u);
  // a back at the bus's rate acknowledges: b's next attempt gets through, to a and the tester.
  a->set_own_bitrate(125000);
  c.run(1000);
  EXPECT_EQ(format_candump(*a->receive()), "080#");
  EXPECT_EQ(format_candump(*tester->receive()), "080#");
  EXPECT_EQ(b->confinement()->tec, 127u);
  EXPECT_EQ(b->bus_state(), BusState::Warning);
  a->set_bus_state_override(BusState::BusOff);
  EXPECT_EQ(a->bus_state(), BusState::BusOff);  // forced worse than its confinement
}

TEST(VirtualBusInTime, IdealBusHasNoDeadline) {
  VirtualBus bus;
  auto a = bus.endpoint("a");
  a->send(*parse_candump("001#").frame);
  EXPECT_FALSE(bus.next_deadline());
  EXPECT_FALSE(bus.timed());
}

}  // namespace
}  // namespace candp2::can

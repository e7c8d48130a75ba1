// The CAN bus in time (docs/can-bus.md "The bus in time"): arbitration, queues, latency and load
// to the microsecond. Frame lengths are the hand-worked frames of frame_bits_test.cpp:
// 000# 53 bits, 080# 51 bits, 123#1122334455667788 112 bits, 7FF#FFFFFFFFFFFFFFFF 126 bits.
#include "can/timed_bus.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <initializer_list>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "can/frame_bits.hpp"

namespace candp2::can {
namespace {

Frame F(const char* text) {
  return *parse_candump(text).frame;
}

// "start end node frame" of every frame at its end.
struct Trace {
  std::vector<std::string> lines;
  explicit Trace(TimedBus& bus) {
    bus.on_end([this](const TimedBus::OnBus& f) {
      lines.push_back(std::to_string(f.start.count()) + " " + std::to_string(f.end.count()) + " " +
                      std::to_string(f.node) + " " + format_candump(f.frame));
    });
  }
};

void run(TimedBus& bus) {
  while (const auto d = bus.next_deadline()) bus.advance(*d);
}

// Each (node, frame) asks to send at `at`, in this order.
void request_all(TimedBus& bus, std::initializer_list<std::pair<std::size_t, const char*>> frames,
                 Time at) {
  for (const auto& [node, text] : frames) bus.request(node, F(text), at);
}

// 125 kbit/s: 8 µs a bit. Three nodes request at 0; the smallest identifier wins each idle.
TEST(TimedBus, ThreeNodesContendSmallestIdentifierFirstToTheBit) {
  TimedBus bus(125000, Time(0));
  Trace trace(bus);
  const auto a = bus.add_node(8), b = bus.add_node(8), c = bus.add_node(8);
  ASSERT_TRUE(bus.request(a, F("123#1122334455667788"), Time(0)));
  ASSERT_TRUE(bus.request(b, F("080#"), Time(0)));
  ASSERT_TRUE(bus.request(c, F("000#"), Time(0)));
  EXPECT_EQ(bus.next_deadline(), Time(0));
  bus.advance(Time(0));
  EXPECT_TRUE(bus.busy());
  EXPECT_EQ(bus.next_deadline(), Time(53 * 8));  // 000# on the bus: bits 0..53
  run(bus);
  // 000# bits 0..53, 080# 53..104, 123# 104..216: back to back, intermission included.
  EXPECT_EQ(trace.lines, (std::vector<std::string>{"0 424 2 000#", "424 832 1 080#",
                                                   "832 1728 0 123#1122334455667788"}));
  const auto& ids = bus.identifiers();
  EXPECT_EQ(ids.at(arbitration_key(F("000#"))).latency_last, Duration(0));
  EXPECT_EQ(ids.at(arbitration_key(F("080#"))).latency_last, Duration(424));
  EXPECT_EQ(ids.at(arbitration_key(F("123#11"))).latency_max, Duration(832));
  EXPECT_EQ(bus.frames(), 3u);
  EXPECT_EQ(bus.busy_bits(), 216u);
  EXPECT_FALSE(bus.next_deadline());
}

// A frame requested while another is on the bus contends at its end, with what waited longer.
TEST(TimedBus, RequestsDuringAFrameContendAtItsEnd) {
  TimedBus bus(125000, Time(0));
  Trace trace(bus);
  const auto a = bus.add_node(8), b = bus.add_node(8), c = bus.add_node(8);
  bus.request(a, F("123#1122334455667788"), Time(0));
  bus.advance(Time(0));
  bus.advance(Time(100));
  bus.request(b, F("7FF#FFFFFFFFFFFFFFFF"), Time(100));
  bus.advance(Time(500));
  bus.request(c, F("080#"), Time(500));
  run(bus);
  // 123# bits 0..112 (896 µs); 080# 112..163; 7FF# 163..289.
  EXPECT_EQ(trace.lines,
            (std::vector<std::string>{"0 896 0 123#1122334455667788", "896 1304 2 080#",
                                      "1304 2312 1 7FF#FFFFFFFFFFFFFFFF"}));
  EXPECT_EQ(bus.identifiers().at(arbitration_key(F("7FF#"))).latency_last, Duration(1204));
  EXPECT_EQ(bus.identifiers().at(arbitration_key(F("080#"))).latency_last, Duration(396));
}

// On an idle bus a frame starts at the first whole bit at or after its request.
TEST(TimedBus, IdleBusStartsAtTheNextBit) {
  TimedBus bus(125000, Time(1000));
  Trace trace(bus);
  const auto a = bus.add_node(8);
  bus.advance(Time(1003));
  bus.request(a, F("080#"), Time(1003));
  EXPECT_EQ(bus.next_deadline(), Time(1008));  // bit 1
  run(bus);
  EXPECT_EQ(trace.lines, (std::vector<std::string>{"1008 1416 0 080#"}));
  EXPECT_EQ(bus.identifiers().begin()->second.latency_last, Duration(5));
}

// 800 kbit/s: 1.25 µs a bit; stamps are the first microsecond at or after the bit.
TEST(TimedBus, StampsRoundUpToTheMicrosecond) {
  TimedBus bus(800000, Time(0));
  Trace trace(bus);
  const auto a = bus.add_node(8);
  bus.request(a, F("080#"), Time(0));
  bus.request(a, F("080#"), Time(0));
  run(bus);
  // bits 0..51 (63.75 µs), 51..102 (127.5 µs).
  EXPECT_EQ(trace.lines, (std::vector<std::string>{"0 64 0 080#", "64 128 0 080#"}));
}

// A node's queue is FIFO: only its head contends, so a low identifier behind a high one waits
// (docs/can-bus.md "Transmit queues").
TEST(TimedBus, OnlyTheHeadOfAQueueContends) {
  TimedBus bus(1000000, Time(0));
  Trace trace(bus);
  const auto a = bus.add_node(8), b = bus.add_node(8);
  request_all(bus, {{a, "7FF#FFFFFFFFFFFFFFFF"}, {a, "000#"}, {b, "080#"}}, Time(0));
  run(bus);
  EXPECT_EQ(trace.lines, (std::vector<std::string>{"0 51 1 080#", "51 177 0 7FF#FFFFFFFFFFFFFFFF",
                                                   "177 230 0 000#"}));
}

TEST(TimedBus, AFramePastAFullQueueIsLost) {
  TimedBus bus(125000, Time(0));
  const auto a = bus.add_node(2);
  EXPECT_TRUE(bus.request(a, F("001#"), Time(0)));
  EXPECT_TRUE(bus.request(a, F("002#"), Time(0)));
  EXPECT_FALSE(bus.request(a, F("003#"), Time(0)));
  EXPECT_EQ(bus.lost(), 1u);
  EXPECT_EQ(bus.queued(a), 2u);
  bus.advance(Time(0));  // 001# on the bus: one place free again
  EXPECT_EQ(bus.queued(a), 1u);
  EXPECT_TRUE(bus.request(a, F("003#"), Time(0)));
  EXPECT_EQ(bus.lost(), 1u);
}

TEST(TimedBus, ARemovedNodeSendsNothingMore) {
  TimedBus bus(125000, Time(0));
  Trace trace(bus);
  const auto a = bus.add_node(8), b = bus.add_node(8);
  request_all(bus, {{a, "001#"}, {a, "002#"}, {b, "003#"}}, Time(0));
  bus.advance(Time(0));  // 001# on the bus
  bus.remove_node(a);
  EXPECT_FALSE(bus.request(a, F("004#"), Time(0)));
  run(bus);
  ASSERT_EQ(trace.lines.size(), 2u);  // 001# ends, 002# never starts
  EXPECT_EQ(trace.lines[1].substr(trace.lines[1].size() - 4), "003#");
}

// docs/can-bus.md "In the plant": a bus advanced in steps reads a second as complete only once it
// has been advanced through it. 400 frames of 080# (51 bits) requested at 0.99 s at 1 Mbit/s go
// back to back to 1.0104 s: second 0 holds 10 000 of their bits, 1.0 %.
TEST(TimedBus, ASecondNotAdvancedThroughIsNotComplete) {
  TimedBus bus(1000000, Time(0));
  const auto a = bus.add_node(4096);
  for (int k = 0; k < 400; ++k) bus.request(a, F("080#"), Time(990'000));
  bus.advance(Time(995'000));
  // Read at 1.005 s: half of second 0's frames have started, the rest wait for the advance.
  EXPECT_DOUBLE_EQ(bus.load(Time(1'005'000)).last_pct, 0.0);
  EXPECT_DOUBLE_EQ(bus.load(Time(1'005'000)).max_pct, 0.0);
  bus.advance(Time(1'005'000));
  EXPECT_DOUBLE_EQ(bus.load(Time(1'005'000)).last_pct, 1.0);
  EXPECT_DOUBLE_EQ(bus.load(Time(1'005'000)).max_pct, 1.0);
}

// 080# (51 bits) every millisecond at 1 Mbit/s: 51 000 bits a second, 5.1 %; period 1 ms, no
// jitter, no latency.
TEST(TimedBus, LoadPeriodAndJitter) {
  TimedBus bus(1000000, Time(0));
  const auto a = bus.add_node(8);
  for (int k = 0; k < 2000; ++k) {
    bus.advance(Time(k * 1000));
    bus.request(a, F("080#"), Time(k * 1000));
    bus.advance(Time(k * 1000));
  }
  EXPECT_DOUBLE_EQ(bus.load(Time(1'999'000)).last_pct, 5.1);  // second 0 complete
  EXPECT_DOUBLE_EQ(bus.load(Time(2'000'000)).last_pct, 5.1);  // second 1 complete
  EXPECT_DOUBLE_EQ(bus.load(Time(3'000'000)).last_pct, 0.0);  // an idle second
  EXPECT_DOUBLE_EQ(bus.load(Time(3'000'000)).max_pct, 5.1);
  // identifiers() is a snapshot: taken again after more frames.
  auto s = bus.identifiers().begin()->second;
  EXPECT_EQ(s.frames, 2000u);
  EXPECT_EQ(s.period_mean(), Duration(1000));
  EXPECT_EQ(s.jitter(), Duration(0));
  EXPECT_EQ(s.latency_max, Duration(0));
  // One late request: its period is 1.5 ms, the next 0.5 ms; jitter 1 ms.
  bus.advance(Time(2'000'500));
  bus.request(a, F("080#"), Time(2'000'500));
  bus.advance(Time(2'001'000));
  bus.request(a, F("080#"), Time(2'001'000));
  bus.advance(Time(2'001'000));
  s = bus.identifiers().begin()->second;
  EXPECT_EQ(s.frames, 2002u);
  EXPECT_EQ(s.period_last, Duration(500));
  EXPECT_EQ(s.period_max, Duration(1500));
  EXPECT_EQ(s.jitter(), Duration(1000));
}

// Overload: the lower-priority identifier waits longer every period.
TEST(TimedBus, OverloadGrowsLatency) {
  TimedBus bus(125000, Time(0));
  const auto a = bus.add_node(64), b = bus.add_node(64);
  // Every 1 ms a 112-bit (896 µs) frame from each node: 1.79 ms of bus time a millisecond.
  for (int k = 0; k < 10; ++k) {
    bus.advance(Time(k * 1000));
    bus.request(a, F("100#1122334455667788"), Time(k * 1000));
    bus.request(b, F("200#1122334455667788"), Time(k * 1000));
    bus.advance(Time(k * 1000));
  }
  run(bus);
  const auto low = bus.identifiers().at(arbitration_key(F("200#")));
  const auto high = bus.identifiers().at(arbitration_key(F("100#")));
  EXPECT_GT(low.latency_last, low.latency_mean());
  EXPECT_GT(low.latency_max, Duration(5000));
  EXPECT_LT(high.latency_max, low.latency_max);
}

// docs/can-bus.md "Performance": the owner is told once that the deadline may have moved, until
// it asks next_deadline() again; what it then asks is the deadline after every request.
TEST(TimedBus, OwnerToldOnceUntilItAsksAgain) {
  TimedBus bus(125000, Time(0));
  const auto a = bus.add_node(8), b = bus.add_node(8), c = bus.add_node(8);
  int told = 0;
  bus.on_moved([&told] { ++told; });
  request_all(bus, {{a, "123#11"}, {a, "124#22"}, {b, "080#"}}, Time(100));
  EXPECT_EQ(told, 1);  // three requests to an idle bus, nobody asked in between
  EXPECT_EQ(bus.next_deadline(), Time(104));  // requested at 100: the first whole bit, 13
  ASSERT_TRUE(bus.request(c, F("000#"), Time(50)));
  EXPECT_EQ(told, 2);                        // asked since: told again
  EXPECT_EQ(bus.next_deadline(), Time(56));  // 000# requested at 50: its first bit at 56 µs
  bus.advance(Time(56));                     // 000# starts; the advance moves the deadline
  EXPECT_EQ(told, 3);
  EXPECT_EQ(bus.next_deadline(), Time(56 + 53 * 8));
  ASSERT_TRUE(bus.request(a, F("125#33"), Time(60)));  // while a frame is on the bus: not moved
  EXPECT_EQ(told, 3);
}

// docs/can-bus.md "Round 6": at a rate whose bit is not a whole number of microseconds (666.6k:
// 1.50015 µs) a frame requested within the microsecond of the start bit contends there: 000#
// ends at bit 53, 79.5 µs, stamped 80 µs; 001# requested at 80 µs (its own first whole bit 54)
// still wins the idle at bit 53 against 7FF#, queued since 0.
TEST(TimedBus, RequestWithinTheMicrosecondOfTheStartBitContends) {
  TimedBus bus(666600, Time(0));
  Trace trace(bus);
  const auto a = bus.add_node(8), b = bus.add_node(8);
  request_all(bus, {{a, "000#"}, {a, "7FF#"}}, Time(0));
  bus.advance(Time(0));
  EXPECT_EQ(bus.next_deadline(), Time(80));
  EXPECT_EQ(bus.bit_at(Time(80)), 54u);
  ASSERT_TRUE(bus.request(b, F("001#"), Time(80)));
  run(bus);
  ASSERT_EQ(trace.lines.size(), 3u);
  EXPECT_EQ(trace.lines[1].substr(0, 3), "80 ");
  EXPECT_EQ(trace.lines[1].substr(trace.lines[1].size() - 6), "1 001#");
  EXPECT_EQ(trace.lines[2].substr(trace.lines[2].size() - 6), "0 7FF#");
}

// docs/can-bus.md "Round 7": an identifier's counts are found through its node's guess (the entry
// that followed the node's last frame the last time) and, when the guess fails, through the index.
// A node that changes its order, two nodes sending one identifier, 29-bit and remote frames: the
// counts equal those kept from the starts of frame by a plain map.
TEST(TimedBus, IdentifierCountsFollowANodeThatChangesItsOrder) {
  TimedBus bus(500000, Time(0));
  const auto a = bus.add_node(16), b = bus.add_node(16);
  std::map<std::uint32_t, TimedBus::IdStatistics> expected;
  bus.on_start([&expected](const TimedBus::OnBus& f) {
    TimedBus::IdStatistics& s = expected[arbitration_key(f.frame)];
    s.id = ident_of(f.frame);
    s.remote = f.frame.remote;
    if (s.frames > 0) {
      const Duration period = f.start - s.last_start;
      s.period_last = period;
      s.period_min = s.frames == 1 ? period : std::min(s.period_min, period);
      s.period_max = std::max(s.period_max, period);
      s.period_sum += period;
    }
    s.latency_last = f.start - f.requested;
    s.latency_max = std::max(s.latency_max, s.latency_last);
    s.latency_sum += s.latency_last;
    s.last_start = f.start;
    ++s.frames;
  });
  const std::vector<std::vector<const char*>> orders = {
      {"101#01", "102#0203", "12345678#04", "103#R"},
      {"103#R", "101#05", "12345678#06", "102#0708"},
      {"102#09", "101#0A"},
  };
  for (int k = 0; k < 12; ++k) {
    const Time at(k * 5000);
    bus.advance(at);
    for (const char* text : orders[static_cast<std::size_t>(k / 4 % 3)])
      ASSERT_TRUE(bus.request(a, F(text), at));
    if (k % 2) {
      ASSERT_TRUE(bus.request(b, F("102#FF"), at + Duration(30)));
    }
    run(bus);
  }
  const auto got = bus.identifiers();
  ASSERT_EQ(got.size(), expected.size());
  ASSERT_EQ(got.size(), 4u);
  for (const auto& [key, e] : expected) {
    SCOPED_TRACE(key);
    const TimedBus::IdStatistics& s = got.at(key);
    EXPECT_EQ(s.id, e.id);
    EXPECT_EQ(s.remote, e.remote);
    EXPECT_EQ(s.frames, e.frames);
    EXPECT_EQ(s.last_start, e.last_start);
    EXPECT_EQ(s.period_last, e.period_last);
    EXPECT_EQ(s.period_min, e.period_min);
    EXPECT_EQ(s.period_max, e.period_max);
    EXPECT_EQ(s.period_sum, e.period_sum);
    EXPECT_EQ(s.latency_last, e.latency_last);
    EXPECT_EQ(s.latency_max, e.latency_max);
    EXPECT_EQ(s.latency_sum, e.latency_sum);
  }
  EXPECT_TRUE(got.at(arbitration_key(F("12345678#"))).id.extended);
  EXPECT_TRUE(got.at(arbitration_key(F("103#R"))).remote);
}

// docs/can-bus.md "Seen from outside": a period or latency is kept to 2^32 − 1 µs (71 min 35 s);
// a longer one reads as that, and the means stay exact.
TEST(TimedBus, PeriodsBeyondSeventyOneMinutesReadAsTheirLimit) {
  TimedBus bus(1000000, Time(0));
  const auto a = bus.add_node(4);
  const Duration two_hours = std::chrono::hours(2);
  for (const Time at : {Time(0), Time(0) + two_hours, Time(0) + two_hours + Duration(1000)}) {
    bus.advance(at);
    ASSERT_TRUE(bus.request(a, F("080#"), at));
    run(bus);
  }
  const auto s = bus.identifiers().at(arbitration_key(F("080#")));
  constexpr Duration kLimit(0xFFFFFFFFll);
  EXPECT_EQ(s.frames, 3u);
  EXPECT_EQ(s.period_max, kLimit);
  EXPECT_EQ(s.period_min, Duration(1000));
  EXPECT_EQ(s.period_last, Duration(1000));
  EXPECT_EQ(s.period_mean(), (two_hours + Duration(1000)) / 2);
}

}  // namespace
}  // namespace candp2::can

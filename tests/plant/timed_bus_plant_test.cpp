// A bus in time in the plant (docs/can-bus.md "In the plant"): the plant's next wake-up is each
// frame's start and end, so virtual time reaches every frame to the microsecond; with a step
// (candp2d) the wake-ups are at least the step apart and the frames' times stay the same.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <variant>
#include <vector>

#include "can/frame_bits.hpp"
#include "config/config.hpp"
#include "plant/plant.hpp"

namespace candp2 {
namespace {

// gw3's release on a 125 kbit/s bus: 201#0000 then 202#0000 from its one queue.
constexpr const char* kConfig = R"({
  "master": { "address": 1, "cycle_ms": 10 },
  "buses": { "can0": { "type": "virtual", "bitrate": "125k" } },
  "gateways": [ { "name": "gw3", "address": 3, "bus": "can0",
                  "parameters": { "can_bitrate": "125k" },
                  "slots": [ { "io": "output", "address": 0, "length": 2, "comment": "02,01,00" },
                             { "io": "output", "address": 2, "length": 2, "comment": "02,02,00" } ] } ]
})";

struct Frames : plant::Tap {
  std::vector<std::pair<Time, std::string>> seen;
  void on_can(const plant::CanRecord& r) override {
    seen.emplace_back(r.time, can::format_candump(r.frame));
  }
};

struct Recording {
  Frames frames;
  std::vector<Time> wakeups;
};

Recording record(Duration step) {
  auto parsed = config::parse_daemon(kConfig, "bus.json");
  const auto cfg = std::get<config::DaemonConfig>(parsed);
  plant::Options o;
  o.step = step;
  std::string error;
  auto p = plant::Plant::build(cfg, std::move(o), Time{0}, &error);
  // A second node acknowledges gw3's frames (alone, each would be an ACK error: docs/can-bus.md
  // "Error confinement").
  const auto listener = p->buses().at(0)->virtual_bus()->endpoint("listener");
  Recording r;
  p->add_tap(&r.frames);
  while (const auto next = p->next_deadline()) {
    if (*next > Time{100'000}) break;
    r.wakeups.push_back(*next);
    p->advance(*next);
  }
  p->remove_tap(&r.frames);
  return r;
}

TEST(TimedBusInThePlant, TheWakeUpsAreTheFramesStartsAndEnds) {
  const Recording r = record(Duration{0});
  ASSERT_GE(r.frames.seen.size(), 2u);
  const Time release = r.frames.seen[0].first;
  EXPECT_EQ(r.frames.seen[0].second, "201#0000");
  EXPECT_EQ(r.frames.seen[1].second, "202#0000");
  const auto bits = can::frame_bits_exact(*can::parse_candump("201#0000").frame);
  EXPECT_EQ(r.frames.seen[1].first, release + Duration(bits * 8));  // 8 µs a bit, back to back
  // The plant woke at the first frame's end (where the second starts) and at the second's end.
  const auto end2 = r.frames.seen[1].first +
                    Duration(can::frame_bits_exact(*can::parse_candump("202#0000").frame) * 8);
  EXPECT_NE(std::find(r.wakeups.begin(), r.wakeups.end(), r.frames.seen[1].first), r.wakeups.end());
  EXPECT_NE(std::find(r.wakeups.begin(), r.wakeups.end(), end2), r.wakeups.end());
}

TEST(TimedBusInThePlant, WithAStepTheFramesKeepTheirTimes) {
  const Recording exact = record(Duration{0});
  const Recording stepped = record(milliseconds(1));
  EXPECT_EQ(stepped.frames.seen, exact.frames.seen);
  // No wake-up for the second frame's start: it came with the step after the release.
  EXPECT_EQ(
      std::find(stepped.wakeups.begin(), stepped.wakeups.end(), exact.frames.seen.at(1).first),
      stepped.wakeups.end());
}

// docs/can-bus.md "Performance": on a bus in time a gateway is given its controller state again
// only when something but the frames changed, or when its IRQ_LOST total moved. Frames dropped on
// cue (docs/faults.md) still reach IRQ_LOST at the frame that was dropped.
TEST(TimedBusInThePlant, FramesDroppedOnCueReachIrqLost) {
  auto parsed = config::parse_daemon(R"({
    "master": { "address": 1, "cycle_ms": 10 },
    "buses": { "can0": { "type": "virtual", "bitrate": "125k" } },
    "gateways": [ { "name": "gw3", "address": 3, "bus": "can0",
                    "parameters": { "can_bitrate": "125k" },
                    "slots": [ { "io": "input", "address": 0, "length": 2,
                                 "comment": "02,89,B8" } ] } ]
  })",
                                     "bus.json");
  const auto cfg = std::get<config::DaemonConfig>(parsed);
  std::string error;
  auto p = plant::Plant::build(cfg, plant::Options{}, Time{0}, &error);
  ASSERT_TRUE(p) << error;
  const auto peer = p->buses().at(0)->virtual_bus()->endpoint("peer");
  auto run_to = [&](Time end) {
    while (const auto next = p->next_deadline()) {
      if (*next > end) break;
      p->advance(*next);
    }
    p->advance(end);
  };
  run_to(Time{200'000});
  plant::GatewayUnit& gw = *p->gateway("gw3");
  const auto rx_before = gw.gateway().status().rx_frames;
  p->drop_rx(gw, 2, p->now(), "(test)");
  for (int i = 0; i < 3; ++i) peer->send(*can::parse_candump("289#1122").frame);
  run_to(p->now() + milliseconds(5));
  const auto status = gw.gateway().status();
  EXPECT_EQ(status.irq_lost, 2u);
  EXPECT_EQ(status.rx_frames, rx_before + 1);  // the third frame got through
}

}  // namespace
}  // namespace candp2

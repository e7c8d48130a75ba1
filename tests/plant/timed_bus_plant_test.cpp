// A bus in time in the plant (docs/can-bus.md "In the plant"): the plant's next wake-up is each
// frame's start and end, so virtual time reaches every frame to the microsecond; with a step
// (candp2d) the wake-ups are at least the step apart and the frames' times stay the same.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "can/frame_bits.hpp"
#include "config/config.hpp"
#include "plant/plant.hpp"
#include "tests/virtual_time_plant.hpp"

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

// docs/can-bus.md "In the plant": two layer-2 gateways, each's Tx identifiers the other's Rx, a
// writer changing every output 2 ms after each cycle, while the cycle's frames are still on the
// bus (about 5 ms of them at 125 kbit/s). candp2d's steps (1 ms, and
// 10 ms for buses that only fill images) against replay's wake at every frame: the same frames at
// the same times, the same master input image at every cycle, the same statistics; and the
// plant woke only for the cycles and the writes.
// gw3 and gw4 on a 125 kbit/s bus with `tx3` and `tx4` 8-byte Tx slots (0x301.., 0x401..), each
// reading the other's first and last identifier.
std::string image_buses(int tx3, int tx4) {
  auto gateway = [](int address, int tx, int peer, int peer_tx, int base) {
    std::string slots;
    auto slot = [&](const char* io, int at, int id) {
      char text[120];
      std::snprintf(text, sizeof text,
                    R"(%s{ "io": "%s", "address": %d, "length": 8, "comment": "%02X,%02X,00" })",
                    slots.empty() ? "" : ", ", io, at, id >> 8, id & 0xFF);
      slots += text;
    };
    for (int k = 0; k < tx; ++k) slot("output", base + 8 * k, address * 0x100 + 1 + k);
    slot("input", base, peer * 0x100 + 1);
    slot("input", base + 8, peer * 0x100 + peer_tx);
    return R"({ "name": "gw)" + std::to_string(address) + R"(", "address": )" +
           std::to_string(address) +
           R"(, "bus": "can0", "parameters": { "can_bitrate": "125k" }, "slots": [ )" + slots +
           " ] }";
  };
  return R"({ "master": { "address": 1, "cycle_ms": 10 },
              "buses": { "can0": { "type": "virtual", "bitrate": "125k" } },
              "gateways": [ )" +
         gateway(3, tx3, 4, tx4, 0) + ", " + gateway(4, tx4, 3, tx3, 64) + " ] }";
}

struct ImageRun {
  Frames frames;
  std::vector<std::vector<std::uint8_t>> inputs;  // the master's inputs after each cycle
  std::vector<Time> wakeups, cycles, writes;
  std::vector<std::string> identifiers;  // the bus's statistics per identifier
  std::uint64_t rx_frames = 0;
  std::optional<Time> after_fault;  // the plant's next deadline once the fault was set
};

// `fault_at`: a CAN fault on cue (error frames on 402, once) set at that write.
// `config`: image_buses(3, 2) by default, five frames a cycle.
// `listener`: a third endpoint on the bus (as a socketcand export is).
ImageRun run_images(Duration step, Duration image_step, int fault_at = -1,
                    const std::string& config = image_buses(3, 2), bool listener = false) {
  const auto cfg = std::get<config::DaemonConfig>(config::parse_daemon(config, "img.json"));
  plant::Options o;
  o.step = step;
  o.image_bus_step = image_step;
  o.first_cycle_at_start = true;
  std::string error;
  auto p = plant::Plant::build(cfg, std::move(o), Time{0}, &error);
  EXPECT_TRUE(p) << error;
  ImageRun r;
  const auto watcher = listener ? p->buses().at(0)->virtual_bus()->endpoint("listener") : nullptr;
  p->add_tap(&r.frames);
  p->on_cycle([&](Time now) {
    r.cycles.push_back(now);
    // The hook runs in the cycle: the inputs it read are the image now.
    const auto& in = p->master().image().inputs;
    r.inputs.emplace_back(in.begin(), in.end());
  });
  auto& q = p->master().image().outputs;
  for (int k = 0; k < 300; ++k) {  // 3 s: the release, then 2.5 s of changing outputs
    const Time at = milliseconds(10) * k + milliseconds(2);
    test::run_until(*p, at, &r.wakeups);
    r.writes.push_back(at);
    for (std::size_t i = 0; i < q.size(); ++i) q[i] = static_cast<std::uint8_t>(k * 7 + i);
    if (k == fault_at) {
      plant::CanFault f;
      f.kind = plant::CanFaultKind::ErrorFrames;
      f.bus = "can0";
      f.id = can::Ident{0x402, false};
      p->can_fault(f, at, "(test)");
      r.after_fault = p->next_deadline();
    }
  }
  test::run_until(*p, seconds(3), &r.wakeups);
  p->remove_tap(&r.frames);
  for (const auto& [key, s] : p->buses().at(0)->virtual_bus()->timed()->identifiers())
    r.identifiers.push_back(std::to_string(s.id.id) + " " + std::to_string(s.frames) + " " +
                            std::to_string(s.latency_max.count()) + " " +
                            std::to_string(s.latency_mean().count()));
  for (auto& g : p->gateways()) r.rx_frames += g->gateway().status().rx_frames;
  return r;
}

TEST(TimedBusInThePlant, BusesThatOnlyFillImagesWaitForThePlantsWakes) {
  const ImageRun exact = run_images(Duration{0}, Duration{0});
  const ImageRun lazy = run_images(milliseconds(1), milliseconds(10));
  ASSERT_GT(exact.frames.seen.size(), 1000u);  // 5 frames a cycle once released
  EXPECT_EQ(lazy.frames.seen, exact.frames.seen);
  ASSERT_EQ(lazy.inputs.size(), exact.inputs.size());
  // The frames reached the gateways' inputs before the master's cycle read them, as in replay.
  for (std::size_t c = 0; c < exact.inputs.size(); ++c)
    ASSERT_EQ(lazy.inputs[c], exact.inputs[c]) << "cycle " << c;
  EXPECT_NE(exact.inputs.back(), exact.inputs.front());  // the writer's bytes went round
  EXPECT_EQ(lazy.identifiers, exact.identifiers);
  EXPECT_EQ(lazy.rx_frames, exact.rx_frames);
  // Woken for nothing but the cycles and the writes (and the gateways' power-on timers).
  std::size_t other = 0;
  for (const Time t : lazy.wakeups)
    if (std::find(lazy.cycles.begin(), lazy.cycles.end(), t) == lazy.cycles.end() &&
        std::find(lazy.writes.begin(), lazy.writes.end(), t) == lazy.writes.end())
      ++other;
  EXPECT_LE(other, 10u);
  // With the 1 ms step alone the plant wakes for the buses between them.
  const ImageRun stepped = run_images(milliseconds(1), Duration{0});
  EXPECT_EQ(stepped.frames.seen, exact.frames.seen);
  EXPECT_GT(stepped.wakeups.size(), lazy.wakeups.size() + 500);
  // A third endpoint on the bus may show or answer a frame: the bus steps at 1 ms.
  const ImageRun watched =
      run_images(milliseconds(1), milliseconds(10), -1, image_buses(3, 2), true);
  EXPECT_EQ(watched.frames.seen, exact.frames.seen);
  EXPECT_GT(watched.wakeups.size(), lazy.wakeups.size() + 500);
}

// On an overloaded bus (12 frames of 8 bytes a cycle, about 1500 bits in 1250: always busy)
// frames end at a cycle's own time too: there the cycle reads the images first, as replay orders
// them.
TEST(TimedBusInThePlant, OnAnOverloadedBusTheImagesAreReplays) {
  const ImageRun exact = run_images(Duration{0}, Duration{0}, -1, image_buses(6, 6));
  const ImageRun lazy = run_images(milliseconds(1), milliseconds(10), -1, image_buses(6, 6));
  std::size_t at_cycles = 0;  // frames that ended at a cycle's time
  for (std::size_t i = 1; i < exact.frames.seen.size(); ++i)
    if (std::find(exact.cycles.begin(), exact.cycles.end(), exact.frames.seen[i].first) !=
        exact.cycles.end())
      ++at_cycles;
  EXPECT_GT(at_cycles, 0u);
  EXPECT_EQ(lazy.frames.seen, exact.frames.seen);
  ASSERT_EQ(lazy.inputs.size(), exact.inputs.size());
  for (std::size_t c = 0; c < exact.inputs.size(); ++c)
    ASSERT_EQ(lazy.inputs[c], exact.inputs[c]) << "cycle " << c;
  EXPECT_EQ(lazy.identifiers, exact.identifiers);
}

TEST(TimedBusInThePlant, ACanFaultMakesTheBusesStepAgain) {
  // From the fault on, the bus steps every 1 ms while it has frames: at once (the cycle's frames
  // are still on the bus), and between the write that set it, the next cycle and the write
  // after.
  auto between = [](const ImageRun& r, Time from) {
    std::size_t n = 0;
    for (const Time t : r.wakeups)
      if (t > from && t < from + milliseconds(10) &&
          std::find(r.cycles.begin(), r.cycles.end(), t) == r.cycles.end())
        ++n;
    return n;
  };
  const ImageRun r = run_images(milliseconds(1), milliseconds(10), 150);
  const ImageRun quiet = run_images(milliseconds(1), milliseconds(10));
  ASSERT_TRUE(r.after_fault);
  EXPECT_LE(*r.after_fault, r.writes.at(150) + milliseconds(1));
  EXPECT_GE(between(r, r.writes.at(150)), 3u);
  EXPECT_EQ(between(quiet, quiet.writes.at(150)), 0u);
  // The fault spoiled 402's next frame once, then the bus went back to waiting for the wakes.
  EXPECT_EQ(between(r, r.writes.at(200)), 0u);
}

}  // namespace
}  // namespace candp2

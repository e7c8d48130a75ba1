// The master cycle's accounting in the plant (docs/daemon.md "Cycle timing"): a cycle run late
// records its lateness against its own grid point, overrun included; grid points that passed
// meanwhile are missed and counted; a run of misses is logged when it starts and when it ends.
#include <gtest/gtest.h>

#include <variant>

#include "config/config.hpp"
#include "plant/plant.hpp"

namespace candp2 {
namespace {

constexpr const char* kConfig = R"({
  "master": { "address": 1, "cycle_ms": 10 },
  "buses": { "can0": { "type": "virtual" } },
  "gateways": [ { "name": "gw3", "address": 3, "bus": "can0",
                  "parameters": { "can_bitrate": "500k" },
                  "slots": [ { "io": "output", "address": 0, "length": 2, "comment": "02,01,00" } ] } ]
})";

struct Fixture : ::testing::Test {
  void SetUp() override {
    auto parsed = config::parse_daemon(kConfig, "cycle.json");
    ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(parsed));
    cfg = std::get<config::DaemonConfig>(parsed);
    std::string error;
    plant::Options o;
    o.log = &log;
    plant = plant::Plant::build(cfg, std::move(o), Time{0}, &error);
    ASSERT_TRUE(plant) << error;
  }
  // Runs the plant the way the daemon's timer does: at each deadline, or late at `at`.
  void run_until(Time end) {
    while (const auto next = plant->next_deadline()) {
      if (*next > end) break;
      plant->advance(*next);
    }
  }
  std::size_t lines_with(std::string_view text) const {
    std::size_t n = 0;
    for (const auto& l : log.lines) n += l.message.find(text) != std::string::npos;
    return n;
  }
  config::DaemonConfig cfg;
  MemoryLog log;
  std::unique_ptr<plant::Plant> plant;
};

TEST_F(Fixture, PunctualCyclesMissNothing) {
  run_until(Time{1'000'000});
  const auto s = plant->cycle_stats().summary();
  EXPECT_EQ(s.cycles, 100u);  // grid points 10 ms .. 1000 ms
  EXPECT_EQ(s.missed, 0u);
  EXPECT_EQ(s.max_us, 0u);
  EXPECT_EQ(lines_with("missed"), 0u);
}

TEST_F(Fixture, AnOverrunCountsAsLatenessAndMissedGridPoints) {
  run_until(Time{100'000});  // cycles at 10 .. 100 ms
  // The loop was busy: the cycle due at 110 ms runs at 147 ms. It is 37 ms late; the grid points
  // 120, 130 and 140 ms passed without a cycle; the next one is due at 150 ms.
  plant->advance(Time{147'000});
  auto s = plant->cycle_stats().summary();
  EXPECT_EQ(s.cycles, 11u);
  EXPECT_EQ(s.missed, 3u);
  EXPECT_EQ(s.max_us, 37'000u);
  EXPECT_EQ(plant->next_cycle(), Time{150'000});
  EXPECT_EQ(lines_with("3 cycle(s) missed, started 37.0 ms late"), 1u);
  // Another miss within the run: no new line.
  run_until(Time{300'000});
  plant->advance(Time{325'000});  // due 310 ms: 15 ms late, 320 missed
  EXPECT_EQ(plant->cycle_stats().missed(), 4u);
  EXPECT_EQ(lines_with("cycle(s) missed, started"), 1u);
  // A second on the grid ends the run with its count.
  run_until(Time{1'320'000});
  EXPECT_EQ(lines_with("back on its grid"), 0u);
  run_until(Time{1'400'000});
  EXPECT_EQ(lines_with("back on its grid: 4 cycle(s) missed within 178.0 ms (4 since start)"), 1u)
      << (log.lines.empty() ? "" : log.lines.back().message);
  s = plant->cycle_stats().summary();
  EXPECT_EQ(s.cycles + s.missed, 140u);  // every grid point 10 ms .. 1400 ms, run or missed
}

TEST_F(Fixture, TheGridStartsWithTheFirstCycle) {
  // The driver's first turn comes 35 ms after the plant was built (candp2d opening its
  // listeners): no miss, and the grid runs from there.
  plant->advance(Time{35'000});
  EXPECT_EQ(plant->cycle_stats().missed(), 0u);
  EXPECT_EQ(plant->cycle_stats().summary().max_us, 0u);
  EXPECT_EQ(plant->next_cycle(), Time{45'000});
}

TEST_F(Fixture, OnePeriodLateIsOneMiss) {
  run_until(Time{100'000});
  plant->advance(Time{120'000});  // due 110 ms, run at 120 ms: 120 ms is missed
  EXPECT_EQ(plant->cycle_stats().missed(), 1u);
  EXPECT_EQ(plant->next_cycle(), Time{130'000});
  plant->advance(Time{139'999});  // due 130 ms, 9.999 ms late: no miss
  EXPECT_EQ(plant->cycle_stats().missed(), 1u);
}

}  // namespace
}  // namespace candp2

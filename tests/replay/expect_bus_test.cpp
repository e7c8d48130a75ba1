// Replay's expect_bus (docs/replay-format.md "The CAN bus in time"): the figures of a CAN bus in
// time and of one identifier, checked against ranges; a failed step says what was measured; a
// step on an ideal bus, or an identifier's figure without "id", is refused with its JSON path.
// And can_fault's for_ms on a node's unplugged or wrong_bitrate (docs/replay-format.md).
#include <gtest/gtest.h>

#include <string>
#include <variant>

#include "replay/runner.hpp"
#include "replay/scenario.hpp"

namespace candp2::replay {
namespace {

// A version-2 scenario on one of the repository's configurations.
config::Result<Scenario> parse(const std::string& config, const std::string& steps) {
  const std::string text = R"({"format": "candp2-replay", "version": 2, "name": "bus",
      "config": ")" + std::string(CANDP2_SOURCE_DIR) +
                           "/config/" + config + R"(", "steps": [)" + steps + "]}";
  return parse_scenario(text, "bus.json");
}

config::ConfigError error(const std::string& config, const std::string& steps) {
  auto r = parse(config, steps);
  EXPECT_TRUE(std::holds_alternative<config::ConfigError>(r));
  return std::holds_alternative<config::ConfigError>(r) ? std::get<config::ConfigError>(r)
                                                        : config::ConfigError{};
}

RunResult run_steps(const std::string& config, const std::string& steps) {
  auto r = parse(config, steps);
  if (auto* e = std::get_if<config::ConfigError>(&r)) {
    ADD_FAILURE() << e->to_string();
    return {};
  }
  static Scenario sc;  // the results point into its steps
  sc = std::get<Scenario>(std::move(r));
  return run(sc);
}

// config/timed-bus-125k.json: twelve 8-byte frames every 10 ms at 125 kbit/s, more than the bus
// carries (docs/can-bus.md "In the plant"); the lower-priority gateway "even" loses 129 frames in
// the first two seconds (config/scenarios/timed-bus-overload.json).
constexpr const char* kOverload = "timed-bus-125k.json";

TEST(ExpectBus, TheBusFiguresOfAnOverloadedBus) {
  const RunResult r = run_steps(kOverload, R"({"advance_ms": 2100},
      {"expect_bus": {"tx_lost": 129, "load_pct": {"min": 99, "max": 100},
                      "load_max_pct": {"min": 99}, "frames_on_bus": {"min": 2000}}},
      {"expect_bus": {"bus": "can0", "id": "0x101", "frames": {"min": 150},
                      "latency_max_ms": {"max": 2.1}}},
      {"expect_bus": {"id": "0x10C", "latency_max_ms": {"min": 100}}})");
  // 0x101, the highest priority, waits at most for the frame on the bus and for its own
  // gateway's last frame of the cycle before, ahead of it in the gateway's FIFO: two 8-byte
  // frames of about 1 ms each at 125 kbit/s.
  ASSERT_EQ(r.steps.size(), 4u);
  for (const auto& s : r.steps) EXPECT_TRUE(s.passed) << s.index << ": " << s.detail;
}

TEST(ExpectBus, AFailedStepSaysWhatWasMeasured) {
  const RunResult r = run_steps(kOverload, R"({"advance_ms": 2100},
      {"expect_bus": {"tx_lost": 0, "load_pct": {"max": 50}}},
      {"expect_bus": {"id": 768, "frames": 0, "latency_max_ms": {"max": 1}}})");
  ASSERT_EQ(r.steps.size(), 3u);
  EXPECT_FALSE(r.steps[1].passed);
  // In the table's order (replay/bus_figures.cpp), whatever the step's.
  EXPECT_EQ(r.steps[1].detail, "got load_pct 100, tx_lost 129");
  // 0x300 never went on the bus: its frames are 0, its latency has no value.
  EXPECT_FALSE(r.steps[2].passed);
  EXPECT_EQ(r.steps[2].detail, "got frames 0, latency_max_ms none (no frame of 300 yet)");
}

// docs/replay-format.md "The CAN bus in time": the bus's error frames and a node's counters
// (config/timed-bus-alone.json: a gateway nobody acknowledges, error passive at TEC 128 after 16
// ACK errors); a node not on the bus is no value.
TEST(ExpectBus, ErrorFramesAndANodesCounters) {
  const RunResult r = run_steps("timed-bus-alone.json", R"({"advance_ms": 1000},
      {"expect_bus": {"node": "gw:alone", "tec": 128, "rec": 0, "error_frames": {"min": 16}}},
      {"expect_bus": {"node": "gw:alone", "tec": 127, "error_frames": 0}},
      {"expect_bus": {"node": "gw:nobody", "tec": 0}})");
  ASSERT_EQ(r.steps.size(), 4u);
  EXPECT_TRUE(r.steps[1].passed) << r.steps[1].detail;
  EXPECT_FALSE(r.steps[2].passed);
  EXPECT_EQ(r.steps[2].detail.rfind("got error_frames ", 0), 0u) << r.steps[2].detail;
  EXPECT_NE(r.steps[2].detail.find(", tec 128"), std::string::npos) << r.steps[2].detail;
  EXPECT_FALSE(r.steps[3].passed);
  EXPECT_EQ(r.steps[3].detail, "got tec none (no node gw:nobody on the bus)");
  const auto e = error("timed-bus-alone.json", R"({"expect_bus": {"tec": 0}})");
  EXPECT_EQ(e.json_path, "$.steps[0].expect_bus.tec");
  EXPECT_NE(e.message.find("give \"node\""), std::string::npos) << e.to_string();
}

// A node's confinement state by the words of GET /api/v1/status nodes[].state; a failed step
// says the word it measured, the report the word it wants; another word is refused with its path.
TEST(ExpectBus, ANodesStateByItsWord) {
  const RunResult r = run_steps("timed-bus-alone.json", R"({"advance_ms": 1000},
      {"expect_bus": {"node": "gw:alone", "state": "error-passive"}},
      {"expect_bus": {"node": "gw:alone", "state": "bus-off", "tec": 128}})");
  ASSERT_EQ(r.steps.size(), 3u);
  EXPECT_TRUE(r.steps[1].passed) << r.steps[1].detail;
  EXPECT_FALSE(r.steps[2].passed);
  EXPECT_EQ(r.steps[2].detail, "got tec 128, state error-passive");
  auto p = parse("timed-bus-alone.json", R"({"expect_bus": {"node": "gw:alone", "state": "ok"}})");
  ASSERT_TRUE(std::holds_alternative<Scenario>(p)) << std::get<config::ConfigError>(p).to_string();
  EXPECT_EQ(std::get<Scenario>(p).steps.at(0).describe_action(),
            "expect_bus can0 gw:alone state = ok");
  for (const char* bad : {R"("error_passive")", "2"}) {
    const auto e =
        error("timed-bus-alone.json",
              R"({"expect_bus": {"node": "gw:alone", "state": )" + std::string(bad) + "}}");
    EXPECT_EQ(e.json_path, "$.steps[0].expect_bus.state");
    EXPECT_NE(e.message.find(R"(expected one of "ok", "warning", "error-passive", "bus-off")"),
              std::string::npos)
        << e.to_string();
  }
}

// docs/replay-format.md "can_fault": unplugged with for_ms ends by itself. "odd" is "even"'s only
// acknowledger (the tester acknowledges nothing): out for 50 ms, even's frames are ACK errors
// (TEC to 128, error passive); after it they are acknowledged again and its TEC counts down.
TEST(CanFaultStep, UnpluggedForMsEndsByItself) {
  const RunResult r = run_steps(kOverload, R"({"advance_ms": 100},
      {"can_fault": {"gateway": 3, "kind": "unplugged", "for_ms": 50}},
      {"advance_ms": 49},
      {"expect_bus": {"node": "gw:even", "tec": 128, "state": "error-passive"}},
      {"expect_bus": {"node": "gw:even", "tec": {"max": 127}, "state": "warning"},
       "within_ms": 100})");
  // Its frames wait behind odd's, queued while odd was out (odd's identifiers win): the TEC
  // counts down a frame at a time once they get through.
  ASSERT_EQ(r.steps.size(), 5u);
  for (const auto& s : r.steps) EXPECT_TRUE(s.passed) << s.index << ": " << s.detail;
  auto p = parse(kOverload, R"({"can_fault": {"gateway": 3, "kind": "unplugged", "for_ms": 50}})");
  ASSERT_TRUE(std::holds_alternative<Scenario>(p)) << std::get<config::ConfigError>(p).to_string();
  EXPECT_EQ(std::get<Scenario>(p).steps.at(0).describe_action(),
            "can_fault unplugged gateway 3 for 50 ms");
}

TEST(CanFaultStep, ForMsOutOfRangeNamesItsPathAndRange) {
  for (const char* bad : {"-5", "86400001", "\"soon\""}) {
    const auto e = error(kOverload, R"({"can_fault": {"gateway": 3, "kind": "wrong_bitrate",
        "for_ms": )" + std::string(bad) +
                                        "}}");
    EXPECT_EQ(e.file, "bus.json");
    EXPECT_EQ(e.json_path, "$.steps[0].can_fault.for_ms");
    EXPECT_NE(e.message.find("from 0 to 86400000 ms"), std::string::npos) << e.to_string();
  }
  const auto none =
      error(kOverload, R"({"can_fault": {"gateway": 3, "kind": "none", "for_ms": 5}})");
  EXPECT_EQ(none.json_path, "$.steps[0].can_fault.for_ms");
}

// config/timed-bus-drive.json: the drive's request 0x201 goes on the bus once, after the write.
TEST(ExpectBus, APeriodNeedsTwoFrames) {
  const RunResult r = run_steps("timed-bus-drive.json", R"(
      {"expect_dp_state": "data_exch", "gateway": "plc", "within_ms": 100},
      {"write": {"address": 0, "bytes": "3D E2 00 00 00"}, "gateway": "plc"},
      {"advance_ms": 30},
      {"expect_bus": {"id": "0x201", "frames": 1, "latency_max_ms": {"min": 9},
                      "period_ms": {"max": 1000}}})");
  ASSERT_EQ(r.steps.size(), 4u);
  EXPECT_FALSE(r.steps[3].passed);
  EXPECT_EQ(r.steps[3].detail,
            "got frames 1, period_ms none (one frame of 201 so far: it needs two), latency_max_ms "
            "9.032");
}

TEST(ExpectBus, ItIsPolledOverItsWindow) {
  const RunResult r = run_steps(kOverload, R"({"expect_bus": {"frames_on_bus": {"min": 24}},
      "within_ms": 100})");
  ASSERT_EQ(r.steps.size(), 1u);
  EXPECT_TRUE(r.steps[0].passed) << r.steps[0].detail;
  EXPECT_GT(r.steps[0].end, r.steps[0].start);  // the frames came after the step began
}

TEST(ExpectBus, TheReportDescribesTheStep) {
  auto r = parse(kOverload, R"({"expect_bus": {"id": "0x10C", "latency_max_ms": {"max": 2.5},
      "load_pct": {"min": 40, "max": 60}, "tx_lost": 0}, "within_ms": 10})");
  ASSERT_TRUE(std::holds_alternative<Scenario>(r)) << std::get<config::ConfigError>(r).to_string();
  EXPECT_EQ(std::get<Scenario>(r).steps.at(0).describe_action(),
            "expect_bus can0 load_pct 40 .. 60, tx_lost = 0; 10C latency_max_ms ≤ 2.5 within "
            "10 ms");
}

TEST(ExpectBus, AnIdealBusIsRefused) {
  const auto e = error("two-gateways.json", R"({"expect_bus": {"bus": "can1", "tx_lost": 0}})");
  EXPECT_EQ(e.json_path, "$.steps[0].expect_bus.bus");
  EXPECT_NE(e.message.find("bus \"can1\" has no \"bitrate\""), std::string::npos) << e.to_string();
  const auto several = error("two-gateways.json", R"({"expect_bus": {"tx_lost": 0}})");
  EXPECT_EQ(several.json_path, "$.steps[0].expect_bus");
  EXPECT_NE(several.message.find("give \"bus\", one of \"can0\", \"can1\""), std::string::npos)
      << several.to_string();
}

TEST(ExpectBus, BadFiguresNameTheirPath) {
  auto e = error(kOverload, R"({"expect_bus": {"frames": 3}})");
  EXPECT_EQ(e.json_path, "$.steps[0].expect_bus.frames");
  EXPECT_NE(e.message.find("\"frames_on_bus\""), std::string::npos) << e.to_string();
  e = error(kOverload, R"({"expect_bus": {"load_pct": {"min": 60, "max": 40}}})");
  EXPECT_EQ(e.json_path, "$.steps[0].expect_bus.load_pct.min");
  e = error(kOverload, R"({"expect_bus": {"load_pct": "high"}})");
  EXPECT_EQ(e.json_path, "$.steps[0].expect_bus.load_pct");
  e = error(kOverload, R"({"expect_bus": {"id": "0x800", "frames": 1}})");
  EXPECT_EQ(e.json_path, "$.steps[0].expect_bus.id");
  e = error(kOverload, R"({"expect_bus": {"rtr": true, "tx_lost": 0}})");
  EXPECT_EQ(e.json_path, "$.steps[0].expect_bus.rtr");
  e = error(kOverload, R"({"expect_bus": {"bus": "can0"}})");
  EXPECT_EQ(e.json_path, "$.steps[0].expect_bus");
  EXPECT_NE(e.message.find("latency_max_ms"), std::string::npos) << e.to_string();
}

}  // namespace
}  // namespace candp2::replay

// Replay of a line of generic slaves alone (docs/replay-format.md "Version 2", docs/slaves.md
// "A line of generic slaves alone"): config/slaves-line.json has no gateway and no CAN bus; the
// image and slave steps run, a step that needs a gateway is refused with the scenario file, the
// step's JSON path and why.
#include <gtest/gtest.h>

#include "replay/report.hpp"
#include "replay/runner.hpp"
#include "replay/scenario.hpp"

namespace candp2::replay {
namespace {

// A scenario "file" beside the example scenarios: "config" resolves to config/slaves-line.json.
const std::string kFile = CANDP2_SOURCE_DIR "/config/scenarios/line-test.json";

config::Result<Scenario> parse(const std::string& steps, const std::string& extra = "") {
  const std::string text = R"({"format": "candp2-replay", "version": 2, "name": "line",
      "config": "../slaves-line.json", )" +
                           extra + R"("steps": [)" + steps + "]}";
  return parse_scenario(text, kFile);
}

config::ConfigError error(const std::string& steps, const std::string& extra = "") {
  auto r = parse(steps, extra);
  EXPECT_TRUE(std::holds_alternative<config::ConfigError>(r)) << steps;
  return std::holds_alternative<config::ConfigError>(r) ? std::get<config::ConfigError>(r)
                                                        : config::ConfigError{};
}

TEST(SlavesLineReplay, ImageAndSlaveStepsRunWithoutAGateway) {
  auto r = parse(R"({"expect_dp_state": "data_exch", "slave": "in1", "within_ms": 100},
      {"expect_dp_state": "data_exch", "slave": "in2", "within_ms": 100},
      {"write": {"address": 8, "bytes": "5A A5"}},
      {"expect_field": {"bytes": "5A A5"}, "slave": "in2", "within_ms": 30},
      {"field_write": {"bytes": "77"}, "slave": "in1"},
      {"expect_input": {"address": 0, "bytes": "77"}, "within_ms": 30},
      {"expect_output": {"address": 8, "bytes": "5A A5"}})");
  ASSERT_TRUE(std::holds_alternative<Scenario>(r)) << std::get<config::ConfigError>(r).to_string();
  const auto& sc = std::get<Scenario>(r);
  EXPECT_TRUE(sc.installation.gateways.empty());
  EXPECT_TRUE(sc.installation.buses.empty());
  const auto res = run(sc);
  EXPECT_TRUE(res.passed()) << format_report(sc, res);
  EXPECT_TRUE(res.traffic.empty());  // no CAN bus, no frame
}

TEST(SlavesLineReplay, AGatewayStepIsRefused) {
  for (const char* step :
       {R"({"expect_frame": "201#00", "within_ms": 10})", R"({"force_can_state": "bus-off"})",
        R"({"drop_rx": 2})", R"({"expect_counters": {"rx_frames": 0}})"}) {
    const auto e = error(R"({"note": "first"}, )" + std::string(step));
    EXPECT_EQ(e.file, kFile);
    EXPECT_EQ(e.json_path, "$.steps[1]") << step;
    EXPECT_NE(e.message.find("concerns a gateway, and "), std::string::npos) << e.message;
    EXPECT_NE(e.message.find("slaves-line.json configures none"), std::string::npos) << e.message;
  }
}

TEST(SlavesLineReplay, AStationStepWithoutSlaveSaysToNameIt) {
  const auto e = error(R"({"expect_dp_state": "data_exch", "within_ms": 100})");
  EXPECT_EQ(e.json_path, "$.steps[0]");
  EXPECT_NE(e.message.find("give \"slave\""), std::string::npos) << e.message;
  // Naming a gateway that is not there lists none.
  const auto g = error(R"({"power_cycle": true, "gateway": "gw3"})");
  EXPECT_EQ(g.json_path, "$.steps[0].gateway");
  EXPECT_NE(g.message.find("no gateway \"gw3\""), std::string::npos) << g.message;
}

TEST(SlavesLineReplay, APageDriverNeedsAGateway) {
  const auto e = error("", R"("page_driver": {}, )");
  EXPECT_EQ(e.json_path, "$.page_driver");
  EXPECT_NE(e.message.find("configures none"), std::string::npos) << e.message;
}

}  // namespace
}  // namespace candp2::replay

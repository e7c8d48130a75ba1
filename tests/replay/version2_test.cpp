// Replay of a whole configuration (docs/replay-format.md "Version 2"): a scenario names a candp2d
// configuration, steps address gateways by name; a missing or unknown name, or a configuration
// that does not load, is refused with the scenario file, the JSON path and what was expected.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>

#include "replay/report.hpp"
#include "replay/runner.hpp"
#include "replay/scenario.hpp"

namespace candp2::replay {
namespace {

namespace fs = std::filesystem;

// Two gateways on two buses, one drive each (as config/two-gateways.json, smaller).
const char* kConfig = R"({
  "master": {"address": 1, "cycle_ms": 10},
  "buses": {"a": {"type": "virtual"}, "b": {"type": "socketcan", "interface": "can7"}},
  "gateways": [
    {"name": "left", "address": 3, "bus": "a", "parameters": {},
     "slots": [{"io": "output", "address": 0, "length": 5, "comment": "02,01,00"},
               {"io": "input", "address": 0, "length": 6, "comment": "01,81,00"}]},
    {"name": "right", "address": 5, "bus": "b", "parameters": {},
     "slots": [{"io": "output", "address": 16, "length": 5, "comment": "02,01,00"},
               {"io": "input", "address": 16, "length": 6, "comment": "01,81,00"}]}],
  "drives": [{"type": "unitek", "name": "axis1", "bus": "a"}]
})";

class Version2 : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("candp2-replay-v2-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir / "conf");
    std::ofstream(dir / "conf" / "line.json") << kConfig;
  }
  void TearDown() override { fs::remove_all(dir); }
  // A scenario beside conf/: "config" is relative to the scenario file.
  config::Result<Scenario> parse(const std::string& steps) {
    const std::string text = R"({"format": "candp2-replay", "version": 2, "name": "v2",
        "config": "conf/line.json", "steps": [)" +
                             steps + "]}";
    return parse_scenario(text, (dir / "s.json").string());
  }
  config::ConfigError error(const std::string& steps) {
    auto r = parse(steps);
    EXPECT_TRUE(std::holds_alternative<config::ConfigError>(r));
    return std::holds_alternative<config::ConfigError>(r) ? std::get<config::ConfigError>(r)
                                                          : config::ConfigError{};
  }
  fs::path dir;
};

TEST_F(Version2, StepsAddressGatewaysByNameAndFramesAreTheirs) {
  auto r = parse(R"({"expect_dp_state": "data_exch", "gateway": "left", "within_ms": 100},
      {"expect_dp_state": "data_exch", "gateway": "right", "within_ms": 100},
      {"write": {"address": 16, "bytes": "3D E2 00 00 00"}, "gateway": "right"},
      {"expect_frame": "201#3DE2000000", "gateway": "right", "within_ms": 20},
      {"expect_no_frame": "201#3DE2000000", "gateway": "left", "for_ms": 30},
      {"write": {"address": 0, "bytes": "3D E2 00 00 00"}, "gateway": "left"},
      {"expect_input": {"address": 0, "bytes": "E2 01 00 00 00 00"}, "gateway": "left",
       "within_ms": 40},
      {"inject": "181#E2000000", "bus": "b"},
      {"expect_input": {"address": 16, "bytes": "E2 00 00 00 00 00"}, "gateway": "right",
       "within_ms": 20})");
  ASSERT_TRUE(std::holds_alternative<Scenario>(r)) << std::get<config::ConfigError>(r).to_string();
  const auto& sc = std::get<Scenario>(r);
  EXPECT_EQ(sc.installation.gateways.size(), 2u);
  EXPECT_EQ(sc.steps[3].gateway, 1u);
  const auto res = run(sc);
  EXPECT_TRUE(res.passed()) << format_report(sc, res);
  // Every bus under its own interface name: the virtual bus "a", the SocketCAN bus's "can7".
  const auto log = format_can_log(sc, res);
  EXPECT_NE(log.find(" a 201#3DE2000000"), std::string::npos) << log;
  EXPECT_NE(log.find(" can7 201#3DE2000000"), std::string::npos) << log;
  EXPECT_NE(log.find(" can7 181#E2000000"), std::string::npos) << log;
}

TEST_F(Version2, AStepWithoutAGatewayIsRefusedWhenThereAreSeveral) {
  const auto e = error(R"({"power_cycle": true})");
  EXPECT_EQ(e.file, (dir / "s.json").string());
  EXPECT_EQ(e.json_path, "$.steps[0]");
  EXPECT_NE(e.message.find("give \"gateway\", one of \"left\", \"right\""), std::string::npos)
      << e.to_string();
}

TEST_F(Version2, AnUnknownGatewayNameIsRefused) {
  const auto e = error(R"({"note": "x"}, {"expect_diag": "00 0C 00 01 04 A4 05 04 00 00 00",
      "gateway": "middle"})");
  EXPECT_EQ(e.json_path, "$.steps[1].gateway");
  EXPECT_NE(e.message.find("no gateway \"middle\""), std::string::npos) << e.to_string();
  EXPECT_NE(e.message.find("line.json"), std::string::npos) << e.to_string();
}

TEST_F(Version2, AConfigurationThatDoesNotLoadNamesItsOwnFileAndPath) {
  std::ofstream(dir / "conf" / "line.json", std::ios::trunc)
      << R"({"buses": {"a": {"type": "virtual"}},
             "gateways": [{"address": 3, "bus": "a", "slots": [{"io": "sideways"}]}]})";
  const auto e = error("");
  EXPECT_EQ(e.file, (dir / "s.json").string());
  EXPECT_EQ(e.json_path, "$.config");
  EXPECT_NE(e.message.find("line.json: $.gateways[0].slots[0]"), std::string::npos)
      << e.to_string();
}

TEST_F(Version2, ConfigAndTheVersionOneKeysDoNotMix) {
  const std::string text = R"({"format": "candp2-replay", "version": 2, "config": "conf/line.json",
      "cycle_ms": 5, "steps": []})";
  auto r = parse_scenario(text, (dir / "s.json").string());
  ASSERT_TRUE(std::holds_alternative<config::ConfigError>(r));
  EXPECT_EQ(std::get<config::ConfigError>(r).json_path, "$.cycle_ms");
}

#ifdef CANDP2_BIN
// `candp2 replay` exits 2 for a refused scenario, naming the file and the JSON path.
TEST_F(Version2, TheToolExitsTwoOnAnUnknownGateway) {
  std::ofstream(dir / "s.json") << R"({"format": "candp2-replay", "version": 2,
      "config": "conf/line.json", "steps": [{"drop_rx": 3, "gateway": "nope"}]})";
  const std::string cmd =
      "timeout 60 " + std::string(CANDP2_BIN) + " replay " + (dir / "s.json").string() + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int rc = ::pclose(p);
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 2) << out;
  EXPECT_NE(out.find("s.json: $.steps[0].gateway: no gateway \"nope\""), std::string::npos) << out;
}
#endif

}  // namespace
}  // namespace candp2::replay

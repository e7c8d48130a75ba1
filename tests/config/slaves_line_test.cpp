// A line of generic slaves alone (docs/configuration.md "Top level", docs/slaves.md "A line of
// generic slaves alone"): "slaves" without "gateways" and without "buses" is a configuration;
// neither stations at all is an error naming the file, the JSON path and what was expected.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "config/config.hpp"

namespace candp2::config {
namespace {

using json = nlohmann::json;

// A "file" in config/: the example GSD config/gsd/CDP2C0A.GSD resolves as gsd/CDP2C0A.GSD.
const std::string kFile = CANDP2_SOURCE_DIR "/config/line.json";

json line() {
  return json::parse(R"json({
    "master": {"address": 1, "cycle_ms": 10},
    "slaves": [
      {"name": "in1", "address": 4, "gsd": "gsd/CDP2C0A.GSD", "field_unit": 104,
       "input_address": 0, "output_address": 0},
      {"name": "in2", "address": 5, "gsd": "gsd/CDP2C0A.GSD", "field_unit": 105,
       "input_address": 8, "output_address": 8, "parameters": {"Filter time (ms)": 5}}
    ]
  })json");
}

Result<DaemonConfig> parse(const json& j) {
  return parse_daemon(j.dump(), kFile);
}

DaemonConfig ok(const json& j) {
  auto r = parse(j);
  if (auto* e = std::get_if<ConfigError>(&r)) {
    ADD_FAILURE() << e->to_string();
    return {};
  }
  return std::get<DaemonConfig>(r);
}

ConfigError bad(const json& j) {
  auto r = parse(j);
  if (!std::holds_alternative<ConfigError>(r)) {
    ADD_FAILURE() << "accepted: " << j.dump();
    return {};
  }
  return std::get<ConfigError>(r);
}

TEST(SlavesLine, NoGatewaysAndNoBuses) {
  const auto c = ok(line());
  EXPECT_TRUE(c.gateways.empty());
  EXPECT_TRUE(c.buses.empty());
  ASSERT_EQ(c.slaves.size(), 2u);
  EXPECT_EQ(c.slaves[1].name, "in2");
  EXPECT_EQ(c.slaves[1].profile.ident_number, 0x0C0A);
  EXPECT_TRUE(c.warnings.empty()) << c.warnings[0].to_string();
  // The master's Set_Prm carries the named parameter, Chk_Cfg the one module's bytes.
  const auto p = slave_parameters(c.slaves[1]);
  ASSERT_EQ(p.prm.size(), 8u);
  EXPECT_EQ(p.prm[7], 5);
  EXPECT_EQ(p.cfg, (std::vector<std::uint8_t>{0x17, 0x27}));
  EXPECT_EQ(p.addresses.at(0).input, 8);
}

TEST(SlavesLine, AnEmptyGatewaysArrayAndAnEmptyBusesObject) {
  json j = line();
  j["gateways"] = json::array();
  j["buses"] = json::object();
  const auto c = ok(j);
  EXPECT_TRUE(c.gateways.empty());
  EXPECT_EQ(c.slaves.size(), 2u);
  // A bus given anyway is still read (a drive may use it).
  j["buses"] = {{"can0", {{"type", "virtual"}}}};
  j["drives"] = json::array({{{"name", "axis1"}, {"bus", "can0"}}});
  EXPECT_EQ(ok(j).buses.size(), 1u);
}

TEST(SlavesLine, NeitherGatewaysNorSlavesIsAnError) {
  const std::string expected =
      "line.json: $.gateways: expected a non-empty array of gateways, or generic DP-V0 slaves in "
      "$.slaves (docs/slaves.md); the file configures neither";
  auto suffix = [&](const ConfigError& e) {
    const std::string text = e.to_string();
    return text.substr(text.size() - std::min(text.size(), expected.size()));
  };
  json none = line();
  none.erase("slaves");
  ConfigError e = bad(none);
  EXPECT_EQ(e.file, kFile);
  EXPECT_EQ(e.json_path, "$.gateways");
  EXPECT_EQ(suffix(e), expected);
  json empty = line();
  empty["slaves"] = json::array();
  empty["gateways"] = json::array();
  EXPECT_EQ(suffix(bad(empty)), expected);
}

TEST(SlavesLine, WrongTypesAndADriveWithoutItsBus) {
  json j = line();
  j["gateways"] = json::object();
  ConfigError e = bad(j);
  EXPECT_EQ(e.json_path, "$.gateways");
  EXPECT_EQ(e.message, "expected an array of gateways, got an object");
  j = line();
  j["slaves"] = "in1";
  e = bad(j);
  EXPECT_EQ(e.json_path, "$.slaves");
  EXPECT_NE(e.message.find("expected an array of slaves"), std::string::npos) << e.message;
  j = line();
  j["drives"] = json::array({{{"name", "axis1"}, {"bus", "can0"}}});
  e = bad(j);
  EXPECT_EQ(e.json_path, "$.drives[0].bus");
  EXPECT_NE(e.message.find("unknown bus \"can0\""), std::string::npos) << e.message;
}

TEST(SlavesLine, AGatewayStillNeedsItsBus) {
  json j = line();
  j["gateways"] = json::array(
      {{{"name", "gw3"},
        {"address", 3},
        {"bus", "can0"},
        {"slots",
         json::array(
             {{{"io", "output"}, {"address", 20}, {"length", 1}, {"comment", "07,F8,00"}}})}}});
  const ConfigError e = bad(j);
  EXPECT_EQ(e.json_path, "$");
  EXPECT_NE(e.message.find("buses"), std::string::npos) << e.message;
}

}  // namespace
}  // namespace candp2::config

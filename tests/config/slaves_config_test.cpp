// The "slaves" array (config/slaves_config.hpp, docs/configuration.md "slaves"): generic DP-V0
// slaves from the project's own GSD files (tests/gsd/data/README.md), what the master sends them,
// and that every bad entry names the file, the JSON path and what was expected.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "common/hex.hpp"
#include "config/config.hpp"
#include "tests/vendor_files.hpp"

namespace candp2::config {
namespace {

using json = nlohmann::json;

const std::string kCorpus = candp2::test::project_gsd_dir().string();
// A configuration "file" in the GSD folder: relative GSD paths resolve there (parse_daemon
// does not read the file itself).
const std::string kFile = kCorpus + "/line.json";

json base() {
  return json::parse(R"({
    "master": {"address": 1, "cycle_ms": 10},
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [{"name": "gw3", "address": 3, "bus": "can0",
                  "slots": [{"io": "output", "address": 0, "length": 1, "comment": "07,F8,00"}]}],
    "slaves": [{"address": 8, "gsd": "CP2MOTOR.GSD", "modules": ["Starter Standard"],
                "field_unit": 108}]
  })");
}

json with_slave(const json& patch) {
  json j = base();
  j["slaves"][0].merge_patch(patch);
  return j;
}

DaemonConfig ok(const json& j) {
  auto r = parse_daemon(j.dump(), kFile);
  if (auto* e = std::get_if<ConfigError>(&r)) {
    ADD_FAILURE() << e->to_string();
    return {};
  }
  return std::get<DaemonConfig>(r);
}

ConfigError bad(const json& j) {
  auto r = parse_daemon(j.dump(), kFile);
  if (!std::holds_alternative<ConfigError>(r)) {
    ADD_FAILURE() << "accepted: " << j.dump();
    return {};
  }
  return std::get<ConfigError>(r);
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(SlavesConfig, AnEntryAndWhatTheMasterSends) {
  const auto c = ok(with_slave(json::parse(R"({
    "name": "motor1", "watchdog_ms": 100, "input_address": 100, "output_address": 200,
    "parameters": {"Class": 20, "Thermistor Type": "PTC Binary"}, "safe_state": "hold"})")));
  ASSERT_EQ(c.slaves.size(), 1u);
  const SlaveConfig& s = c.slaves[0];
  EXPECT_EQ(s.name, "motor1");
  EXPECT_EQ(s.address, 8);
  EXPECT_EQ(s.gsd, kCorpus + "/CP2MOTOR.GSD");  // relative to the configuration file
  EXPECT_EQ(s.field_unit, 108);
  EXPECT_EQ(s.profile.ident_number, 0x0C31);
  ASSERT_EQ(s.modules.size(), 1u);
  EXPECT_EQ(s.modules[0].json_path, "$.slaves[0].modules[0]");
  EXPECT_EQ(s.safe_state, gsd_slave::SafeState::Hold);
  EXPECT_TRUE(s.warnings.empty());
  const dp::SlaveParameters p = slave_parameters(s);
  EXPECT_EQ(hex_bytes(std::span(p.prm).first(7)), "88 0A 01 00 0C 31 00");
  EXPECT_EQ(p.prm.size(), 7u + 24u);
  EXPECT_EQ(p.prm[16], 20);            // "Class"
  EXPECT_EQ((p.prm[10] >> 2) & 7, 1);  // "Thermistor Type" = PTC Binary
  EXPECT_EQ(hex_bytes(p.cfg), "10 10 91 20 20 20 20");
  ASSERT_EQ(p.addresses.size(), 7u);  // one per identifier entry
  EXPECT_EQ(p.addresses[0].input, 100);
  EXPECT_EQ(p.addresses[2].input, 102);  // after two 1-byte inputs
  EXPECT_EQ(p.addresses[3].output, 200);
  EXPECT_EQ(p.addresses[6].output, 203);
  // The emulated slave built from the entry accepts exactly that.
  std::string error;
  auto slave = gsd_slave::GsdSlave::create(s.setup(), &error);
  ASSERT_TRUE(slave) << error;
  EXPECT_TRUE(slave->dp().set_prm(1, p.prm, Time{0}));
  EXPECT_TRUE(slave->dp().chk_cfg(1, p.cfg, Time{0}));
}

TEST(SlavesConfig, CfgHexAndNoSlaves) {
  const auto c =
      ok(with_slave(json::parse(R"({"modules": null, "cfg_hex": "10 10 91 20 20 20 20"})")));
  EXPECT_EQ(hex_bytes(chk_cfg_bytes(c.slaves[0])), "10 10 91 20 20 20 20");
  EXPECT_TRUE(c.slaves[0].modules.empty());
  json none = base();
  none.erase("slaves");
  EXPECT_TRUE(ok(none).slaves.empty());
}

TEST(SlavesConfig, ErrorsNameThePathAndWhatWasExpected) {
  struct Case {
    json patch;
    std::string path, message_part;
  };
  const Case cases[] = {
      {json::parse(R"({"modules": ["Starter Standard", "Starter Type 9"]})"),
       "$.slaves[0].modules[1]",
       "no module \"Starter Type 9\" in " + kCorpus +
           "/CP2MOTOR.GSD (its modules: \"Starter Standard"},
      {json::parse(R"({"parameters": {"No Such": 1}})"), "$.slaves[0].parameters[\"No Such\"]",
       "\"No Such\": no such parameter (ExtUserPrmData name)"},
      {json::parse(R"({"parameters": {"Class": 40}})"), "$.slaves[0].parameters.Class",
       "outside the range 5-30"},
      {json::parse(R"({"parameters": {"Class": true}})"), "$.slaves[0].parameters.Class",
       "expected a number or a text of the parameter's PrmText, got true"},
      {json::parse(R"({"gsd": "NOPE.GSD"})"), "$.slaves[0].gsd",
       "expected a GSD file, but " + kCorpus + "/NOPE.GSD does not exist"},
      {json::parse(R"({"gsd": "README.md"})"), "$.slaves[0].gsd", "the GSD file has errors"},
      {json::parse(R"({"address": 3})"), "$.slaves[0].address",
       "DP address 3 is already used by $.gateways[0]"},
      {json::parse(R"({"address": 1})"), "$.slaves[0].address",
       "DP address 1 is already used by $.master.address"},
      {json::parse(R"({"address": 126})"), "$.slaves[0].address", "from 0 to 125"},
      {json::parse(R"({"field_unit": 3})"), "$.slaves[0].field_unit",
       "Modbus unit ID 3 is already used by $.gateways[0]"},
      {json::parse(R"({"field_unit": 8})"), "$.slaves[0].field_unit",
       "Modbus unit ID 8 is already used by $.slaves[0].address"},
      {json::parse(R"({"cfg_hex": "10"})"), "$.slaves[0].cfg_hex",
       "give either \"modules\" (by GSD name) or \"cfg_hex\", not both"},
      {json::parse(R"({"modules": null, "cfg_hex": "43"})"), "$.slaves[0].cfg_hex",
       "expected whole Chk_Cfg identifier entries"},
      {json::parse(R"({"modules": null})"), "$.slaves[0]", "missing key \"modules\""},
      {json::parse(R"({"modules": "Starter Standard"})"), "$.slaves[0].modules",
       "expected an array of module names as in the GSD"},
      {json::parse(R"({"safe_state": "off"})"), "$.slaves[0].safe_state",
       "expected \"zero\" or \"hold\""},
      {json::parse(R"({"prm_hex": "88 0A", "watchdog_ms": 100})"), "$.slaves[0].watchdog_ms",
       "prm_hex gives the whole Set_Prm telegram"},
      {json::parse(R"({"input_address": 8190})"), "$.slaves[0].input_address",
       "lie outside the 8192-byte PLC image"},
      {json::parse(R"({"bus": "can0"})"), "$.slaves[0].bus", "unknown key"},
      {json::parse(R"({"name": "gw3"})"), "$.slaves[0].name",
       "the name \"gw3\" is already used by $.gateways[0]"},
  };
  for (const auto& c : cases) {
    const ConfigError e = bad(with_slave(c.patch));
    EXPECT_EQ(e.file, kFile) << c.patch.dump();
    EXPECT_EQ(e.json_path, c.path) << c.patch.dump() << ": " << e.to_string();
    EXPECT_TRUE(has(e.message, c.message_part)) << c.patch.dump() << ": " << e.to_string();
  }
  json twice = base();
  twice["slaves"].push_back(twice["slaves"][0]);
  twice["slaves"][1]["field_unit"] = 109;
  EXPECT_EQ(bad(twice).to_string(),
            kFile + ": $.slaves[1].address: DP address 8 is already used by $.slaves[0]");
  json not_array = base();
  not_array["slaves"] = json::object();
  EXPECT_EQ(bad(not_array).json_path, "$.slaves");
}

TEST(SlavesConfig, WhatTheSlaveWouldRejectIsAWarning) {
  // Two modules on a station with Max_Module 1: the slave answers Cfg_Fault.
  auto c = ok(with_slave(json::parse(R"({"modules": ["Starter Standard", "Starter Standard"]})")));
  ASSERT_EQ(c.slaves[0].warnings.size(), 1u);
  EXPECT_EQ(c.slaves[0].warnings[0].json_path, "$.slaves[0].modules");
  EXPECT_TRUE(has(c.slaves[0].warnings[0].message,
                  "the slave will reject this configuration: 2 modules, Max_Module is 1"));
  ASSERT_FALSE(c.warnings.empty());
  EXPECT_EQ(c.warnings.back().json_path, "$.slaves[0].modules");
  // A raw Set_Prm with "Class" = 40: Prm fault on purpose.
  auto prm = slave_parameters(ok(base()).slaves[0]).prm;
  prm[16] = 40;
  c = ok(with_slave(json{{"prm_hex", hex_bytes(prm)}}));
  ASSERT_EQ(c.slaves[0].warnings.size(), 1u);
  EXPECT_EQ(c.slaves[0].warnings[0].json_path, "$.slaves[0].prm_hex");
  EXPECT_TRUE(has(c.slaves[0].warnings[0].message,
                  "the slave will reject this Set_Prm: \"Class\" (byte 16) = 40"));
}

// The project's own modular test device (docs/slaves.md "Preset modules"): "Head module" has
// Preset = 1 and the GSD FixPresetModules = 1.
const std::string kPresetGsd = CANDP2_SOURCE_DIR "/tests/gsd_slave/data/preset_modular.gsd";

json preset_slave(const json& modules) {
  return with_slave(json{{"gsd", kPresetGsd}, {"modules", modules}});
}

TEST(SlavesConfigPresets, APresetModuleLeftOutIsAddedFirst) {
  const auto c = ok(preset_slave({"Output 2 bytes", "Input 1 byte"}));
  const SlaveConfig& s = c.slaves[0];
  ASSERT_EQ(s.modules.size(), 3u);
  EXPECT_EQ(s.modules[0].name, "Head module");
  EXPECT_TRUE(s.modules[0].added);
  EXPECT_EQ(s.modules[0].json_path, "$.slaves[0].modules");
  EXPECT_EQ(s.modules[1].name, "Output 2 bytes");
  EXPECT_FALSE(s.modules[1].added);
  EXPECT_EQ(s.modules[1].json_path, "$.slaves[0].modules[0]");
  EXPECT_EQ(s.modules[2].json_path, "$.slaves[0].modules[1]");
  // What the master sends and what the slave has: the head module's entry first.
  EXPECT_EQ(hex_bytes(chk_cfg_bytes(s)), "90 21 10");
  std::string error;
  auto slave = gsd_slave::GsdSlave::create(s.setup(), &error);
  ASSERT_TRUE(slave) << error;
  EXPECT_EQ(hex_bytes(slave->configuration().bytes), "90 21 10");
  EXPECT_TRUE(s.warnings.empty());  // the dry run: accepted
  // A note, not a warning: it says what was added, where, and why.
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_EQ(s.notes[0].json_path, "$.slaves[0].modules");
  EXPECT_TRUE(has(s.notes[0].message, "preset module \"Head module\" of " + kPresetGsd +
                                          " added at slot 0, as configuration tools do "
                                          "(Preset = 1, FixPresetModules = 1"))
      << s.notes[0].message;
  EXPECT_TRUE(c.warnings.empty());
}

TEST(SlavesConfigPresets, APresetModuleListedFirstStands) {
  const auto c = ok(preset_slave({"Head module", "Output 2 bytes", "Input 1 byte"}));
  const SlaveConfig& s = c.slaves[0];
  ASSERT_EQ(s.modules.size(), 3u);
  EXPECT_FALSE(s.modules[0].added);
  EXPECT_EQ(s.modules[0].json_path, "$.slaves[0].modules[0]");
  EXPECT_EQ(hex_bytes(chk_cfg_bytes(s)), "90 21 10");  // the same configuration
  EXPECT_TRUE(s.notes.empty());
}

TEST(SlavesConfigPresets, AFixedModuleMovedOrRepeatedIsAnError) {
  struct Case {
    json modules;
    std::string path;
  };
  const Case cases[] = {
      {{"Output 2 bytes", "Head module"}, "$.slaves[0].modules[1]"},
      {{"Head module", "Input 1 byte", "head module"}, "$.slaves[0].modules[2]"},
  };
  for (const auto& k : cases) {
    SCOPED_TRACE(k.modules.dump());
    const ConfigError e = bad(preset_slave(k.modules));
    EXPECT_EQ(e.file, kFile);
    EXPECT_EQ(e.json_path, k.path);
    EXPECT_TRUE(has(e.message, kPresetGsd + ": \"Head module\" is a fixed preset module: it "
                                            "belongs at slot 0 and cannot be moved "
                                            "(FixPresetModules = 1)"))
        << e.message;
  }
}

}  // namespace
}  // namespace candp2::config

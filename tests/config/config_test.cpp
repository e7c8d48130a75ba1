// The daemon's configuration (docs/configuration.md): what valid files turn into, and that every
// bad file is rejected with the file name, the JSON path and what was expected.
#include "config/config.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/hex.hpp"

namespace candp2::config {
namespace {

using json = nlohmann::json;

// The manual §5.1.4 slot example as a configuration; tests patch it with JSON merge patches.
json base() {
  return json::parse(R"({
    "modbus": {"listen": "127.0.0.1:1502"},
    "master": {"address": 1, "cycle_ms": 10},
    "buses": {"can0": {"type": "virtual", "socketcand": "127.0.0.1:29536"}},
    "gateways": [{
      "name": "gw5", "address": 5, "bus": "can0",
      "slots": [
        {"io": "input",  "address": 172, "length": 6, "comment": "02,89,B8"},
        {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"}
      ]
    }]
  })");
}

DaemonConfig ok(const json& j) {
  auto r = parse_daemon(j.dump(), "test.json");
  if (auto* e = std::get_if<ConfigError>(&r)) {
    ADD_FAILURE() << e->to_string();
    return {};
  }
  return std::get<DaemonConfig>(r);
}

ConfigError bad_text(const std::string& text) {
  auto r = parse_daemon(text, "test.json");
  if (!std::holds_alternative<ConfigError>(r)) {
    ADD_FAILURE() << "accepted: " << text;
    return {};
  }
  return std::get<ConfigError>(r);
}
ConfigError bad(const json& j) {
  return bad_text(j.dump());
}

// Applies `patch` to the first gateway of base().
json with_gateway(const json& patch) {
  json j = base();
  j["gateways"][0].merge_patch(patch);
  return j;
}

std::string hex(const std::vector<std::uint8_t>& b) {
  return hex_bytes(b);
}

// ------------------------------------------------------------------------------ valid files

TEST(Config, Manual514SlotExample) {
  const auto c = ok(base());
  EXPECT_EQ(c.file, "test.json");
  EXPECT_EQ(c.modbus_listen.host, "127.0.0.1");
  EXPECT_EQ(c.modbus_listen.port, 1502);
  ASSERT_EQ(c.buses.size(), 1u);
  EXPECT_EQ(c.buses[0].type, BusType::Virtual);
  ASSERT_TRUE(c.buses[0].socketcand_listen);
  EXPECT_EQ(c.buses[0].socketcand_listen->port, 29536);
  EXPECT_EQ(c.buses[0].channel, "can0");  // export name defaults to the bus name
  ASSERT_EQ(c.gateways.size(), 1u);
  const auto& g = c.gateways[0];
  EXPECT_TRUE(c.warnings.empty()) << c.warnings.front().to_string();
  // Special identifier format (docs/slots.md "Chk_Cfg slots"): input 0x43 (m=3), length 0x85
  // (consistent, 6), comment 02 89 B8; output 0x83 0x85 03 09 B8 (manual §5.1.4, §7).
  EXPECT_EQ(hex(chk_cfg_bytes(g)), "43 85 02 89 B8 83 85 03 09 B8");
  // GSD defaults (manual §5.1.2): 125 kbit/s (6), flags 0, ModuleID 1, wake-up 255, SYNC 65535.
  EXPECT_EQ(hex(set_prm_bytes(g)), "00 01 01 00 04 A4 00 00 06 00 01 00 00 FF FF FF");
  const auto p = slave_parameters(g);
  ASSERT_EQ(p.addresses.size(), 2u);
  EXPECT_EQ(p.addresses[0].input, 172);
  EXPECT_FALSE(p.addresses[0].output);
  EXPECT_EQ(p.addresses[1].output, 172);
  EXPECT_EQ(p.name, "gw5");
}

TEST(Config, Defaults) {
  json j = base();
  j.erase("modbus");
  j.erase("master");
  j["gateways"][0].erase("name");
  const auto c = ok(j);
  EXPECT_EQ(c.modbus_listen.to_string(), "127.0.0.1:1502");  // Default listen address
  EXPECT_EQ(c.master_address, 1);
  EXPECT_EQ(c.cycle_ms, 10u);
  EXPECT_EQ(c.host_stall_ms, 50u);  // docs/configuration.md "master"
  EXPECT_EQ(c.log_level, "info");
  EXPECT_EQ(c.gateways[0].name, "gw5");
  EXPECT_TRUE(c.gateways[0].slots[0].consistent);
}

TEST(Config, NamedParameters) {
  const auto c = ok(with_gateway(
      {{"parameters",
        {{"can_bitrate", 500000},
         {"communication_window", false},
         {"rtr_frames", false},
         {"canopen", "master"},
         {"start_frame", true},
         {"module_id", "0x7F"},
         {"wakeup_s", 3},
         {"sync_ms", 1000},
         {"can_diagnosis", true},
         {"rx_counter", true},
         {"tx_counter", false},
         {"watchdog_ms", 100}}},
       {"slots",
        json::array(
            {{{"io", "output"}, {"address", 0}, {"length", 1}, {"comment", "07,F8,00"}}})}}));
  const auto& p = c.gateways[0].parameters;
  EXPECT_EQ(p.bitrate_index, 2);  // manual table 5.1.1: 500 kbit/s
  EXPECT_FALSE(p.send_rtr);
  EXPECT_TRUE(p.canopen_master);
  EXPECT_TRUE(p.start_frame);
  EXPECT_EQ(p.module_id, 127);
  // Set_Prm (docs/dp-slave.md "User parameters"): WD on (10 ms x 10 x 1), byte 8 = 2, flags
  // 0x10|0x04|0x02 = 16, ModuleID 7F, diag 0x03, wake-up 3, SYNC 03 E8.
  EXPECT_EQ(hex(set_prm_bytes(c.gateways[0])), "08 0A 01 00 04 A4 00 00 02 16 7F 03 00 03 03 E8");
}

TEST(Config, BitrateNames) {
  for (const auto& [given, index] : std::vector<std::pair<json, int>>{{"1000k", 0},
                                                                      {"666.6k", 1},
                                                                      {"125 kbit/s", 6},
                                                                      {"10k", 13},
                                                                      {125000, 6},
                                                                      {"0x1E848", 6}}) {
    const auto c = ok(with_gateway({{"parameters", {{"can_bitrate", given}}}}));
    EXPECT_EQ(c.gateways[0].parameters.bitrate_index, index) << given;
  }
  const auto e = bad(with_gateway({{"parameters", {{"can_bitrate", 123456}}}}));
  EXPECT_EQ(e.json_path, "$.gateways[0].parameters.can_bitrate");
  EXPECT_NE(e.message.find("125k"), std::string::npos) << e.message;
}

TEST(Config, NumbersAsHexStrings) {
  const auto c = ok(with_gateway({{"address", "0x05"}}));
  EXPECT_EQ(c.gateways[0].address, 5);
  const auto e = bad(with_gateway({{"address", "5"}}));  // decimal strings are not numbers
  EXPECT_EQ(e.json_path, "$.gateways[0].address");
  EXPECT_NE(e.message.find("\"0x…\""), std::string::npos);
}

TEST(Config, BusTypes) {
  json j = base();
  j["buses"]["hw"] = {{"type", "socketcan"}, {"interface", "vcan0"}};
  j["buses"]["far"] = {{"type", "socketcand"}, {"host", "10.0.0.9"}, {"channel", "can1"}};
  j["buses"]["can0"]["channel"] = "vcan7";
  const auto c = ok(j);
  ASSERT_EQ(c.buses.size(), 3u);
  const auto* hw = c.bus("hw");
  ASSERT_TRUE(hw);
  EXPECT_EQ(hw->type, BusType::SocketCan);
  EXPECT_EQ(hw->interface, "vcan0");
  const auto* far = c.bus("far");
  ASSERT_TRUE(far);
  EXPECT_EQ(far->type, BusType::Socketcand);
  EXPECT_EQ(far->remote.to_string(), "10.0.0.9:29536");  // socketcand.h default port
  EXPECT_EQ(far->channel, "can1");
  EXPECT_EQ(c.bus("can0")->channel, "vcan7");
}

// docs/transports.md "Bit rate": "bitrate" check (default) / apply, restart_ms only with apply.
TEST(Config, SocketcanBitrateMode) {
  json j = base();
  j["buses"]["hw"] = {{"type", "socketcan"}, {"interface", "can0"}};
  EXPECT_EQ(ok(j).bus("hw")->bitrate, BitrateMode::Check);
  EXPECT_FALSE(ok(j).bus("hw")->restart_ms);
  j["buses"]["hw"]["bitrate"] = "apply";
  j["buses"]["hw"]["restart_ms"] = 100;
  const auto c = ok(j);
  EXPECT_EQ(c.bus("hw")->bitrate, BitrateMode::Apply);
  EXPECT_EQ(c.bus("hw")->restart_ms, 100u);
  // docs/dp-slave.md "User parameters" byte 8: index 2 = 500k, 6 (default) = 125k.
  j["gateways"][0]["parameters"]["can_bitrate"] = "500k";
  EXPECT_EQ(configured_bitrate(ok(j).gateways[0]), 500000u);
  EXPECT_EQ(configured_bitrate(ok(base()).gateways[0]), 125000u);
}

TEST(ConfigErrors, SocketcanBitrate) {
  json j = base();
  j["buses"]["hw"] = {{"type", "socketcan"}, {"interface", "can0"}, {"bitrate", "set"}};
  auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.buses.hw.bitrate");
  EXPECT_NE(e.message.find("\"apply\""), std::string::npos) << e.message;
  j["buses"]["hw"]["bitrate"] = "check";
  j["buses"]["hw"]["restart_ms"] = 100;
  e = bad(j);
  EXPECT_EQ(e.json_path, "$.buses.hw.restart_ms");
  EXPECT_NE(e.message.find("apply"), std::string::npos) << e.message;
  j["buses"]["hw"]["bitrate"] = "apply";
  j["buses"]["hw"]["restart_ms"] = 60001;
  EXPECT_EQ(bad(j).json_path, "$.buses.hw.restart_ms");
}

// Two gateways on one interface with "apply" must agree on Set_Prm byte 8 (one interface, one bit
// rate); with "check" on both they may differ (each sees the mismatch).
TEST(ConfigErrors, TwoGatewaysOneInterfaceDifferentBitrates) {
  json j = base();
  j["buses"] = {{"a", {{"type", "socketcan"}, {"interface", "can0"}, {"bitrate", "apply"}}},
                {"b", {{"type", "socketcan"}, {"interface", "can0"}}}};
  j["gateways"][0]["bus"] = "a";
  j["gateways"][0]["parameters"]["can_bitrate"] = "500k";
  json g2 = j["gateways"][0];
  g2["name"] = "gw6";
  g2["address"] = 6;
  g2["bus"] = "b";
  g2["parameters"]["can_bitrate"] = "250k";
  j["gateways"].push_back(g2);
  const auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.gateways[1].parameters.can_bitrate");
  EXPECT_NE(e.message.find("250000 bit/s differs from 500000 bit/s of $.gateways[0]"),
            std::string::npos)
      << e.message;
  EXPECT_NE(e.message.find("can0"), std::string::npos) << e.message;
  j["gateways"][1]["parameters"]["can_bitrate"] = "500k";
  EXPECT_EQ(ok(j).gateways.size(), 2u);
  j["gateways"][1]["parameters"]["can_bitrate"] = "250k";
  j["buses"]["a"].erase("bitrate");
  EXPECT_EQ(ok(j).gateways.size(), 2u);
}

TEST(Config, RawPrmAndCfgHex) {
  const auto c =
      ok(with_gateway({{"prm_hex", "00 01 01 00 04 A4 00 00 06 80 01 00 00 FF FF FF"},
                       {"slots", json::array({{{"cfg_hex", "83 85 03 09 B8"}, {"address", 10}},
                                              {{"cfg_hex", "00"}}})}}));
  const auto& g = c.gateways[0];
  EXPECT_EQ(hex(set_prm_bytes(g)), "00 01 01 00 04 A4 00 00 06 80 01 00 00 FF FF FF");
  EXPECT_EQ(hex(chk_cfg_bytes(g)), "83 85 03 09 B8 00");
  const auto p = slave_parameters(g);
  EXPECT_EQ(p.addresses[0].output, 10);
  EXPECT_FALSE(p.addresses[1].input || p.addresses[1].output);
}

TEST(Config, RelativeFilesFollowTheConfigFile) {
  json j = base();
  j["log"] = {{"level", "debug"}, {"can_log", "can.log"}};
  j["state_file"] = "/var/lib/candp2/state.json";
  auto r = parse_daemon(j.dump(), "/etc/candp2/candp2d.json");
  ASSERT_TRUE(std::holds_alternative<DaemonConfig>(r));
  const auto& c = std::get<DaemonConfig>(r);
  EXPECT_EQ(c.can_log, "/etc/candp2/can.log");
  EXPECT_EQ(c.state_file, "/var/lib/candp2/state.json");
  EXPECT_EQ(c.log_level, "debug");
}

TEST(Config, CommentKeysAreIgnored) {
  json j = base();
  j["_comment"] = "anything";
  j["gateways"][0]["slots"][0]["_note"] = 42;
  ok(j);
}

TEST(Config, ExampleFilesInTheRepositoryAreValid) {
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(CANDP2_SOURCE_DIR "/config")) {
    if (entry.path().extension() != ".json") continue;
    ++files;
    auto r = load_daemon(entry.path().string());
    if (auto* e = std::get_if<ConfigError>(&r)) {
      ADD_FAILURE() << e->to_string();
      continue;
    }
    // config/line-9600.json shows on purpose watchdogs shorter than the bus cycle itself
    // (docs/validate.md "The watchdog rule"), which config/scenarios/line-watchdog-9600.json
    // replays: those two findings and nothing else.
    const bool on_purpose = entry.path().filename() == "line-9600.json";
    std::size_t unholdable = 0;
    for (const auto& w : std::get<DaemonConfig>(r).warnings) {
      if (on_purpose && w.kind == WarningKind::Unholdable && ++unholdable) continue;
      ADD_FAILURE() << "warning in an example: " << w.to_string();
    }
    EXPECT_EQ(unholdable, on_purpose ? 2u : 0u) << entry.path();
  }
  EXPECT_GE(files, 3);
}

// ------------------------------------------------------------------------------ bad files
// Missing key, wrong type, unknown bus, slot comment with odd hex — file + JSON path.

TEST(ConfigErrors, MissingKey) {
  json j = base();
  j["gateways"][0].erase("slots");
  const auto e = bad(j);
  EXPECT_EQ(e.to_string(), "test.json: $.gateways[0]: missing key \"slots\"");
  j = base();
  j["gateways"][0]["slots"][1].erase("length");
  EXPECT_EQ(bad(j).json_path, "$.gateways[0].slots[1]");
  j = base();
  j.erase("buses");
  EXPECT_EQ(bad(j).to_string(), "test.json: $: missing key \"buses\"");
}

TEST(ConfigErrors, WrongType) {
  auto e = bad(with_gateway({{"address", true}}));
  EXPECT_EQ(e.json_path, "$.gateways[0].address");
  EXPECT_NE(e.message.find("expected a number from 0 to 126"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find("got true"), std::string::npos) << e.message;

  json j = base();
  j["gateways"][0]["slots"][0]["consistent"] = "yes";
  e = bad(j);
  EXPECT_EQ(e.to_string(),
            "test.json: $.gateways[0].slots[0].consistent: expected true or false, got the string "
            "\"yes\"");

  j = base();
  j["gateways"] = json::object();
  EXPECT_EQ(bad(j).json_path, "$.gateways");

  j = base();
  j["gateways"][0]["slots"][0]["length"] = 2.5;
  e = bad(j);
  EXPECT_NE(e.message.find("not a whole number"), std::string::npos);
  j["gateways"][0]["slots"][0]["length"] = -1;
  EXPECT_EQ(bad(j).json_path, "$.gateways[0].slots[0].length");
}

// docs/can-bus.md "The bus's bit rate": a virtual bus's "bitrate" is a rate of manual table 5.1.1
// written as can_bitrate is; without it the bus is ideal.
TEST(Config, VirtualBusBitrate) {
  json j = base();
  EXPECT_FALSE(ok(j).bus("can0")->timed_bitrate);
  j["buses"]["can0"]["bitrate"] = "500k";
  EXPECT_EQ(ok(j).bus("can0")->timed_bitrate, 500000u);
  j["buses"]["can0"]["bitrate"] = "666.6k";
  EXPECT_EQ(ok(j).bus("can0")->timed_bitrate, 666600u);
  j["buses"]["can0"]["bitrate"] = 1000000;
  EXPECT_EQ(ok(j).bus("can0")->timed_bitrate, 1000000u);
  j["buses"]["can0"]["bitrate"] = "125 kbit/s";
  EXPECT_EQ(ok(j).bus("can0")->timed_bitrate, 125000u);
}

TEST(ConfigErrors, VirtualBusBitrate) {
  json j = base();
  j["buses"]["can0"]["bitrate"] = "400k";
  auto e = bad(j);
  EXPECT_EQ(e.file, "test.json");
  EXPECT_EQ(e.json_path, "$.buses.can0.bitrate");
  EXPECT_NE(e.message.find("expected a CAN bit rate of manual table 5.1.1"), std::string::npos)
      << e.message;
  j["buses"]["can0"]["bitrate"] = 400000;
  EXPECT_EQ(bad(j).json_path, "$.buses.can0.bitrate");
  j["buses"]["can0"]["bitrate"] = "check";  // the socketcan buses' mode is no rate
  EXPECT_EQ(bad(j).json_path, "$.buses.can0.bitrate");
}

TEST(ConfigErrors, UnknownBus) {
  const auto e = bad(with_gateway({{"bus", "can9"}}));
  EXPECT_EQ(e.to_string(),
            "test.json: $.gateways[0].bus: unknown bus \"can9\" (defined in $.buses: can0)");
}

TEST(ConfigErrors, SlotCommentWithOddHex) {
  json j = base();
  j["gateways"][0]["slots"][1]["comment"] = "03,9,B8";
  auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.gateways[0].slots[1].comment");
  EXPECT_NE(e.message.find("expected hex bytes like \"02,89,B8\""), std::string::npos);
  EXPECT_NE(e.message.find("'9' is not one byte"), std::string::npos) << e.message;
  j["gateways"][0]["slots"][1]["comment"] = "03,0G,B8";
  EXPECT_NE(bad(j).message.find("'G' is not a hex digit"), std::string::npos);
  j["gateways"][0]["slots"][1]["comment"] = 30980;
  EXPECT_EQ(bad(j).json_path, "$.gateways[0].slots[1].comment");
}

TEST(ConfigErrors, OddHexInRawBytes) {
  auto e = bad(with_gateway({{"prm_hex", "00 01 0"}}));
  EXPECT_EQ(e.json_path, "$.gateways[0].prm_hex");
  EXPECT_NE(e.message.find("odd number of hex digits"), std::string::npos) << e.message;
  e = bad(with_gateway({{"slots", json::array({{{"cfg_hex", "83 85 03"}, {"address", 0}}})}}));
  EXPECT_EQ(e.json_path, "$.gateways[0].slots[0].cfg_hex");  // manufacturer bytes missing
  e = bad(with_gateway(
      {{"slots",
        json::array({{{"cfg_hex", "83 85 03 09 B8"}, {"io", "output"}, {"address", 0}}})}}));
  EXPECT_EQ(e.json_path, "$.gateways[0].slots[0].io");
}

TEST(ConfigErrors, UnknownKeyNamesTheAllowedOnes) {
  json j = base();
  j["gateways"][0]["slots"][0]["lenght"] = 6;
  const auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.gateways[0].slots[0].lenght");
  EXPECT_NE(e.message.find("unknown key (expected one of: io, address, length"), std::string::npos)
      << e.message;
  j = base();
  j["gateways"][0]["parameters"] = {{"canopen_master", true}};
  EXPECT_EQ(bad(j).json_path, "$.gateways[0].parameters.canopen_master");
}

TEST(ConfigErrors, EnumValues) {
  auto e = bad(with_gateway({{"parameters", {{"canopen", "both"}}}}));
  EXPECT_EQ(e.to_string(),
            "test.json: $.gateways[0].parameters.canopen: expected one of \"none\", \"master\", "
            "\"slave\", got the string \"both\"");
  json j = base();
  j["buses"]["can0"]["type"] = "vcan";
  e = bad(j);
  EXPECT_EQ(e.json_path, "$.buses.can0.type");
  j = base();
  j["log"] = {{"level", "verbose"}};
  EXPECT_EQ(bad(j).json_path, "$.log.level");
}

TEST(ConfigErrors, DuplicateKeyWithItsPath) {
  const auto e = bad_text(R"({"buses": {"can0": {"type": "virtual"}},
    "gateways": [{"address": 5, "bus": "can0", "slots": [
       {"io": "output", "address": 1, "address": 2, "length": 1}]}]})");
  EXPECT_EQ(e.to_string(),
            "test.json: $.gateways[0].slots[0].address: duplicate key (each key may appear once)");
}

TEST(ConfigErrors, SyntaxErrorNamesLineAndColumn) {
  const auto e = bad_text("{\n  \"buses\": {\n    \"can0\": {\"type\": \"virtual\",}\n  }\n}");
  EXPECT_EQ(e.file, "test.json");
  EXPECT_NE(e.message.find("invalid JSON"), std::string::npos);
  EXPECT_NE(e.message.find("line 3"), std::string::npos) << e.message;
}

TEST(ConfigErrors, NumberBeyondWhatJsonNumbersHold) {
  // Found by config_fuzz: nlohmann reports it as out_of_range, not as a parse error.
  const auto e = bad_text("{\"buses\": 661E76661}");
  EXPECT_EQ(e.file, "test.json");
  EXPECT_NE(e.message.find("invalid JSON"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find("number overflow"), std::string::npos) << e.message;
  const auto big = bad(with_gateway({{"address", "0xFFFFFFFFFFFFFFFFFF"}}));
  EXPECT_EQ(big.json_path, "$.gateways[0].address");
}

TEST(ConfigErrors, Endpoints) {
  json j = base();
  j["modbus"]["listen"] = "localhost:1502";
  auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.modbus.listen");
  EXPECT_NE(e.message.find("numeric IPv4"), std::string::npos);
  j["modbus"]["listen"] = "127.0.0.1:99999";
  EXPECT_NE(bad(j).message.find("0 to 65535"), std::string::npos);
  j["modbus"]["listen"] = "1502";
  EXPECT_NE(bad(j).message.find("HOST:PORT"), std::string::npos);
  j = base();
  j["modbus"]["listen"] = "127.0.0.1:29536";  // the socketcand export's port
  EXPECT_EQ(bad(j).json_path, "$.buses.can0.socketcand");
}

TEST(ConfigErrors, AddressesAndRanges) {
  json j = base();
  j["gateways"].push_back(j["gateways"][0]);
  j["gateways"][1]["name"] = "other";
  auto e = bad(j);
  EXPECT_EQ(e.to_string(),
            "test.json: $.gateways[1].address: DP address 5 is already used by $.gateways[0]");
  e = bad(with_gateway({{"address", 127}}));  // DP addresses 0..126 (127 = broadcast)
  EXPECT_EQ(e.json_path, "$.gateways[0].address");
}

TEST(ConfigErrors, MasterAddressClash) {
  json j = base();
  j["master"]["address"] = 5;
  EXPECT_EQ(bad(j).to_string(),
            "test.json: $.gateways[0].address: DP address 5 is the master's address "
            "($.master.address)");
}

TEST(ConfigErrors, SlotOutsideTheImage) {
  json j = base();
  j["gateways"][0]["slots"][1]["address"] = 8190;
  const auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.gateways[0].slots[1].address");
  EXPECT_NE(e.message.find("8190..8195 lie outside the 8192-byte PLC image"), std::string::npos);
}

TEST(ConfigErrors, FileErrors) {
  auto r = load_daemon("/nonexistent/candp2d.json");
  ASSERT_TRUE(std::holds_alternative<ConfigError>(r));
  EXPECT_EQ(std::get<ConfigError>(r).file, "/nonexistent/candp2d.json");
  EXPECT_NE(std::get<ConfigError>(r).message.find("cannot open"), std::string::npos);
}

// ------------------------------------------------------------------------------ warnings

TEST(ConfigWarnings, WhatTheGatewayWouldRejectIsAWarning) {
  json j = base();
  j["gateways"][0]["slots"][1]["comment"] = "03,09";  // docs/slots.md "Chk_Cfg slots" code 5
  const auto c = ok(j);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_EQ(c.warnings[0].json_path, "$.gateways[0].slots[1]");
  EXPECT_NE(c.warnings[0].message.find("diagnosis 3E 01 05"), std::string::npos)
      << c.warnings[0].message;

  const auto p = ok(with_gateway({{"parameters", {{"canopen", "master"}, {"page_mode", true}}}}));
  ASSERT_FALSE(p.warnings.empty());
  EXPECT_EQ(p.warnings[0].json_path, "$.gateways[0].parameters");
  // docs/dp-slave.md "User parameters": Page-Mode with a CANopen role: byte 9, Page-Mode bit
  // cleared.
  EXPECT_NE(p.warnings[0].message.find("diagnosis 3D 09 04"), std::string::npos)
      << p.warnings[0].message;
}

TEST(ConfigWarnings, OverlappingSlotsAndClampedAddress) {
  json j = base();
  j["gateways"][0]["address"] = 2;  // manual §2.1: counts as 3
  j["gateways"][0]["slots"].push_back(
      {{"io", "input"}, {"address", 175}, {"length", 2}, {"comment", "02,8A,00"}});
  const auto c = ok(j);
  EXPECT_EQ(c.gateways[0].dp_address(), 3);
  ASSERT_EQ(c.warnings.size(), 2u);
  EXPECT_EQ(c.warnings[0].json_path, "$.gateways[0].address");
  EXPECT_EQ(c.warnings[1].json_path, "$.gateways[0].slots[2]");
  EXPECT_NE(c.warnings[1].message.find("I 175..176 overlap $.gateways[0].slots[0]"),
            std::string::npos)
      << c.warnings[1].message;
}

TEST(ConfigWarnings, SameRxIdentifierTwiceLaterWins) {
  json j = base();
  j["gateways"][0]["slots"].push_back(
      {{"io", "input"}, {"address", 200}, {"length", 6}, {"comment", "02,89,00"}});
  const auto c = ok(j);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_EQ(c.warnings[0].json_path, "$.gateways[0].slots[0]");
  EXPECT_NE(c.warnings[0].message.find("later slot wins"), std::string::npos);
}

// docs/validate.md "The watchdog rule" on the ideal line: the master cycle, up to host_stall_ms
// late; shorter than the cycle itself it can never hold and makes the file invalid.
TEST(ConfigWarnings, WatchdogAgainstTheMasterCycle) {
  json j = with_gateway({{"parameters", {{"watchdog_ms", 30}}}});
  j["master"]["cycle_ms"] = 20;
  j["master"]["host_stall_ms"] = 50;
  auto c = ok(j);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_EQ(c.warnings[0].json_path, "$.gateways[0].parameters.watchdog_ms");
  EXPECT_EQ(c.warnings[0].kind, WarningKind::Watchdog);
  EXPECT_NE(c.warnings[0].message.find("(70.00 ms: the master cycle 20.00 ms, up to 50.00 ms "
                                       "late): it will expire; set watchdog_ms to at least 70"),
            std::string::npos);
  j["gateways"][0]["parameters"]["watchdog_ms"] = 70;
  EXPECT_TRUE(ok(j).warnings.empty());
  j["gateways"][0]["parameters"]["watchdog_ms"] = 15;
  c = ok(j);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_EQ(c.warnings[0].kind, WarningKind::Unholdable);
  EXPECT_TRUE(makes_invalid(c.warnings[0].kind));
  // host_stall_ms 0: no guard bounds a late cycle, the rule adds no lateness.
  j["master"]["host_stall_ms"] = 0;
  j["gateways"][0]["parameters"]["watchdog_ms"] = 30;
  EXPECT_EQ(ok(j).warnings.size(), 0u);
}

TEST(Config, HostStallTolerance) {  // docs/daemon.md "Host stalls"
  json j = base();
  j["master"]["host_stall_ms"] = 0;
  EXPECT_EQ(ok(j).host_stall_ms, 0u);
  j["master"]["host_stall_ms"] = 60001;
  EXPECT_EQ(bad(j).json_path, "$.master.host_stall_ms");
}

TEST(ParseGateway, StandaloneForTheReplayRunner) {
  auto r = parse_gateway(base()["gateways"][0], "scenario.json", "$.gateway");
  ASSERT_TRUE(std::holds_alternative<GatewayConfig>(r));
  EXPECT_EQ(std::get<GatewayConfig>(r).json_path, "$.gateway");
  json g = base()["gateways"][0];
  g["slots"][0]["io"] = "in";
  r = parse_gateway(g, "scenario.json", "$.gateway");
  ASSERT_TRUE(std::holds_alternative<ConfigError>(r));
  EXPECT_EQ(std::get<ConfigError>(r).to_string(),
            "scenario.json: $.gateway.slots[0].io: expected one of \"input\", \"output\", got the "
            "string \"in\"");
}

TEST(ParseHex, Forms) {
  std::string error;
  EXPECT_EQ(hex(*parse_hex("88 80,c4", &error)), "88 80 C4");
  EXPECT_EQ(hex(*parse_hex("8880C4", &error)), "88 80 C4");
  EXPECT_FALSE(parse_hex("888", &error));
  EXPECT_FALSE(parse_hex("", &error));
  EXPECT_EQ(error, "no bytes given");
  EXPECT_FALSE(parse_hex("0x12", &error));
}

// ------------------------------------------------------------------- profibus (docs/profibus.md)

json with_profibus(const json& profibus) {
  json j = base();
  j["profibus"] = profibus;
  return j;
}

// role master: remote gateway 3 with the manual §5.1.4 slots, no bus.
json remote_master() {
  return json::parse(R"({
    "modbus": {"listen": "127.0.0.1:1502"},
    "profibus": {"port": "/dev/null", "baud": 19200, "role": "master"},
    "gateways": [{
      "address": 3,
      "slots": [
        {"io": "input",  "address": 172, "length": 6, "comment": "02,89,B8"},
        {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"}
      ]
    }]
  })");
}

TEST(ConfigProfibus, AbsentMeansInProcess) {
  EXPECT_FALSE(ok(base()).profibus);
}

TEST(ConfigProfibus, RoleSlavesOnAPtyWithDefaults) {
  const auto c = ok(with_profibus({{"port", "pty:/tmp/pb"}, {"baud", 19200}, {"role", "slaves"}}));
  ASSERT_TRUE(c.profibus);
  EXPECT_EQ(c.profibus->port, "pty:/tmp/pb");
  EXPECT_EQ(c.profibus->baud, 19200u);
  EXPECT_EQ(c.profibus->role, ProfibusRole::Slaves);
  EXPECT_FALSE(c.profibus->master_address);
  // docs/profibus.md "Bus parameters": the DP default profile of the rate (19200: min_TSDR 11,
  // slot time 100, retry limit 1).
  EXPECT_EQ(c.profibus->bus, *fdl::default_bus_parameters(19200));
  EXPECT_EQ(c.profibus->bus.min_tsdr_bits, 11u);
  EXPECT_EQ(c.profibus->bus.slot_time_bits, 100u);
  EXPECT_EQ(c.profibus->bus.retry_limit, 1u);
  EXPECT_FALSE(c.profibus->rs485);
  EXPECT_FALSE(c.profibus->echo);
  EXPECT_FALSE(c.remote_gateways());
}

TEST(ConfigProfibus, EveryOptionalKey) {
  const auto c = ok(with_profibus({{"port", "/dev/null"},
                                   {"baud", 93750},
                                   {"role", "slaves"},
                                   {"master_address", 2},
                                   {"slot_time_bits", 300},
                                   {"retries", 3},
                                   {"min_tsdr_bits", 22},
                                   {"rs485", true},
                                   {"echo", true}}));
  ASSERT_TRUE(c.profibus);
  EXPECT_EQ(c.profibus->baud, 93750u);
  EXPECT_EQ(c.profibus->master_address, 2);
  EXPECT_EQ(c.profibus->bus.slot_time_bits, 300u);
  EXPECT_EQ(c.profibus->bus.retry_limit, 3u);
  EXPECT_EQ(c.profibus->bus.min_tsdr_bits, 22u);
  EXPECT_TRUE(c.profibus->rs485);
  EXPECT_TRUE(c.profibus->echo);
}

TEST(ConfigProfibus, PtyPathRelativeToTheConfigFile) {
  auto r =
      parse_daemon(with_profibus({{"port", "pty:pb"}, {"baud", 19200}, {"role", "slaves"}}).dump(),
                   "/tmp/x.json");
  ASSERT_TRUE(std::holds_alternative<DaemonConfig>(r)) << std::get<ConfigError>(r).to_string();
  EXPECT_EQ(std::get<DaemonConfig>(r).profibus->port, "pty:/tmp/pb");
}

TEST(ConfigProfibus, RoleMasterRemoteGatewaysWithoutBuses) {
  auto j = remote_master();
  j["gateways"][0]["prm_hex"] = "88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF";
  j["gateways"][0]["slots"][1] = {{"cfg_hex", "83 85 03 09 B8"}, {"address", 172}};
  const auto c = ok(j);
  ASSERT_TRUE(c.profibus);
  EXPECT_TRUE(c.remote_gateways());
  EXPECT_TRUE(c.buses.empty());
  ASSERT_EQ(c.gateways.size(), 1u);
  EXPECT_TRUE(c.gateways[0].bus.empty());
  // What the master sends over FDL: the prm_hex and cfg_hex bytes as given (docs/profibus.md).
  EXPECT_EQ(hex(set_prm_bytes(c.gateways[0])), "88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF");
  EXPECT_EQ(hex(chk_cfg_bytes(c.gateways[0])), "43 85 02 89 B8 83 85 03 09 B8");
}

TEST(ConfigProfibusErrors, UnknownDevice) {
  const auto e = bad(
      with_profibus({{"port", "/dev/candp2-no-such-tty"}, {"baud", 19200}, {"role", "slaves"}}));
  EXPECT_EQ(e.file, "test.json");
  EXPECT_EQ(e.json_path, "$.profibus.port");
  EXPECT_NE(e.message.find("unknown device \"/dev/candp2-no-such-tty\""), std::string::npos)
      << e.message;
  EXPECT_NE(e.message.find("does not exist"), std::string::npos) << e.message;
}

TEST(ConfigProfibusErrors, PtyLinkDirectoryMissingOrPathEmpty) {
  auto e = bad(
      with_profibus({{"port", "pty:/candp2-no-such-dir/pb"}, {"baud", 19200}, {"role", "slaves"}}));
  EXPECT_EQ(e.json_path, "$.profibus.port");
  EXPECT_NE(e.message.find("/candp2-no-such-dir"), std::string::npos) << e.message;
  e = bad(with_profibus({{"port", "pty:"}, {"baud", 19200}, {"role", "slaves"}}));
  EXPECT_EQ(e.json_path, "$.profibus.port");
  EXPECT_NE(e.message.find("pty:PATH"), std::string::npos) << e.message;
}

TEST(ConfigProfibusErrors, BaudNotSupportedListsTheAllowedOnes) {
  const auto e =
      bad(with_profibus({{"port", "pty:/tmp/pb"}, {"baud", 115200}, {"role", "slaves"}}));
  EXPECT_EQ(e.json_path, "$.profibus.baud");
  EXPECT_NE(e.message.find("115200 is not supported"), std::string::npos) << e.message;
  // docs/profibus.md rates, including the non-standard ones.
  for (const char* b : {"9600", "19200", "45450", "93750", "187500", "500000", "1500000"})
    EXPECT_NE(e.message.find(b), std::string::npos) << b << " in " << e.message;
  const auto missing = bad(with_profibus({{"port", "pty:/tmp/pb"}, {"role", "slaves"}}));
  EXPECT_EQ(missing.json_path, "$.profibus");
  EXPECT_NE(missing.message.find("baud"), std::string::npos) << missing.message;
}

TEST(ConfigProfibusErrors, Role) {
  auto e = bad(with_profibus({{"port", "pty:/tmp/pb"}, {"baud", 19200}}));
  EXPECT_EQ(e.json_path, "$.profibus");
  EXPECT_NE(e.message.find("\"role\""), std::string::npos) << e.message;
  e = bad(with_profibus({{"port", "pty:/tmp/pb"}, {"baud", 19200}, {"role", "slave"}}));
  EXPECT_EQ(e.json_path, "$.profibus.role");
  EXPECT_NE(e.message.find("\"slaves\""), std::string::npos) << e.message;
  EXPECT_NE(e.message.find("\"master\""), std::string::npos) << e.message;
}

TEST(ConfigProfibusErrors, RoleMasterGatewayWithABus) {
  auto j = remote_master();
  j["buses"] = {{"can0", {{"type", "virtual"}}}};
  j["gateways"][0]["bus"] = "can0";
  const auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.gateways[0].bus");
  EXPECT_NE(e.message.find("remote stations"), std::string::npos) << e.message;
}

TEST(ConfigProfibusErrors, RoleSlavesStillNeedsBuses) {
  auto j = remote_master();
  j["profibus"]["role"] = "slaves";
  const auto e = bad(j);
  EXPECT_EQ(e.json_path, "$");
  EXPECT_NE(e.message.find("buses"), std::string::npos) << e.message;
}

TEST(ConfigProfibusErrors, MasterAddress) {
  auto e = bad(with_profibus(
      {{"port", "pty:/tmp/pb"}, {"baud", 19200}, {"role", "slaves"}, {"master_address", 126}}));
  EXPECT_EQ(e.json_path, "$.profibus.master_address");
  auto j = remote_master();
  j["profibus"]["master_address"] = 2;
  e = bad(j);
  EXPECT_EQ(e.json_path, "$.profibus.master_address");
  EXPECT_NE(e.message.find("$.master.address"), std::string::npos) << e.message;
  e = bad(with_profibus(
      {{"port", "pty:/tmp/pb"}, {"baud", 19200}, {"role", "slaves"}, {"master_address", 5}}));
  EXPECT_EQ(e.json_path, "$.gateways[0].address");
  EXPECT_NE(e.message.find("$.profibus.master_address"), std::string::npos) << e.message;
}

// docs/profibus.md "Bus parameters": one rule set and one text for the serial line ($.profibus)
// and the line in time ($.master.bus_parameters); the path names the key as given.
TEST(ConfigBusParameters, OneBadParameterOneTextOnEitherLine) {
  auto serial = [](const char* key, json v) {
    json p = {{"port", "pty:/tmp/pb"}, {"baud", 19200}, {"role", "slaves"}};
    p[key] = v;
    return bad(with_profibus(p));
  };
  auto in_time = [](const char* key, json v) {
    json j = base();
    j["master"]["baud"] = 19200;
    j["master"]["bus_parameters"] = {{key, v}};
    return bad(j);
  };
  // Slot time below max_TSDR (60 at 19200) + 15.
  auto a = serial("slot_time_bits", 74), b = in_time("slot_time_bits", 74);
  EXPECT_EQ(a.json_path, "$.profibus.slot_time_bits");
  EXPECT_EQ(b.json_path, "$.master.bus_parameters.slot_time_bits");
  EXPECT_EQ(a.message, b.message);
  EXPECT_NE(a.message.find("slot time 74 bit times: expected max_tsdr_bits + 15 (75) .. 16383"),
            std::string::npos)
      << a.message;
  // The retry limit: "retries" on the serial line, "retry_limit" in bus_parameters; 0 is refused
  // with what to write instead.
  a = serial("retries", 0), b = in_time("retry_limit", 0);
  EXPECT_EQ(a.json_path, "$.profibus.retries");
  EXPECT_EQ(b.json_path, "$.master.bus_parameters.retry_limit");
  EXPECT_EQ(a.message, b.message);
  EXPECT_NE(a.message.find("retry limit 0: expected 1 .. 15"), std::string::npos) << a.message;
  EXPECT_NE(a.message.find("write 1"), std::string::npos) << a.message;
  a = serial("min_tsdr_bits", 61), b = in_time("min_tsdr_bits", 61);
  EXPECT_EQ(a.json_path, "$.profibus.min_tsdr_bits");
  EXPECT_EQ(b.json_path, "$.master.bus_parameters.min_tsdr_bits");
  EXPECT_EQ(a.message, b.message);
  EXPECT_NE(a.message.find("expected 11 .. max_tsdr_bits (60)"), std::string::npos) << a.message;
}

// Role master: $.profibus and $.master.bus_parameters set one line's parameters, checked together;
// each rate's defaults load (12 Mbit/s: slot time 1000 over max_TSDR 800).
TEST(ConfigBusParameters, RoleMasterOneLineFromBothSections) {
  auto j = remote_master();
  j["profibus"]["baud"] = 12000000;
  auto c = ok(j);
  EXPECT_EQ(c.profibus->bus, *fdl::default_bus_parameters(12000000));
  j["profibus"]["baud"] = 19200;
  j["profibus"]["slot_time_bits"] = 300;
  j["master"]["bus_parameters"] = {{"max_tsdr_bits", 250}, {"retry_limit", 2}};
  c = ok(j);
  EXPECT_EQ(c.profibus->bus.slot_time_bits, 300u);
  EXPECT_EQ(c.profibus->bus.max_tsdr_bits, 250u);
  EXPECT_EQ(c.profibus->bus.retry_limit, 2u);
  EXPECT_FALSE(c.line);                                  // the line is the serial one
  j["master"]["bus_parameters"]["max_tsdr_bits"] = 290;  // 290 + 15 > 300
  auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.profibus.slot_time_bits");
  EXPECT_NE(e.message.find("expected max_tsdr_bits + 15 (305)"), std::string::npos) << e.message;
  j["master"]["bus_parameters"]["slot_time_bits"] = 400;
  EXPECT_EQ(bad(j).json_path, "$.master.bus_parameters.slot_time_bits");  // given twice
  j["profibus"].erase("slot_time_bits");
  j["master"]["bus_parameters"] = {{"max_tsdr_bits", 400}};  // the default slot time 100
  EXPECT_EQ(bad(j).json_path, "$.master.bus_parameters");
  // min_TSDR travels in Set_Prm byte 3: at most 255 even where max_TSDR is higher.
  auto s = with_profibus({{"port", "pty:/tmp/pb"}, {"baud", 12000000}, {"role", "slaves"}});
  s["profibus"]["min_tsdr_bits"] = 256;
  e = bad(s);
  EXPECT_EQ(e.json_path, "$.profibus.min_tsdr_bits");
  EXPECT_NE(e.message.find("11 .. 255 (Set_Prm byte 3)"), std::string::npos) << e.message;
}

TEST(ConfigProfibusErrors, TimingRangesAndUnknownKeys) {
  json p = {{"port", "pty:/tmp/pb"}, {"baud", 19200}, {"role", "slaves"}};
  auto with = [&](const char* key, json v) {
    json q = p;
    q[key] = v;
    return bad(with_profibus(q));
  };
  EXPECT_EQ(with("slot_time_bits", 36).json_path, "$.profibus.slot_time_bits");
  EXPECT_EQ(with("slot_time_bits", 16384).json_path, "$.profibus.slot_time_bits");
  EXPECT_EQ(with("retries", 16).json_path, "$.profibus.retries");
  EXPECT_EQ(with("min_tsdr_bits", 10).json_path, "$.profibus.min_tsdr_bits");
  EXPECT_EQ(with("rs485", "yes").json_path, "$.profibus.rs485");
  const auto e = with("bauds", 19200);
  EXPECT_NE(e.to_string().find("bauds"), std::string::npos) << e.to_string();
  EXPECT_EQ(bad(with_profibus("pty:/tmp/pb")).json_path, "$.profibus");
}

}  // namespace
}  // namespace candp2::config

// ------------------------------------------------------------------- the line in time

namespace candp2::config {
namespace {

// docs/profibus.md "The line in time", docs/configuration.md "master".
TEST(ConfigLine, BaudAndBusParameters) {
  EXPECT_FALSE(ok(base()).line);  // no baud: the ideal line
  json j = base();
  j["master"]["baud"] = 1500000;
  auto c = ok(j);
  ASSERT_TRUE(c.line);
  EXPECT_EQ(c.line->baud, 1500000u);
  EXPECT_EQ(c.line->params, *fdl::default_bus_parameters(1500000));
  j["master"]["bus_parameters"] = {{"slot_time_bits", 400}, {"retry_limit", 3}};
  c = ok(j);
  EXPECT_EQ(c.line->params.slot_time_bits, 400u);
  EXPECT_EQ(c.line->params.retry_limit, 3u);
  EXPECT_EQ(c.line->params.max_tsdr_bits, 150u);  // the rest: the rate's defaults
}

TEST(ConfigLine, ErrorsNameTheFileAndPath) {
  json j = base();
  j["master"]["baud"] = 115200;
  auto e = bad(j);
  EXPECT_EQ(e.json_path, "$.master.baud");
  EXPECT_NE(e.message.find("9600, 19200, 45450"), std::string::npos) << e.message;
  j["master"]["baud"] = 12000000;
  j["master"]["bus_parameters"] = {{"slot_time_bits", 814}};  // max_TSDR 800 + 15 > 814
  e = bad(j);
  EXPECT_EQ(e.file, "test.json");
  EXPECT_EQ(e.json_path, "$.master.bus_parameters.slot_time_bits");
  j["master"]["bus_parameters"] = {{"tset_bits", 400}};  // 35 + 800 > max_TSDR 800 (a default)
  e = bad(j);
  EXPECT_EQ(e.json_path, "$.master.bus_parameters");  // the broken rule's key was not given
  EXPECT_NE(e.message.find("max_TSDR 800"), std::string::npos) << e.message;
  j["master"]["bus_parameters"] = {{"gap_factor", 0}};
  EXPECT_EQ(bad(j).json_path, "$.master.bus_parameters.gap_factor");
  j["master"]["bus_parameters"] = {{"slot", 1}};
  EXPECT_EQ(bad(j).json_path, "$.master.bus_parameters.slot");
  j = base();
  j["master"]["bus_parameters"] = {{"retry_limit", 2}};  // no baud: no line to set up
  EXPECT_EQ(bad(j).json_path, "$.master.bus_parameters");
}

}  // namespace
}  // namespace candp2::config

// `candp2d --print-modbus-map --json` (modbus/map_json.hpp): the JSON carries exactly the numbers
// the server uses, and the status block's fields tile the block without gaps or overlaps.
#include "modbus/map_json.hpp"

#include <gtest/gtest.h>

#include <set>

#include "faults/can_fault.hpp"
#include "faults/drive_fault.hpp"
#include "gateway/gateway.hpp"
#include "modbus/modbus_map.hpp"

namespace candp2::modbus {
namespace {

// The manual §5.1.4 slots on gateway 5 and a drive with fault registers on unit 20.
config::DaemonConfig manual_514() {
  const auto r = config::parse_daemon(R"({
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [
      {"name": "gw5", "address": 5, "bus": "can0", "slots": [
        {"io": "input", "address": 172, "length": 6, "comment": "02,89,B8"},
        {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"}]},
      {"name": "gw7", "address": 7, "bus": "can0", "slots": [
        {"io": "output", "address": 3, "length": 2, "comment": "02,01,00"}]}],
    "drives": [{"name": "axis1", "bus": "can0", "modbus_unit": 20},
               {"name": "axis2", "bus": "can0", "rx_id": "0x202", "tx_id": "0x182"}]
  })",
                                      "test.json");
  return std::get<config::DaemonConfig>(r);
}

TEST(MapJson, StatusFieldsTileTheBlock) {
  const auto j = map_json(manual_514());
  const auto& s = j["status"];
  EXPECT_EQ(s["table"], "input_registers");
  EXPECT_EQ(s["first"], kStatusBase);
  EXPECT_EQ(s["count"], status::kCount);
  std::set<unsigned> covered;
  for (const auto& f : s["fields"]) {
    const unsigned first = f["register"], n = f["registers"];
    EXPECT_EQ(first, kStatusBase + f["offset"].get<unsigned>());
    for (unsigned r = first; r < first + n; ++r)
      EXPECT_TRUE(covered.insert(r).second) << "register " << r << " twice (" << f["name"] << ")";
  }
  EXPECT_EQ(covered.size(), status::kCount);
  EXPECT_EQ(*covered.begin(), kStatusBase);
  EXPECT_EQ(*covered.rbegin(), kStatusBase + status::kCount - 1);
  EXPECT_EQ(s["fields"].size(), status_fields().size());
}

TEST(MapJson, NamedFieldsAreTheServersOffsets) {
  const auto j = map_json(manual_514());
  auto field = [&](const char* name) {
    for (const auto& f : j["status"]["fields"])
      if (f["name"] == name) return f;
    ADD_FAILURE() << "no field " << name;
    return nlohmann::ordered_json{};
  };
  EXPECT_EQ(field("dp_state")["register"], kStatusBase + status::kDpState);
  EXPECT_EQ(field("diag")["registers"], dp::DpSlave::kDiagLen);
  EXPECT_EQ(field("tx_frames")["register"], kStatusBase + status::kTxFrames);
  EXPECT_EQ(field("tx_frames")["registers"], 2);
  EXPECT_EQ(field("led_c")["register"], kStatusBase + status::kLedC);
  EXPECT_EQ(field("forced_can_state")["register"], kStatusBase + status::kForcedState);
}

TEST(MapJson, ControlFaultAndDriveRegisters) {
  const auto j = map_json(manual_514());
  EXPECT_EQ(j["format"], "candp2-modbus-map");
  EXPECT_EQ(j["version"], 1);
  EXPECT_EQ(j["control"]["register"], kControlRegister);
  for (const auto& c : control_commands()) {
    bool found = false;
    for (const auto& e : j["control"]["commands"])
      if (e["name"] == c.name) found = e["value"] == static_cast<unsigned>(c.command);
    EXPECT_TRUE(found) << c.name;
  }
  const auto& forced = j["faults"]["forced_can_state"];
  EXPECT_EQ(forced["register"], kForcedStateRegister);
  ASSERT_EQ(forced["values"].size(), faults::kForceMax + 1u);
  EXPECT_EQ(forced["values"][0]["name"], "real");
  EXPECT_EQ(forced["values"][faults::kForceMax]["name"], "bus-off");
  EXPECT_EQ(j["faults"]["drop_rx"]["register"], kDropRxRegister);
  const auto& drive = j["drive_faults"]["registers"];
  EXPECT_EQ(drive[0]["name"], "mute");
  EXPECT_EQ(drive[0]["register"], faults::kDriveMute);
  EXPECT_EQ(drive[3]["name"], "restart");
  EXPECT_EQ(drive[3]["register"], faults::kDriveRestart);
  EXPECT_EQ(j["image"]["outputs"]["count"], kImageRegisters);
  EXPECT_EQ(j["image"]["input_bits"]["count"], kImageBits);
  EXPECT_EQ(j["exceptions"].size(), 5u);
  EXPECT_EQ(j["exceptions"][4]["code"], static_cast<int>(Exception::GatewayTargetFailed));
}

TEST(MapJson, GatewaysSlotsAndDrivesOfTheConfiguration) {
  const auto j = map_json(manual_514());
  ASSERT_EQ(j["gateways"].size(), 2u);
  const auto& g = j["gateways"][0];
  EXPECT_EQ(g["name"], "gw5");
  EXPECT_EQ(g["units"], nlohmann::ordered_json::array({5, 0, 255}));
  EXPECT_EQ(j["gateways"][1]["units"], nlohmann::ordered_json::array({7}));
  ASSERT_EQ(g["slots"].size(), 2u);
  // manual §5.1.4: I/Q 172..177 = registers 86..88, bits 1376..1423.
  const auto& in = g["slots"][0];
  EXPECT_EQ(in["io"], "input");
  EXPECT_EQ(in["address"], 172);
  EXPECT_EQ(in["length"], 6);
  EXPECT_EQ(in["comment"], "02,89,B8");
  EXPECT_EQ(in["registers"]["table"], "input_registers");
  EXPECT_EQ(in["registers"]["first"], 86);
  EXPECT_EQ(in["registers"]["last"], 88);
  EXPECT_EQ(in["bits"]["first"], 1376);
  EXPECT_EQ(in["bits"]["last"], 1423);
  EXPECT_EQ(g["slots"][1]["registers"]["table"], "holding_registers");
  // An odd start shares its first register with the byte before it: Q 3..4 = registers 1..2.
  const auto& odd = j["gateways"][1]["slots"][0];
  EXPECT_EQ(odd["registers"]["first"], 1);
  EXPECT_EQ(odd["registers"]["last"], 2);
  ASSERT_EQ(j["drives"].size(), 2u);
  EXPECT_EQ(j["drives"][0]["unit"], 20);
  EXPECT_TRUE(j["drives"][1]["unit"].is_null());
  EXPECT_EQ(j["drives"][1]["rx_id"], 0x202);
}

TEST(MapJson, DiagnosisLayoutAndValueNames) {
  const auto j = map_json(manual_514());
  const auto& d = j["diagnosis"];
  EXPECT_EQ(d["length"], dp::DpSlave::kDiagLen);
  EXPECT_EQ(d["ext"]["can_state_mask"], gw::kBusStateMask);
  EXPECT_EQ(d["ext"]["can_states"][3]["name"], "bus-off");
  EXPECT_EQ(d["ext"]["can_states"][3]["code"], gw::bus_state_code(can::BusState::BusOff));
  EXPECT_EQ(d["ext"]["cfg_fault"]["marker"], dp::kExtDiagCfgSap);
  bool ext_diag = false;
  for (const auto& b : d["bits"])
    if (b["name"] == "Ext_Diag") ext_diag = b["byte"] == 0 && b["mask"] == dp::kDiag1ExtDiag;
  EXPECT_TRUE(ext_diag);
  EXPECT_EQ(j["values"]["dp_state"][static_cast<int>(dp::SlaveState::DataExch)], "Data_Exch");
  EXPECT_EQ(j["values"]["bus_state"][static_cast<int>(can::BusState::BusOff)], "bus-off");
  EXPECT_EQ(j["leds"]["morse"]["O"], led::kMorseO);
  // The text form parses back to the same document.
  EXPECT_EQ(nlohmann::ordered_json::parse(map_json_text(manual_514())), j);
}

TEST(MapJson, GenericSlavesTheirFaultsFieldSideAndWholeDiagnosis) {
  // config/plc-line.json's io1: 8 DI, 8 DO, 2 AI from the example GSD (docs/slaves.md).
  const auto r = config::parse_daemon(R"({
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [{"name": "gw3", "address": 3, "bus": "can0", "slots": [
        {"io": "output", "address": 0, "length": 2, "comment": "02,01,00"}]}],
    "slaves": [{"name": "io1", "address": 8, "gsd": ")" CANDP2_SOURCE_DIR
                                      R"(/gsd/examples/CDP20C2D.GSD",
                "modules": ["8 DI", "8 DO", "2 AI"], "field_unit": 108,
                "input_address": 100, "output_address": 100}]
  })",
                                      "test.json");
  ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(r));
  const auto j = map_json(std::get<config::DaemonConfig>(r));
  ASSERT_EQ(j["slaves"].size(), 1u);
  const auto& s = j["slaves"][0];
  EXPECT_EQ(s["name"], "io1");
  EXPECT_EQ(s["dp_address"], 8);
  EXPECT_EQ(s["field_unit"], 108);
  EXPECT_EQ(s["input_bytes"], 5);  // 8 DI + 2 AI
  EXPECT_EQ(s["output_bytes"], 1);
  EXPECT_EQ(s["inputs"][1]["address"], 101);
  EXPECT_EQ(s["inputs"][1]["length"], 4);
  const auto& f = j["slave_faults"]["registers"];
  ASSERT_EQ(f.size(), 5u);
  EXPECT_EQ(f[0]["name"], "on_bus");
  EXPECT_EQ(f[0]["register"], kSlaveFaultBase + kSlaveOnBus);
  EXPECT_EQ(f[3]["name"], "alarm_length");
  EXPECT_EQ(f[3]["register"], kSlaveFaultBase + kSlaveAlarmLength);
  EXPECT_EQ(f[4]["register"], kSlaveFaultBase + kSlaveAlarmBytes);
  EXPECT_EQ(f[4]["count"], kSlaveAlarmMax / 2);
  EXPECT_EQ(j["field"]["inputs"]["table"], "holding_registers");
  EXPECT_EQ(j["field"]["outputs"]["table"], "input_registers");
  const auto& d = j["diagnosis_bytes"];
  EXPECT_EQ(d["table"], "input_registers");
  EXPECT_EQ(d["length_register"], kDiagnosisBase);
  EXPECT_EQ(d["first"], kDiagnosisBase + 1);
  EXPECT_EQ(d["count"].get<unsigned>() * 2, dp::kDiagMaxLen);
}

}  // namespace
}  // namespace candp2::modbus

#include "modbus/map_json.hpp"

#include <cstdio>

#include "faults/can_fault.hpp"
#include "faults/drive_fault.hpp"
#include "gateway/gateway.hpp"
#include "modbus/modbus_map.hpp"
#include "plant/can_fault.hpp"
#include "profibus_sim/dp/dp_slave.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::modbus {

namespace {

using json = nlohmann::ordered_json;

// The format name and version of the document; a change of meaning raises the version.
constexpr const char* kFormat = "candp2-modbus-map";
constexpr int kVersion = 1;

// Table names as the JSON spells them (snake case of to_string(Table)).
std::string table_name(Table t) {
  std::string s(to_string(t));
  for (auto& c : s)
    if (c == ' ') c = '_';
  return s;
}

json range(Table t, std::uint32_t first, std::uint32_t count) {
  return {{"table", table_name(t)}, {"first", first}, {"count", count}};
}

json image_json() {
  return {
      {"bytes", dp::kImageSize},
      {"outputs", range(Table::HoldingRegisters, 0, kImageRegisters)},
      {"inputs", range(Table::InputRegisters, 0, kImageRegisters)},
      {"output_bits", range(Table::Coils, 0, kImageBits)},
      {"input_bits", range(Table::DiscreteInputs, 0, kImageBits)},
      {"packing",
       "register r = image bytes 2r (high) and 2r+1 (low); bit b = byte b/8, bit b%8 (bit 0 = "
       "least significant)"},
      // MB spec §6 quantity limits, which a client splits its requests by.
      {"limits",
       {{"read_registers", kMaxReadRegisters},
        {"write_registers", kMaxWriteRegisters},
        {"read_bits", kMaxReadBits},
        {"write_bits", kMaxWriteBits}}},
  };
}

json status_json() {
  json fields = json::array();
  for (const auto& f : status_fields())
    fields.push_back({{"name", f.name},
                      {"offset", f.offset},
                      {"register", kStatusBase + f.offset},
                      {"registers", f.registers},
                      {"meaning", f.meaning}});
  json j = range(Table::InputRegisters, kStatusBase, status::kCount);
  j["words"] = "a field of 2 registers is a 32-bit value, high word first";
  j["fields"] = std::move(fields);
  return j;
}

json control_json() {
  json commands = json::array();
  for (const auto& c : control_commands())
    commands.push_back({{"name", c.name},
                        {"value", static_cast<std::uint16_t>(c.command)},
                        {"meaning", c.meaning}});
  return {{"table", table_name(Table::HoldingRegisters)},
          {"register", kControlRegister},
          {"commands", std::move(commands)}};
}

json faults_json() {
  // faults/can_fault.hpp: 0 = the real state, 1..kForceMax = the BusState of that number.
  json states = json::array();
  states.push_back({{"name", "real"}, {"value", faults::kForceReal}});
  for (std::uint16_t v = faults::kForceReal + 1; v <= faults::kForceMax; ++v)
    states.push_back({{"name", can::to_string(static_cast<can::BusState>(v))}, {"value", v}});
  return {
      {"table", table_name(Table::HoldingRegisters)},
      {"forced_can_state", {{"register", kForcedStateRegister}, {"values", std::move(states)}}},
      {"drop_rx",
       {{"register", kDropRxRegister},
        {"meaning", "drop the next N frames the gateway would receive (IRQ_LOST); 0 cancels"}}},
  };
}

json drive_faults_json() {
  return {
      {"table", table_name(Table::HoldingRegisters)},
      {"unit", "the drive's modbus_unit"},
      {"registers",
       {{{"name", "mute"},
         {"register", faults::kDriveMute},
         {"meaning", "1 = the drive stops answering, 0 = it answers again"}},
        {{"name", "error_bits"},
         {"register", faults::kDriveErrorBits},
         {"meaning", "ERR_BITMAP1 (REGID 0x8F) bits 0..15"}},
        {{"name", "warning_bits"},
         {"register", faults::kDriveWarningBits},
         {"meaning", "ERR_BITMAP1 (REGID 0x8F) bits 16..31"}},
        {{"name", "restart"},
         {"register", faults::kDriveRestart},
         {"meaning", "write 1: the drive restarts (power-on state)"}}}},
  };
}

// A generic slave's fault registers and field side (docs/faults.md "Generic slaves",
// docs/slaves.md "Modbus").
json slave_faults_json() {
  return {
      {"table", table_name(Table::HoldingRegisters)},
      {"unit", "the slave's DP address"},
      {"registers",
       {{{"name", "on_bus"},
         {"register", kSlaveFaultBase + kSlaveOnBus},
         {"meaning", "1 = the slave answers, 0 = it has left the bus (no answer at all)"}},
        {{"name", "prm_fault"},
         {"register", kSlaveFaultBase + kSlavePrmFault},
         {"meaning", "1 = every Set_Prm is refused (Prm_Fault), 0 = accepted again"}},
        {{"name", "cfg_fault"},
         {"register", kSlaveFaultBase + kSlaveCfgFault},
         {"meaning", "1 = every Chk_Cfg is refused (Cfg_Fault), 0 = accepted again"}},
        {{"name", "alarm_length"},
         {"register", kSlaveFaultBase + kSlaveAlarmLength},
         {"meaning",
          "diagnosis alarm: number of device-related bytes (0 clears); writing it "
          "applies the bytes in alarm_bytes"}},
        {{"name", "alarm_bytes"},
         {"register", kSlaveFaultBase + kSlaveAlarmBytes},
         {"count", kSlaveAlarmMax / 2},
         {"meaning", "the alarm's bytes, two per register, high byte first"}}}},
  };
}

json field_json() {
  return {{"unit", "the slave's field_unit"},
          {"inputs",
           {{"table", table_name(Table::HoldingRegisters)},
            {"meaning", "the inputs the slave reports: register r = input bytes 2r, 2r+1"}}},
          {"outputs",
           {{"table", table_name(Table::InputRegisters)},
            {"meaning", "the outputs the slave applies: register r = output bytes 2r, 2r+1"}}}};
}

// A station's whole Slave_Diag answer after the status block (docs/modbus.md "Whole diagnosis").
json diagnosis_bytes_json() {
  return {{"table", table_name(Table::InputRegisters)},
          {"unit", "the station's DP address"},
          {"length_register", kDiagnosisBase},
          {"first", kDiagnosisBase + 1},
          {"count", kDiagnosisRegisters - 1},
          {"meaning",
           "the whole Slave_Diag answer: its length n in length_register, then byte 2i (high) "
           "and 2i+1 (low) in register first + i"}};
}

// docs/modbus.md "Line block": the analyser's counters (fdl::kStationCounters), the live state,
// the bus cycle, and the line fault registers; null without line statistics.
json line_json(const config::DaemonConfig& config) {
  if (!has_line_block(config)) return nullptr;
  json fields = json::array();
  std::uint16_t at = line::kCounters;
  for (const auto& f : fdl::kStationCounters) {
    fields.push_back(
        {{"name", f.name}, {"register", kLineBase + at}, {"registers", 2}, {"meaning", f.meaning}});
    at = static_cast<std::uint16_t>(at + 2);
  }
  json live = json::array();
  for (auto l : {fdl::Live::None, fdl::Live::Ok, fdl::Live::Missing, fdl::Live::Phantom})
    live.push_back(fdl::to_string(l));
  json cycle = json::array();
  std::uint16_t c = line::kBusCycle;
  for (const char* n : {"bus_cycle_last_us", "bus_cycle_min_us", "bus_cycle_mean_us",
                        "bus_cycle_max_us", "bus_cycles"}) {
    cycle.push_back({{"name", n}, {"register", kLineBase + c}, {"registers", 2}});
    c = static_cast<std::uint16_t>(c + 2);
  }
  json kinds = json::array();
  for (std::size_t k = 0; k < fdl::kStationFaultNames.size(); ++k)
    kinds.push_back({{"name", fdl::kStationFaultNames[k]}, {"value", k}});
  json registers = json::array();
  for (const auto& [name, offset] : {std::pair{"kind", line::kFaultKind},
                                     {"count", line::kFaultCount},
                                     {"every", line::kFaultEvery},
                                     {"for_ms", line::kFaultForMs},
                                     {"noise_for_ms", line::kNoiseForMs}})
    registers.push_back({{"name", name}, {"register", kLineBase + offset}});
  return {{"table", table_name(Table::InputRegisters)},
          {"unit", "the station's DP address"},
          {"first", kLineBase},
          {"count", line::kCount},
          {"counters", std::move(fields)},
          {"live", {{"register", kLineBase + line::kLive}, {"values", std::move(live)}}},
          {"bus_cycle", std::move(cycle)},
          {"faults",
           {{"table", table_name(Table::HoldingRegisters)},
            {"registers", std::move(registers)},
            {"kinds", std::move(kinds)}}}};
}

// docs/modbus.md "CAN fault block": the registers (kCanFaultFields), the kinds by their code
// (plant::CanFaultKind) and the units that have the block (the gateways on a bus in time).
json can_faults_json(const config::DaemonConfig& config) {
  json registers = json::array();
  for (std::size_t i = 0; i < kCanFaultFields.size(); ++i)
    registers.push_back({{"name", kCanFaultFields[i].name},
                         {"register", kCanFaultBase + i},
                         {"meaning", kCanFaultFields[i].meaning}});
  json kinds = json::array();
  for (std::size_t k = 0; k < plant::kCanFaultNames.size(); ++k)
    kinds.push_back({{"name", plant::kCanFaultNames[k]}, {"value", k}});
  json units = json::array();
  for (const auto& g : config.gateways)
    for (const auto& b : config.buses)
      if (b.name == g.bus && b.timed_bitrate) units.push_back(g.dp_address());
  return {{"table", table_name(Table::HoldingRegisters)},
          {"unit", "the DP address of a gateway on a bus in time"},
          {"units", std::move(units)},
          {"first", kCanFaultBase},
          {"count", can_fault::kRegisters},
          {"registers", std::move(registers)},
          {"kinds", std::move(kinds)}};
}

// docs/modbus.md "Host block": the host stalls, in every unit.
json host_json() {
  json fields = json::array();
  for (std::size_t i = 0; i < kHostFields.size(); ++i)
    fields.push_back({{"name", kHostFields[i].name},
                      {"register", kHostBase + 2 * i},
                      {"registers", 2},
                      {"meaning", kHostFields[i].meaning}});
  return {{"table", table_name(Table::InputRegisters)},
          {"unit", "any unit"},
          {"first", kHostBase},
          {"count", kHostRegisters},
          {"fields", std::move(fields)}};
}

json exceptions_json() {
  json out = json::array();
  for (auto e :
       {Exception::IllegalFunction, Exception::IllegalDataAddress, Exception::IllegalDataValue,
        Exception::ServerDeviceFailure, Exception::GatewayTargetFailed})
    out.push_back({{"code", static_cast<int>(e)}, {"name", to_string(e)}});
  return out;
}

// Names of the status block's enumerated values, index = value.
json values_json() {
  json dp_state = json::array(), master_state = json::array(), bus_state = json::array(),
       nmt_state = json::array();
  for (auto s : {dp::SlaveState::WaitPrm, dp::SlaveState::WaitCfg, dp::SlaveState::DataExch})
    dp_state.push_back(dp::to_string(s));
  for (auto s : {dp::MasterSlaveState::Init, dp::MasterSlaveState::SetPrm,
                 dp::MasterSlaveState::ChkCfg, dp::MasterSlaveState::CheckDiag,
                 dp::MasterSlaveState::DataExch, dp::MasterSlaveState::Retry})
    master_state.push_back(dp::to_string(s));
  for (auto s : {can::BusState::Ok, can::BusState::Warning, can::BusState::ErrorPassive,
                 can::BusState::BusOff})
    bus_state.push_back(can::to_string(s));
  for (auto s : {gw::NmtState::Initialising, gw::NmtState::PreOperational,
                 gw::NmtState::Operational, gw::NmtState::Stopped})
    nmt_state.push_back(gw::to_string(s));
  return {{"dp_state", std::move(dp_state)},
          {"master_state", std::move(master_state)},
          {"bus_state", std::move(bus_state)},
          {"nmt_state", std::move(nmt_state)}};
}

json leds_json() {
  // manual §3.3 table 3.3.1, as modbus::led::codes() encodes it.
  return {
      {"fields", {{"P", "led_p"}, {"D", "led_d"}, {"E", "led_e"}, {"C", "led_c"}}},
      {"off", led::kOff},
      {"on", led::kOn},
      {"morse", {{"E", led::kMorseE}, {"W", led::kMorseW}, {"O", led::kMorseO}}},
      {"flashes", "LED E: a value n > 1 is n short flashes (3 waiting for Set_Prm, 4 for Chk_Cfg)"},
  };
}

// The Slave_Diag bytes as the gateway fills them (manual §3.4, tables 3.4.3-3.4.5).
json diagnosis_json() {
  json bits = json::array();
  auto bit = [&](int byte, std::uint8_t mask, const char* name) {
    bits.push_back({{"byte", byte}, {"mask", mask}, {"name", name}});
  };
  for (const auto& b : dp::kDiagBitNames) bit(b.byte, b.mask, b.name);
  json can_states = json::array();
  for (auto s : {can::BusState::Ok, can::BusState::Warning, can::BusState::ErrorPassive,
                 can::BusState::BusOff})
    can_states.push_back({{"name", can::to_string(s)}, {"code", gw::bus_state_code(s)}});
  return {
      {"length", dp::DpSlave::kDiagLen},
      {"bits", std::move(bits)},
      {"master", {{"byte", 3}, {"none", dp::kNoMaster}}},
      {"ident", {{"bytes", {4, 5}}}},
      // Byte 8 says what bytes 8..10 hold (manual table 3.4.5): a Prm fault (telegram byte,
      // correct value), a Cfg fault (slot, code), or with CAN-Diagnosis the CAN state in bits
      // 7..6, IRQ_LOST in byte 9 and MSG_LOST in byte 10 (both saturate at 255).
      {"ext",
       {{"byte", 8},
        {"prm_fault", {{"marker", dp::kExtDiagPrmSap}, {"byte", 9}, {"expected", 10}}},
        {"cfg_fault", {{"marker", dp::kExtDiagCfgSap}, {"slot", 9}, {"code", 10}}},
        {"can_state_mask", gw::kBusStateMask},
        {"can_states", std::move(can_states)},
        {"irq_lost", 9},
        {"msg_lost", 10}}},
  };
}

std::string hex_list(const std::vector<std::uint8_t>& bytes) {
  std::string out;
  char b[4];
  for (auto v : bytes) {
    std::snprintf(b, sizeof b, "%s%02X", out.empty() ? "" : ",", v);
    out += b;
  }
  return out;
}

json slots_json(const config::GatewayConfig& g) {
  json slots = json::array();
  const auto params = config::slave_parameters(g);
  const auto decoded = dp::decode_chk_cfg(params.cfg);
  for (std::size_t i = 0; i < decoded.entries.size() && i < params.addresses.size(); ++i) {
    const auto& e = decoded.entries[i];
    for (const bool input : {true, false}) {
      const std::size_t n = input ? e.in_bytes() : e.out_bytes();
      const auto addr = input ? params.addresses[i].input : params.addresses[i].output;
      if (!n || !addr) continue;
      const std::uint32_t first = *addr, last = static_cast<std::uint32_t>(*addr + n - 1);
      slots.push_back({
          {"slot", i},
          {"io", input ? "input" : "output"},
          {"plc", input ? "I" : "Q"},
          {"address", first},
          {"length", n},
          {"comment", hex_list(e.manufacturer)},
          {"registers",
           {{"table", table_name(input ? Table::InputRegisters : Table::HoldingRegisters)},
            {"first", first / 2},
            {"last", last / 2}}},
          {"bits",
           {{"table", table_name(input ? Table::DiscreteInputs : Table::Coils)},
            {"first", first * 8},
            {"last", last * 8 + 7}}},
      });
    }
  }
  return slots;
}

json gateways_json(const config::DaemonConfig& config) {
  json out = json::array();
  for (std::size_t i = 0; i < config.gateways.size(); ++i) {
    const auto& g = config.gateways[i];
    json units = json::array({g.dp_address()});
    if (i == 0)
      for (auto u : kFirstGatewayUnits) units.push_back(u);
    out.push_back({{"name", g.name},
                   {"dp_address", g.dp_address()},
                   {"units", std::move(units)},
                   {"bus", g.bus.empty() ? json(nullptr) : json(g.bus)},
                   {"remote", config.remote_gateways()},
                   {"slots", slots_json(g)}});
  }
  return out;
}

json slaves_json(const config::DaemonConfig& config) {
  json out = json::array();
  for (const auto& sl : config.slaves) {
    // docs/modbus.md "Unit IDs": without gateways 0 and 255 address the first slave.
    json units = json::array({sl.address});
    if (config.gateways.empty() && &sl == &config.slaves.front())
      for (auto u : kFirstGatewayUnits) units.push_back(u);
    const auto params = config::slave_parameters(sl);
    const auto map = dp::map_image(params);
    json in = json::array(), outputs = json::array();
    for (const auto& m : map.in) in.push_back({{"address", m.plc_address}, {"length", m.length}});
    for (const auto& m : map.out)
      outputs.push_back({{"address", m.plc_address}, {"length", m.length}});
    out.push_back({{"name", sl.name},
                   {"dp_address", sl.address},
                   {"units", std::move(units)},
                   {"field_unit", sl.field_unit ? json(*sl.field_unit) : json(nullptr)},
                   {"input_bytes", map.in_len},
                   {"output_bytes", map.out_len},
                   {"inputs", std::move(in)},
                   {"outputs", std::move(outputs)},
                   {"remote", config.remote_gateways()}});
  }
  return out;
}

json drives_json(const config::DaemonConfig& config) {
  json out = json::array();
  for (const auto& d : config.drives)
    out.push_back({{"name", d.name},
                   {"bus", d.bus},
                   {"rx_id", d.rx_id},
                   {"tx_id", d.tx_id},
                   {"unit", d.modbus_unit ? json(*d.modbus_unit) : json(nullptr)}});
  return out;
}

}  // namespace

nlohmann::ordered_json map_json(const config::DaemonConfig& config) {
  nlohmann::ordered_json j = {
      {"format", kFormat},
      {"version", kVersion},
      {"listen", config.modbus_listen.to_string()},
      {"image", image_json()},
      {"status", status_json()},
      {"control", control_json()},
      {"faults", faults_json()},
      {"drive_faults", drive_faults_json()},
      {"slave_faults", slave_faults_json()},
      {"field", field_json()},
      {"exceptions", exceptions_json()},
      {"first_gateway_units", kFirstGatewayUnits},
      {"values", values_json()},
      {"leds", leds_json()},
      {"diagnosis", diagnosis_json()},
      {"diagnosis_bytes", diagnosis_bytes_json()},
      {"host", host_json()},
      {"gateways", gateways_json(config)},
      {"slaves", slaves_json(config)},
      {"drives", drives_json(config)},
  };
  if (has_line_block(config)) j["line"] = line_json(config);  // an ideal line's map as before
  if (has_can_fault_block(config)) j["can_faults"] = can_faults_json(config);  // ideal buses: idem
  return j;
}

std::string map_json_text(const config::DaemonConfig& config) {
  return map_json(config).dump(2) + "\n";
}

}  // namespace candp2::modbus

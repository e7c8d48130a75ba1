#include "modbus/map_report.hpp"

#include <cstdio>
#include <sstream>

#include "modbus/modbus_map.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::modbus {

std::string map_text(const config::DaemonConfig& config) {
  std::ostringstream out;
  out << "Modbus/TCP " << config.modbus_listen.to_string() << " (docs/modbus.md)\n\n";
  out << "Unit IDs (status block and control register of one gateway; the process image is the "
         "same for all):\n";
  for (std::size_t i = 0; i < config.gateways.size(); ++i) {
    const auto& g = config.gateways[i];
    out << "  " << static_cast<int>(g.dp_address()) << (i == 0 ? ", 0, 255" : "") << "  " << g.name
        << "\n";
  }
  for (const auto& sl : config.slaves)  // without gateways 0 and 255 address the first slave
    out << "  " << static_cast<int>(sl.address)
        << (config.gateways.empty() && &sl == &config.slaves.front() ? ", 0, 255" : "") << "  "
        << sl.name << " (generic slave)\n";
  out << "  other  exception 0x0B\n\n";
  out << "Process image (PLC bytes; register r = bytes 2r high, 2r+1 low; bit b = byte b/8 bit "
         "b%8):\n";
  char line[256];
  for (const auto& g : config.gateways) {
    const auto params = config::slave_parameters(g);
    const auto decoded = dp::decode_chk_cfg(params.cfg);
    for (std::size_t i = 0; i < decoded.entries.size() && i < g.slots.size(); ++i) {
      const auto& e = decoded.entries[i];
      std::string comment;
      for (auto b : e.manufacturer) {
        std::snprintf(line, sizeof line, "%s%02X", comment.empty() ? "" : ",", b);
        comment += line;
      }
      for (int dir = 0; dir < 2; ++dir) {
        const bool input = dir == 0;
        const std::size_t n = input ? e.in_bytes() : e.out_bytes();
        const auto addr = input ? params.addresses[i].input : params.addresses[i].output;
        if (!n || !addr) continue;
        const unsigned first = *addr, last = static_cast<unsigned>(*addr + n - 1);
        std::snprintf(line, sizeof line,
                      "  %-10s slot %-2zu %-6s %s %4u..%-4u  %s %4u..%-4u  %s %5u..%-5u  %s\n",
                      g.name.c_str(), i, input ? "input" : "output", input ? "I" : "Q", first, last,
                      input ? "input registers  " : "holding registers", first / 2, last / 2,
                      input ? "discrete inputs" : "coils          ", first * 8, last * 8 + 7,
                      comment.empty() ? "" : ("comment " + comment).c_str());
        out << line;
        if (first % 2 || last % 2 == 0)
          out << "             (odd byte boundaries: the first/last register is shared with "
                 "neighbouring bytes)\n";
      }
    }
  }
  for (const auto& sl : config.slaves) {
    const auto map = dp::map_image(config::slave_parameters(sl));
    for (const auto& m : map.in)
      out << "  " << sl.name << "  inputs  I " << m.plc_address << ".."
          << m.plc_address + m.length - 1 << "\n";
    for (const auto& m : map.out)
      out << "  " << sl.name << "  outputs Q " << m.plc_address << ".."
          << m.plc_address + m.length - 1 << "\n";
    if (sl.field_unit)
      out << "  " << sl.name << "  field side on unit " << static_cast<int>(*sl.field_unit)
          << ": holding registers = its " << map.in_len << " input bytes, input registers = its "
          << map.out_len << " output bytes (register r = bytes 2r, 2r+1)\n";
  }
  out << "\nStatus block (input registers, unit ID = DP address):\n";
  for (const auto& f : status_fields()) {
    const unsigned a = kStatusBase + f.offset;
    if (f.registers == 1)
      std::snprintf(line, sizeof line, "  %u        ", a);
    else
      std::snprintf(line, sizeof line, "  %u..%u  ", a, a + f.registers - 1);
    out << line << f.name << ": " << f.meaning << "\n";
  }
  out << "  " << kDiagnosisBase << ".." << kDiagnosisBase + kDiagnosisRegisters - 1
      << "  the whole Slave_Diag answer: " << kDiagnosisBase << " its length, then 2 bytes a "
      << "register, high first (docs/modbus.md \"Whole diagnosis\")\n";
  if (has_line_block(config)) {  // docs/modbus.md "Line block"
    out << "\nLine block (unit ID = DP address; docs/modbus.md \"Line block\"), input registers:\n";
    std::uint16_t at = line::kCounters;
    for (const auto& f : fdl::kStationCounters) {
      std::snprintf(line, sizeof line, "  %u..%u  ", kLineBase + at, kLineBase + at + 1);
      out << line << f.name << ": " << f.meaning << "\n";
      at = static_cast<std::uint16_t>(at + 2);
    }
    out << "  " << kLineBase + line::kLive << "        live: 0 none, 1 ok, 2 missing, 3 phantom\n"
        << "  " << kLineBase + line::kBusCycle << ".." << kLineBase + line::kCount - 1
        << "  the bus cycle, µs: last, min, mean, max, then the rotations measured (32 bit each)\n"
        << "Line faults (docs/faults.md \"Line faults\"), holding registers: "
        << kLineBase + line::kFaultKind
        << " kind (0 none, 1 corrupt, 2 silent, 3 late, 4 double_address; applied when written), "
        << kLineBase + line::kFaultCount << " count, " << kLineBase + line::kFaultEvery
        << " every, " << kLineBase + line::kFaultForMs << " for_ms, "
        << kLineBase + line::kNoiseForMs << " noise on the line for_ms\n";
  }
  if (has_can_fault_block(config)) {  // docs/modbus.md "CAN fault block"
    out << "\nCAN fault block (holding registers, unit ID = the DP address of a gateway on a bus "
           "in "
           "time; docs/modbus.md \"CAN fault block\"):\n";
    for (std::size_t i = 0; i < kCanFaultFields.size(); ++i) {
      std::snprintf(line, sizeof line, "  %zu        ", kCanFaultBase + i);
      out << line << kCanFaultFields[i].name << ": " << kCanFaultFields[i].meaning << "\n";
    }
  }
  out << "\nHost block (any unit; docs/modbus.md \"Host block\"), input registers:\n";
  for (std::size_t i = 0; i < kHostFields.size(); ++i) {
    std::snprintf(line, sizeof line, "  %zu..%zu  ", kHostBase + 2 * i, kHostBase + 2 * i + 1);
    out << line << kHostFields[i].name << ": " << kHostFields[i].meaning << "\n";
  }
  out << "\nControl (holding register " << kControlRegister
      << ", unit ID = DP address): write 1 = power cycle, 2 = re-parameterize, 3 = the master "
         "stops addressing the gateway, 4 = it resumes; reads the last command\n";
  if (!config.gateways.empty())  // a gateway's CAN side; a line of slaves alone has none
    out << "Faults (docs/faults.md): holding register " << kForcedStateRegister
        << " = forced CAN state (0 real, 1 warning, 2 error-passive, 3 bus-off), "
        << kDropRxRegister << " = drop the next N received frames (IRQ_LOST)\n";
  if (!config.slaves.empty())
    out << "Generic slaves (docs/faults.md), holding registers of the slave's DP address: "
        << kSlaveFaultBase + kSlaveOnBus << " on the bus (1) / off (0), "
        << kSlaveFaultBase + kSlavePrmFault << " Prm fault forced, "
        << kSlaveFaultBase + kSlaveCfgFault << " Cfg fault forced, "
        << kSlaveFaultBase + kSlaveAlarmLength << " diagnosis alarm length (0 clears), "
        << kSlaveFaultBase + kSlaveAlarmBytes << ".." << kSlaveFaultBase + kSlaveFaultRegisters - 1
        << " its bytes\n";
  out << "Exceptions: 0x01 unsupported function, 0x02 address outside the tables, 0x03 bad "
         "quantity/value, 0x0B unknown unit ID\n";
  return out.str();
}

}  // namespace candp2::modbus

#include "modbus/registers.hpp"

#include <algorithm>

namespace candp2::modbus {

// ---------------------------------------------------------------------------------- status

namespace {
constexpr std::size_t kFieldCount = std::size(station::kFields);
constexpr std::array<StatusField, kFieldCount> kStatusFields = [] {
  std::array<StatusField, kFieldCount> out{};
  std::uint16_t at = 0;
  for (std::size_t i = 0; i < kFieldCount; ++i) {
    const auto& f = station::kFields[i];
    out[i] = {at, f.registers, f.name, f.meaning};
    at = static_cast<std::uint16_t>(at + f.registers);
  }
  return out;
}();
}  // namespace

std::span<const StatusField> status_fields() {
  return kStatusFields;
}

std::uint16_t offset_of(const station::Field& f) {
  return kStatusFields[static_cast<std::size_t>(&f - station::kFields)].offset;
}

std::uint32_t field_value(const StatusBlock& b, const station::Field& f) {
  const std::uint16_t at = offset_of(f);
  return f.registers == 2 ? get32(b, at) : b[at];
}

std::span<const ControlCommand> control_commands() {
  static constexpr ControlCommand kCommands[] = {
      {Control::None, "none", "nothing (clears the register)"},
      {Control::PowerCycle, "power_cycle",
       "power-cycle the gateway: Wait_Prm, counters 0, stored wake-up/SYNC values kept"},
      {Control::Reparameterize, "reparameterize",
       "the master runs Slave_Diag, Set_Prm, Chk_Cfg, Slave_Diag again"},
      {Control::MasterStops, "master_stop",
       "the master stops addressing the gateway (a PLC in STOP; docs/faults.md)"},
      {Control::MasterResumes, "master_resume", "the master addresses the gateway again"},
  };
  return kCommands;
}

StatusBlock encode_status(const StatusInputs& in) {
  StatusBlock b{};
  for (const auto& f : status_fields()) {
    const auto& row = station::kFields[static_cast<std::size_t>(&f - kStatusFields.data())];
    if (!row.get) {  // the diagnosis: one byte a register
      for (std::size_t i = 0; i < in.diag.size() && i < f.registers; ++i)
        b[f.offset + i] = in.diag[i];
      continue;
    }
    // The one face that saturates: a value to its 16 or 32 bits (docs/modbus.md).
    const std::uint64_t v = row.get(in);
    if (f.registers == 2) {
      const std::uint32_t x = station::sat32(v);
      b[f.offset] = static_cast<std::uint16_t>(x >> 16);
      b[f.offset + 1] = static_cast<std::uint16_t>(x & 0xFFFF);
    } else {
      b[f.offset] = static_cast<std::uint16_t>(station::sat16(v));
    }
  }
  return b;
}

HostBlock encode_host_stalls(const HostStalls& h) {
  HostBlock b{};
  for (std::size_t i = 0; i < kHostFields.size(); ++i) {
    const std::uint32_t x = station::sat32(kHostFields[i].value(h));
    b[2 * i] = static_cast<std::uint16_t>(x >> 16);
    b[2 * i + 1] = static_cast<std::uint16_t>(x & 0xFFFF);
  }
  return b;
}

}  // namespace candp2::modbus

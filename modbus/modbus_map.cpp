#include "modbus/modbus_map.hpp"

#include <algorithm>

namespace candp2::modbus {

// -------------------------------------------------------------------------------------- map

std::vector<std::uint8_t> GatewayFace::diagnosis(Time now) {
  const StatusBlock block = status(now);
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i < dp::DpSlave::kDiagLen; ++i)
    out.push_back(static_cast<std::uint8_t>(block[status::kDiag + i]));
  return out;
}

ProcessImageMap::ProcessImageMap(dp::ProcessImage& image, std::vector<GatewayFace*> gateways,
                                 std::vector<DriveFace*> drives, std::vector<FieldFace*> fields)
    : image_(image),
      gateways_(std::move(gateways)),
      last_control_(gateways_.size(), 0),
      drives_(std::move(drives)),
      fields_(std::move(fields)) {}

GatewayFace* ProcessImageMap::resolve(std::uint8_t unit) const {
  if (gateways_.empty()) return nullptr;
  // docs/modbus.md: unit IDs 0 and 255 address the first configured gateway.
  for (auto u : kFirstGatewayUnits)
    if (unit == u) return gateways_.front();
  for (auto* g : gateways_)
    if (g->dp_address() == unit) return g;
  return nullptr;
}

std::uint16_t ProcessImageMap::last_control(std::uint8_t dp_address) const {
  for (std::size_t i = 0; i < gateways_.size(); ++i)
    if (gateways_[i]->dp_address() == dp_address) return last_control_[i];
  return 0;
}

namespace {

DecodeFailure address_error(Table t, std::uint32_t address, std::uint32_t count) {
  return {Exception::IllegalDataAddress, std::string(to_string(t)) + " " + std::to_string(address) +
                                             ".." + std::to_string(address + count - 1) +
                                             " outside the map"};
}

bool within(std::uint32_t address, std::uint32_t count, std::uint32_t begin, std::uint32_t size) {
  return address >= begin && address + count <= begin + size;
}

std::uint16_t image_register(const std::array<std::uint8_t, dp::kImageSize>& bytes,
                             std::uint32_t r) {
  // docs/modbus.md: register r = byte 2r (high) and 2r+1 (low).
  return static_cast<std::uint16_t>((bytes[2 * r] << 8) | bytes[2 * r + 1]);
}

}  // namespace

std::optional<DecodeFailure> ProcessImageMap::read_registers(Table t, GatewayFace& g,
                                                             std::uint16_t address,
                                                             std::uint16_t count, ReadResult& out,
                                                             Time now) {
  const auto& bytes = t == Table::InputRegisters ? image_.inputs : image_.outputs;
  if (within(address, count, 0, kImageRegisters)) {
    for (std::uint32_t i = 0; i < count; ++i) out.registers[i] = image_register(bytes, address + i);
    return std::nullopt;
  }
  if (t == Table::InputRegisters && within(address, count, kStatusBase, status::kCount)) {
    const StatusBlock block = g.status(now);
    std::copy_n(block.begin() + (address - kStatusBase), count, out.registers.begin());
    return std::nullopt;
  }
  if (t == Table::InputRegisters && within(address, count, kDiagnosisBase, kDiagnosisRegisters)) {
    // docs/modbus.md "Whole diagnosis": the length, then two bytes a register (high first).
    const auto d = g.diagnosis(now);
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t a = address + i - kDiagnosisBase;
      if (a == 0) {
        out.registers[i] = static_cast<std::uint16_t>(d.size());
        continue;
      }
      const std::size_t b = 2 * (a - 1);
      const std::uint8_t high = b < d.size() ? d[b] : 0, low = b + 1 < d.size() ? d[b + 1] : 0;
      out.registers[i] = static_cast<std::uint16_t>(high << 8 | low);
    }
    return std::nullopt;
  }
  if (t == Table::HoldingRegisters && within(address, count, kControlRegister, kControlRegisters)) {
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t a = address + i;
      out.registers[i] = a == kControlRegister       ? last_control(g.dp_address())
                         : a == kForcedStateRegister ? g.forced_bus_state()
                                                     : g.drop_remaining();
    }
    return std::nullopt;
  }
  if (t == Table::InputRegisters && within(address, count, kHostBase, kHostRegisters)) {
    const HostBlock block = encode_host_stalls(host_stalls_ ? host_stalls_() : HostStalls{});
    std::copy_n(block.begin() + (address - kHostBase), count, out.registers.begin());
    return std::nullopt;
  }
  if (g.line() && t == Table::InputRegisters && within(address, count, kLineBase, line::kCount)) {
    const LineBlock block = g.line()->block(g.dp_address(), now);
    std::copy_n(block.begin() + (address - kLineBase), count, out.registers.begin());
    return std::nullopt;
  }
  if (g.line() && t == Table::HoldingRegisters &&
      within(address, count, kLineBase, line::kFaultRegisters)) {
    for (std::uint32_t i = 0; i < count; ++i)
      out.registers[i] = g.line()->fault_register(
          g.dp_address(), static_cast<std::uint16_t>(address + i - kLineBase), now);
    return std::nullopt;
  }
  if (g.can_faults() && t == Table::HoldingRegisters &&
      within(address, count, kCanFaultBase, can_fault::kRegisters)) {
    for (std::uint32_t i = 0; i < count; ++i)
      out.registers[i] = g.can_faults()->fault_register(
          g.dp_address(), static_cast<std::uint16_t>(address + i - kCanFaultBase));
    return std::nullopt;
  }
  if (t == Table::HoldingRegisters && g.has_slave_faults() &&
      within(address, count, kSlaveFaultBase, kSlaveFaultRegisters)) {
    for (std::uint32_t i = 0; i < count; ++i)
      out.registers[i] = g.slave_fault(static_cast<std::uint16_t>(address + i - kSlaveFaultBase));
    return std::nullopt;
  }
  return address_error(t, address, count);
}

namespace {
DecodeFailure read_only_error() {
  // docs/profibus.md role slaves: the output image is what the external master sends.
  return {Exception::ServerDeviceFailure,
          "the output image belongs to the external PROFIBUS master (profibus role slaves): it "
          "shows what the master sent and cannot be written"};
}
}  // namespace

// docs/faults.md: holding registers 0..3 of the drive's unit ID.
std::optional<DecodeFailure> ProcessImageMap::handle_drive(DriveFace& d, const Request& r,
                                                           ReadResult& out, Time now) {
  if (r.function == Function::ReadHoldingRegisters) {
    if (!within(r.address, r.count, 0, kDriveRegisters))
      return address_error(r.table, r.address, r.count);
    for (std::uint32_t i = 0; i < r.count; ++i)
      out.registers[i] = d.fault_register(static_cast<std::uint16_t>(r.address + i));
    return std::nullopt;
  }
  if (r.function == Function::WriteSingleRegister ||
      r.function == Function::WriteMultipleRegisters) {
    if (!within(r.write_address, r.write_count, 0, kDriveRegisters))
      return address_error(Table::HoldingRegisters, r.write_address, r.write_count);
    for (std::uint32_t i = 0; i < r.write_count; ++i)
      d.set_fault_register(static_cast<std::uint16_t>(r.write_address + i), r.register_value(i),
                           now);
    return std::nullopt;
  }
  return DecodeFailure{Exception::IllegalFunction,
                       "a drive's fault registers take FC 03, 06 and 16 only"};
}

// docs/slaves.md "Field side": holding registers = the inputs the slave reports (byte 2r high,
// 2r+1 low, as the image), input registers = the outputs it applies.
std::optional<DecodeFailure> ProcessImageMap::handle_field(FieldFace& f, const Request& r,
                                                           ReadResult& out) {
  const auto in = f.inputs();
  const auto outputs = f.outputs();
  const auto regs = [](std::size_t bytes) { return static_cast<std::uint32_t>((bytes + 1) / 2); };
  const auto reg = [](std::span<const std::uint8_t> b, std::uint32_t r) {
    const std::uint8_t hi = 2 * r < b.size() ? b[2 * r] : 0;
    const std::uint8_t lo = 2 * r + 1 < b.size() ? b[2 * r + 1] : 0;
    return static_cast<std::uint16_t>(hi << 8 | lo);
  };
  switch (r.function) {
    case Function::ReadHoldingRegisters:
    case Function::ReadInputRegisters: {
      const auto bytes = r.function == Function::ReadHoldingRegisters ? in : outputs;
      if (!within(r.address, r.count, 0, regs(bytes.size())))
        return address_error(r.table, r.address, r.count);
      for (std::uint32_t i = 0; i < r.count; ++i) out.registers[i] = reg(bytes, r.address + i);
      return std::nullopt;
    }
    case Function::WriteSingleRegister:
    case Function::WriteMultipleRegisters: {
      if (!within(r.write_address, r.write_count, 0, regs(in.size())))
        return address_error(Table::HoldingRegisters, r.write_address, r.write_count);
      std::vector<std::uint8_t> bytes;
      for (std::uint32_t i = 0; i < r.write_count; ++i) {
        bytes.push_back(static_cast<std::uint8_t>(r.register_value(i) >> 8));
        bytes.push_back(static_cast<std::uint8_t>(r.register_value(i) & 0xFF));
      }
      // An odd input length: the last register's low byte has no input byte behind it.
      const std::size_t first = 2u * r.write_address;
      bytes.resize(std::min(bytes.size(), in.size() - first));
      f.write_inputs(first, bytes);
      return std::nullopt;
    }
    default:
      return DecodeFailure{Exception::IllegalFunction,
                           "a slave's field side takes FC 03, 04, 06 and 16 only"};
  }
}

std::optional<DecodeFailure> ProcessImageMap::handle(const Request& r, ReadResult& out, Time now) {
  for (DriveFace* d : drives_)
    if (d->modbus_unit() == r.unit) return handle_drive(*d, r, out, now);
  for (FieldFace* f : fields_)
    if (f->field_unit() == r.unit) return handle_field(*f, r, out);
  GatewayFace* g = resolve(r.unit);
  if (!g)
    return DecodeFailure{Exception::GatewayTargetFailed,
                         "unit ID " + std::to_string(r.unit) + " addresses no configured station"};
  switch (r.function) {
    case Function::ReadCoils:
    case Function::ReadDiscreteInputs:
    case Function::WriteSingleCoil:
    case Function::WriteMultipleCoils:
      return bits(r, out);
    case Function::ReadHoldingRegisters:
    case Function::ReadInputRegisters:
      return read_registers(r.table, *g, r.address, r.count, out, now);
    case Function::WriteSingleRegister:
    case Function::WriteMultipleRegisters:
    case Function::MaskWriteRegister:
    case Function::ReadWriteMultipleRegisters:
      return write_registers(*g, r, out, now);
  }
  return DecodeFailure{Exception::IllegalFunction, "function not supported"};
}

// Coils and discrete inputs: bit b of the output / input image is byte b/8, bit b%8
// (docs/modbus.md).
std::optional<DecodeFailure> ProcessImageMap::bits(const Request& r, ReadResult& out) {
  if (!within(r.address, r.count, 0, kImageBits)) return address_error(r.table, r.address, r.count);
  auto& q = image_.outputs;
  if (r.function == Function::ReadCoils || r.function == Function::ReadDiscreteInputs) {
    const auto& bytes = r.function == Function::ReadCoils ? q : image_.inputs;
    for (std::uint32_t i = 0; i < r.count; ++i) {
      const std::uint32_t b = r.address + i;
      out.bits[i] = (bytes[b / 8] >> (b % 8)) & 1;
    }
    return std::nullopt;
  }
  if (outputs_read_only_) return read_only_error();
  for (std::uint32_t i = 0; i < r.count; ++i) {
    const std::uint32_t b = r.address + i;
    const bool on =
        r.function == Function::WriteSingleCoil ? r.register_value(0) == kCoilOn : r.coil_value(i);
    const auto mask = static_cast<std::uint8_t>(1u << (b % 8));
    q[b / 8] = static_cast<std::uint8_t>(on ? (q[b / 8] | mask) : (q[b / 8] & ~mask));
  }
  return std::nullopt;
}

// FC 06, 16, 22, 23: the output image, or a station's control and fault registers. All values are
// checked before any is applied (all or nothing).
std::optional<DecodeFailure> ProcessImageMap::write_registers(GatewayFace& g, const Request& r,
                                                              ReadResult& out, Time now) {
  const std::uint16_t wa = r.write_address, wc = r.write_count;
  const bool image = within(wa, wc, 0, kImageRegisters);
  const bool control = within(wa, wc, kControlRegister, kControlRegisters);
  const bool slave = g.has_slave_faults() && within(wa, wc, kSlaveFaultBase, kSlaveFaultRegisters);
  const bool line = g.line() && within(wa, wc, kLineBase, line::kFaultRegisters);
  const bool can = g.can_faults() && within(wa, wc, kCanFaultBase, can_fault::kRegisters);
  if (!image && !control && !slave && !line && !can)
    return address_error(Table::HoldingRegisters, wa, wc);
  if (image && outputs_read_only_) return read_only_error();
  // FC 23: both ranges are checked before anything is written (all or nothing).
  if (r.function == Function::ReadWriteMultipleRegisters &&
      !within(r.address, r.count, 0, kImageRegisters) &&
      !within(r.address, r.count, kControlRegister, kControlRegisters))
    return address_error(Table::HoldingRegisters, r.address, r.count);
  auto& q = image_.outputs;
  std::vector<std::uint16_t> values(wc);
  for (std::uint32_t i = 0; i < wc; ++i) {
    if (r.function != Function::MaskWriteRegister) {
      values[i] = r.register_value(i);
      continue;
    }
    // MB spec §6.16: (current AND and_mask) OR (or_mask AND NOT and_mask).
    const std::uint16_t current =
        image                        ? image_register(q, wa)
        : line                       ? g.line()->fault_register(g.dp_address(),
                                                                static_cast<std::uint16_t>(wa - kLineBase), now)
        : can                        ? g.can_faults()->fault_register(g.dp_address(),
                                                                      static_cast<std::uint16_t>(wa - kCanFaultBase))
        : slave                      ? g.slave_fault(wa - kSlaveFaultBase)
        : wa == kControlRegister     ? last_control(g.dp_address())
        : wa == kForcedStateRegister ? g.forced_bus_state()
                                     : g.drop_remaining();
    values[i] = static_cast<std::uint16_t>((current & r.and_mask) | (r.or_mask & ~r.and_mask));
  }
  if (control) {
    if (auto failure = write_control(g, wa, values, now)) return failure;
  } else if (line) {
    if (auto failure = g.line()->write_faults(
            g.dp_address(), static_cast<std::uint16_t>(wa - kLineBase), values, now))
      return failure;
  } else if (can) {
    if (auto failure = g.can_faults()->write_faults(
            g.dp_address(), static_cast<std::uint16_t>(wa - kCanFaultBase), values, now))
      return failure;
  } else if (slave) {
    if (auto failure =
            g.write_slave_faults(static_cast<std::uint16_t>(wa - kSlaveFaultBase), values, now))
      return failure;
  } else {
    for (std::uint32_t i = 0; i < wc; ++i) {
      q[2 * (wa + i)] = static_cast<std::uint8_t>(values[i] >> 8);
      q[2 * (wa + i) + 1] = static_cast<std::uint8_t>(values[i] & 0xFF);
    }
  }
  if (r.function == Function::ReadWriteMultipleRegisters)
    return read_registers(Table::HoldingRegisters, g, r.address, r.count, out, now);
  return std::nullopt;
}

// Holding registers 8192..8194 (docs/modbus.md "Control", docs/faults.md).
std::optional<DecodeFailure> ProcessImageMap::write_control(GatewayFace& g, std::uint16_t first,
                                                            std::span<const std::uint16_t> values,
                                                            Time now) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::uint16_t v = values[i];
    const std::uint32_t a = first + i;
    if (a == kControlRegister && v > static_cast<std::uint16_t>(Control::MasterResumes))
      return DecodeFailure{Exception::IllegalDataValue,
                           "control command " + std::to_string(v) +
                               " (1 power cycle, 2 re-parameterize, 3 master stops, 4 "
                               "master resumes)"};
    if (a == kControlRegister)
      if (auto why = g.refuses(static_cast<Control>(v)))
        return DecodeFailure{Exception::ServerDeviceFailure, std::move(*why)};
    if (a == kDropRxRegister && !g.has_can_controller())
      return DecodeFailure{Exception::IllegalDataValue,
                           "unit " + std::to_string(g.dp_address()) +
                               " has no CAN controller here to drop frames from"};
    if (a == kForcedStateRegister && v > 3)
      return DecodeFailure{Exception::IllegalDataValue,
                           "forced CAN state " + std::to_string(v) +
                               " (0 real, 1 warning, 2 error-passive, 3 bus-off)"};
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::uint16_t v = values[i];
    const std::uint32_t a = first + i;
    if (a == kControlRegister) {
      for (std::size_t k = 0; k < gateways_.size(); ++k)
        if (gateways_[k] == &g) last_control_[k] = v;
      g.control(static_cast<Control>(v), now);
    } else if (a == kForcedStateRegister) {
      if (!g.force_bus_state(v, now))
        return DecodeFailure{Exception::IllegalDataValue, "forcing not supported"};
    } else {
      g.drop_received(v, now);
    }
  }
  return std::nullopt;
}

}  // namespace candp2::modbus

#include "modbus/modbus_map.hpp"

#include <algorithm>

namespace candp2::modbus {

std::string_view to_string(Exception e) {
  switch (e) {
    case Exception::IllegalFunction:
      return "illegal function";
    case Exception::IllegalDataAddress:
      return "illegal data address";
    case Exception::IllegalDataValue:
      return "illegal data value";
    case Exception::ServerDeviceFailure:
      return "server device failure";
    case Exception::GatewayTargetFailed:
      return "gateway target device failed to respond";
  }
  return "?";
}

std::string_view to_string(Table t) {
  switch (t) {
    case Table::Coils:
      return "coils";
    case Table::DiscreteInputs:
      return "discrete inputs";
    case Table::HoldingRegisters:
      return "holding registers";
    case Table::InputRegisters:
      return "input registers";
  }
  return "?";
}

// ------------------------------------------------------------------------------------- framing

void MbapFramer::append(std::span<const std::uint8_t> bytes) {
  if (start_ > 0 && start_ == buffer_.size()) {
    buffer_.clear();
    start_ = 0;
  } else if (start_ > 4096) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_));
    start_ = 0;
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
}

MbapFramer::Next MbapFramer::next() {
  Next n;
  const std::size_t avail = buffer_.size() - start_;
  if (avail < kMbapLen) return n;
  const std::uint8_t* h = buffer_.data() + start_;
  const unsigned protocol = (h[2] << 8) | h[3];
  const unsigned length = (h[4] << 8) | h[5];  // unit id + PDU
  if (protocol != 0) {
    n.status = Status::Garbage;
    n.why = "MBAP protocol identifier " + std::to_string(protocol) + " (Modbus is 0)";
    return n;
  }
  // TCP guide §3.1.3: the length counts the unit id and the PDU (function code + data, 1..253).
  if (length < 2 || length > 1 + kMaxPduLen) {
    n.status = Status::Garbage;
    n.why =
        "MBAP length " + std::to_string(length) + " outside 2.." + std::to_string(1 + kMaxPduLen);
    return n;
  }
  const std::size_t total = 6 + length;
  if (avail < total) return n;
  n.status = Status::Frame;
  n.adu = std::span<const std::uint8_t>(h, total);
  start_ += total;
  return n;
}

// -------------------------------------------------------------------------------------- decode

bool Request::writes() const {
  switch (function) {
    case Function::WriteSingleCoil:
    case Function::WriteSingleRegister:
    case Function::WriteMultipleCoils:
    case Function::WriteMultipleRegisters:
    case Function::MaskWriteRegister:
    case Function::ReadWriteMultipleRegisters:
      return true;
    default:
      return false;
  }
}

namespace {

std::uint16_t be16(std::span<const std::uint8_t> p, std::size_t at) {
  return static_cast<std::uint16_t>((p[at] << 8) | p[at + 1]);
}

DecodeFailure value_error(std::string why) {
  return {Exception::IllegalDataValue, std::move(why)};
}

std::string count_text(std::uint16_t n, std::uint16_t max) {
  return "quantity " + std::to_string(n) + " outside 1.." + std::to_string(max);
}

}  // namespace

std::variant<Request, DecodeFailure> decode_request(std::span<const std::uint8_t> adu) {
  Request r;
  r.transaction = be16(adu, 0);
  r.unit = adu[6];
  const std::span<const std::uint8_t> pdu = adu.subspan(kMbapLen);  // function code + data
  const std::uint8_t fc = pdu[0];
  auto need = [&](std::size_t len) -> std::optional<DecodeFailure> {
    if (pdu.size() == len) return std::nullopt;
    return value_error("PDU of function 0x" + std::string(1, "0123456789ABCDEF"[fc >> 4]) +
                       std::string(1, "0123456789ABCDEF"[fc & 15]) + " has " +
                       std::to_string(pdu.size()) + " bytes, expected " + std::to_string(len));
  };
  switch (fc) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04: {
      r.function = static_cast<Function>(fc);
      r.table = fc == 0x01   ? Table::Coils
                : fc == 0x02 ? Table::DiscreteInputs
                : fc == 0x03 ? Table::HoldingRegisters
                             : Table::InputRegisters;
      if (auto f = need(5)) return *f;
      r.address = be16(pdu, 1);
      r.count = be16(pdu, 3);
      const std::uint16_t max = fc <= 0x02 ? kMaxReadBits : kMaxReadRegisters;
      if (r.count < 1 || r.count > max) return value_error(count_text(r.count, max));
      return r;
    }
    case 0x05:
    case 0x06: {
      r.function = static_cast<Function>(fc);
      r.table = fc == 0x05 ? Table::Coils : Table::HoldingRegisters;
      if (auto f = need(5)) return *f;
      r.address = r.write_address = be16(pdu, 1);
      r.count = r.write_count = 1;
      r.values = pdu.subspan(3, 2);
      // MB spec §6.5: a coil value other than FF00 or 0000 is illegal.
      if (fc == 0x05 && be16(pdu, 3) != kCoilOn && be16(pdu, 3) != kCoilOff)
        return value_error("coil value must be FF00 or 0000");
      return r;
    }
    case 0x0F:
    case 0x10: {
      r.function = static_cast<Function>(fc);
      r.table = fc == 0x0F ? Table::Coils : Table::HoldingRegisters;
      if (pdu.size() < 6) return *need(6);
      r.address = r.write_address = be16(pdu, 1);
      r.count = r.write_count = be16(pdu, 3);
      const std::uint16_t max = fc == 0x0F ? kMaxWriteBits : kMaxWriteRegisters;
      if (r.count < 1 || r.count > max) return value_error(count_text(r.count, max));
      const std::size_t bytes = fc == 0x0F ? (r.count + 7u) / 8u : 2u * r.count;
      if (pdu[5] != bytes)
        return value_error("byte count " + std::to_string(pdu[5]) + ", expected " +
                           std::to_string(bytes));
      if (auto f = need(6 + bytes)) return *f;
      r.values = pdu.subspan(6, bytes);
      return r;
    }
    case 0x16: {
      r.function = Function::MaskWriteRegister;
      r.table = Table::HoldingRegisters;
      if (auto f = need(7)) return *f;
      r.address = r.write_address = be16(pdu, 1);
      r.count = r.write_count = 1;
      r.and_mask = be16(pdu, 3);
      r.or_mask = be16(pdu, 5);
      return r;
    }
    case 0x17: {
      r.function = Function::ReadWriteMultipleRegisters;
      r.table = Table::HoldingRegisters;
      if (pdu.size() < 10) return *need(10);
      r.address = be16(pdu, 1);
      r.count = be16(pdu, 3);
      r.write_address = be16(pdu, 5);
      r.write_count = be16(pdu, 7);
      if (r.count < 1 || r.count > kMaxReadRegisters)
        return value_error("read " + count_text(r.count, kMaxReadRegisters));
      if (r.write_count < 1 || r.write_count > kMaxReadWriteWriteRegs)
        return value_error("write " + count_text(r.write_count, kMaxReadWriteWriteRegs));
      const std::size_t bytes = 2u * r.write_count;
      if (pdu[9] != bytes)
        return value_error("byte count " + std::to_string(pdu[9]) + ", expected " +
                           std::to_string(bytes));
      if (auto f = need(10 + bytes)) return *f;
      r.values = pdu.subspan(10, bytes);
      return r;
    }
    default:
      return DecodeFailure{Exception::IllegalFunction,
                           "function code " + std::to_string(fc) + " not supported"};
  }
}

// ---------------------------------------------------------------------------------- status

std::span<const StatusField> status_fields() {
  using namespace status;
  static constexpr StatusField kFields[] = {
      {kDpState, 1, "dp_state", "DP slave state: 0 Wait_Prm, 1 Wait_Cfg, 2 Data_Exch"},
      {kDiag, 11, "diag", "Slave_Diag bytes 0..10, one per register (emulator-spec §3)"},
      {kMasterState, 1, "master_state",
       "master's view: 0 Init, 1 Set_Prm, 2 Chk_Cfg, 3 Check_Diag, 4 Data_Exch, 5 Retry"},
      {kBusState, 1, "bus_state", "CAN controller: 0 ok, 1 warning, 2 error-passive, 3 bus-off"},
      {kReleased, 1, "released", "CAN transmission released: 0 no, 1 yes (emulator-spec §7)"},
      {kNmtState, 1, "nmt_state",
       "CANopen NMT state: 0 initialising, 1 pre-operational, 2 operational, 3 stopped"},
      {kRxFrames, 2, "rx_frames", "CAN frames received since power-on"},
      {kTxFrames, 2, "tx_frames", "CAN frames sent since power-on"},
      {kIrqLost, 2, "irq_lost", "frames lost before the gateway saw them (IRQ_LOST)"},
      {kMsgLost, 2, "msg_lost", "frames dropped at the full CW FIFO (MSG_LOST)"},
      {kFifoLevel, 1, "fifo_level", "frames waiting in the Communication Window FIFO"},
      {kFifoHighWater, 1, "fifo_high_water", "highest FIFO level since power-on"},
      {kSyncMs, 1, "sync_ms", "effective SYNC time, ms (0 = off)"},
      {kWakeupS, 1, "wakeup_s", "stored wake-up time, s"},
      {kDataExchanges, 2, "data_exchanges", "Data_Exchange telegrams the gateway answered"},
      {kLedD, 1, "led_d", "LED D (Data Exchange): 0 off, 1 on"},
      {kLedE, 1, "led_e",
       "LED E (DP status): 0 off, 3 = 3 flashes (waiting for Set_Prm), 4 = 4 flashes (Chk_Cfg)"},
      {kLedP, 1, "led_p", "LED P (power): 1 on"},
      {kLedC, 1, "led_c",
       "LED C (CAN): 1 on (ok), 0x45 Morse E (error passive), 0x57 W (warning), 0x4F O (bus off)"},
      {kDpAddress, 1, "dp_address", "the gateway's DP station address"},
      {kParameterizations, 2, "parameterizations", "Set_Prm telegrams the master sent"},
      {kBitrateMode, 1, "bitrate_mode",
       "SocketCAN bit rate handling: 0 none (not SocketCAN), 1 check, 2 apply"},
      {kBitrateConfigured, 2, "bitrate_configured",
       "CAN bit rate of the gateway's Set_Prm byte 8, bit/s (0 before Set_Prm)"},
      {kBitrateInterface, 2, "bitrate_interface",
       "bit rate of the SocketCAN interface, bit/s (0 = no bit timing, e.g. vcan)"},
      {kBitrateMismatch, 1, "bitrate_mismatch",
       "1 = the interface's bit rate differs from Set_Prm's by more than 1 %"},
      {kLineRole, 1, "line_role",
       "PROFIBUS line (emulator-spec §10): 0 none (in-process), 1 role slaves, 2 role master"},
      {kLineTelegrams, 2, "line_telegrams", "good FDL telegrams received on the line"},
      {kLineFcsErrors, 2, "line_fcs_errors", "telegrams dropped for a wrong FCS"},
      {kLineOtherErrors, 2, "line_other_errors",
       "telegrams dropped for framing (LE/LEr, ED, truncated) or parity errors"},
      {kStationRequests, 2, "station_requests", "requests addressed to this station"},
      {kStationRetries, 2, "station_retries",
       "role slaves: FCB repetitions answered; role master: requests repeated (no answer)"},
      {kResponseUs, 1, "response_us",
       "last response time, µs: role slaves request end → answer written; role master request "
       "written → answer complete (65535 = longer)"},
      {kResponseMaxUs, 1, "response_max_us", "highest response time since start, µs"},
      {kStationPresent, 1, "station_present",
       "role slaves: 1 while a master talks to the station; role master: 1 while it answers"},
      {kForcedState, 1, "forced_can_state",
       "holding register 8193: 0 real, 1 warning, 2 error-passive, 3 bus-off (docs/faults.md)"},
      {kTxSuppressed, 2, "tx_suppressed", "frames not sent because of a forced bus-off"},
      {kRxSuppressed, 2, "rx_suppressed", "frames not received because of a forced bus-off"},
      {kRxDropRemaining, 1, "rx_drop_remaining",
       "holding register 8194: received frames still to drop (each counts in IRQ_LOST)"},
      {kAddressed, 1, "addressed", "1 the master addresses the gateway, 0 stopped (control 3)"},
      {kReconnects, 2, "reconnects", "socketcand client: connections re-established"},
      {kCyclesMissed, 2, "master_cycles_missed",
       "DP master cycles missed since start: grid points (every cycle_ms) that passed without a "
       "cycle because the previous one started more than a period late; the same in every block"},
  };
  return kFields;
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

led::Codes led::codes(const gw::GatewayStatus& g) {
  // manual table 3.3.1.
  Codes c;
  c.d = g.dp_state == dp::SlaveState::DataExch ? kOn : kOff;
  c.e = g.dp_state == dp::SlaveState::WaitPrm   ? 3  // 3 short flashes: waiting for Set_Prm
        : g.dp_state == dp::SlaveState::WaitCfg ? 4  // 4 short flashes: waiting for Chk_Cfg
                                                : kOff;
  c.p = kOn;
  switch (g.bus_state) {
    case can::BusState::Ok:
      c.c = kOn;
      break;
    case can::BusState::Warning:
      c.c = kMorseW;
      break;
    case can::BusState::ErrorPassive:
      c.c = kMorseE;
      break;
    case can::BusState::BusOff:
      c.c = kMorseO;
      break;
  }
  return c;
}

StatusBlock encode_status(const StatusInputs& in) {
  using namespace status;
  StatusBlock b{};
  auto put32 = [&](std::uint16_t at, std::uint32_t v) {
    b[at] = static_cast<std::uint16_t>(v >> 16);
    b[at + 1] = static_cast<std::uint16_t>(v & 0xFFFF);
  };
  const auto& g = in.gateway;
  b[kDpState] = static_cast<std::uint16_t>(g.dp_state);
  for (std::size_t i = 0; i < in.diag.size(); ++i) b[kDiag + i] = in.diag[i];
  b[kMasterState] = in.master_state ? static_cast<std::uint16_t>(*in.master_state) : 0;
  b[kBusState] = static_cast<std::uint16_t>(g.bus_state);
  b[kReleased] = g.released ? 1 : 0;
  b[kNmtState] = static_cast<std::uint16_t>(g.nmt);
  put32(kRxFrames, g.rx_frames);
  put32(kTxFrames, g.tx_frames);
  put32(kIrqLost, g.irq_lost);
  put32(kMsgLost, g.msg_lost);
  b[kFifoLevel] = static_cast<std::uint16_t>(std::min<std::uint32_t>(g.fifo_level, 0xFFFF));
  b[kFifoHighWater] =
      static_cast<std::uint16_t>(std::min<std::uint32_t>(g.fifo_high_water, 0xFFFF));
  b[kSyncMs] = g.sync_ms;
  b[kWakeupS] = g.wakeup_s;
  put32(kDataExchanges, g.data_exchanges);
  b[kBitrateMode] = in.bitrate.mode;
  put32(kBitrateConfigured, in.bitrate.configured);
  put32(kBitrateInterface, in.bitrate.interface);
  b[kBitrateMismatch] = in.bitrate.mismatch ? 1 : 0;
  const auto leds = led::codes(g);
  b[kLedD] = leds.d;
  b[kLedE] = leds.e;
  b[kLedP] = leds.p;
  b[kLedC] = leds.c;
  if (in.line) {
    const auto& l = *in.line;
    b[kLineRole] = l.role;
    put32(kLineTelegrams, l.telegrams);
    put32(kLineFcsErrors, l.fcs_errors);
    put32(kLineOtherErrors, l.other_errors);
    put32(kStationRequests, l.requests);
    put32(kStationRetries, l.retries);
    b[kResponseUs] = static_cast<std::uint16_t>(std::min<std::uint32_t>(l.response_us, 0xFFFF));
    b[kResponseMaxUs] =
        static_cast<std::uint16_t>(std::min<std::uint32_t>(l.response_max_us, 0xFFFF));
    b[kStationPresent] = l.present ? 1 : 0;
  }
  b[kDpAddress] = in.dp_address;
  put32(kParameterizations, in.parameterizations);
  b[kForcedState] = in.forced_state;
  put32(kTxSuppressed, in.tx_suppressed);
  put32(kRxSuppressed, in.rx_suppressed);
  b[kRxDropRemaining] =
      static_cast<std::uint16_t>(std::min<std::uint32_t>(in.rx_drop_remaining, 0xFFFF));
  b[kAddressed] = in.addressed ? 1 : 0;
  put32(kReconnects, in.reconnects);
  put32(kCyclesMissed,
        static_cast<std::uint32_t>(std::min<std::uint64_t>(in.cycles_missed, 0xFFFFFFFFu)));
  return b;
}

// -------------------------------------------------------------------------------------- map

ProcessImageMap::ProcessImageMap(dp::ProcessImage& image, std::vector<GatewayFace*> gateways,
                                 std::vector<DriveFace*> drives)
    : image_(image),
      gateways_(std::move(gateways)),
      last_control_(gateways_.size(), 0),
      drives_(std::move(drives)) {}

GatewayFace* ProcessImageMap::resolve(std::uint8_t unit) const {
  if (gateways_.empty()) return nullptr;
  // emulator-spec §8: unit IDs 0 and 255 address the first configured gateway.
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
  // emulator-spec §8: register r = byte 2r (high) and 2r+1 (low).
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
  if (t == Table::HoldingRegisters && within(address, count, kControlRegister, kControlRegisters)) {
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t a = address + i;
      out.registers[i] = a == kControlRegister       ? last_control(g.dp_address())
                         : a == kForcedStateRegister ? g.forced_bus_state()
                                                     : g.drop_remaining();
    }
    return std::nullopt;
  }
  return address_error(t, address, count);
}

namespace {
DecodeFailure read_only_error() {
  // emulator-spec §10, role slaves: the output image is what the external master sends.
  return {Exception::ServerDeviceFailure,
          "the output image belongs to the external PROFIBUS master (profibus role slaves): it "
          "shows what the master sent and cannot be written"};
}
}  // namespace

std::optional<DecodeFailure> ProcessImageMap::handle(const Request& r, ReadResult& out, Time now) {
  for (DriveFace* d : drives_) {
    if (d->modbus_unit() != r.unit) continue;
    // docs/faults.md: holding registers 0..3 of the drive's unit ID.
    if (r.function == Function::ReadHoldingRegisters) {
      if (!within(r.address, r.count, 0, kDriveRegisters))
        return address_error(r.table, r.address, r.count);
      for (std::uint32_t i = 0; i < r.count; ++i)
        out.registers[i] = d->fault_register(static_cast<std::uint16_t>(r.address + i));
      return std::nullopt;
    }
    if (r.function == Function::WriteSingleRegister ||
        r.function == Function::WriteMultipleRegisters) {
      if (!within(r.write_address, r.write_count, 0, kDriveRegisters))
        return address_error(Table::HoldingRegisters, r.write_address, r.write_count);
      for (std::uint32_t i = 0; i < r.write_count; ++i)
        d->set_fault_register(static_cast<std::uint16_t>(r.write_address + i), r.register_value(i),
                              now);
      return std::nullopt;
    }
    return DecodeFailure{Exception::IllegalFunction,
                         "a drive's fault registers take FC 03, 06 and 16 only"};
  }
  GatewayFace* g = resolve(r.unit);
  if (!g)
    return DecodeFailure{Exception::GatewayTargetFailed,
                         "unit ID " + std::to_string(r.unit) + " addresses no configured gateway"};
  auto& in = image_.inputs;
  auto& q = image_.outputs;
  switch (r.function) {
    case Function::ReadCoils:
    case Function::ReadDiscreteInputs: {
      if (!within(r.address, r.count, 0, kImageBits))
        return address_error(r.table, r.address, r.count);
      const auto& bytes = r.function == Function::ReadCoils ? q : in;
      for (std::uint32_t i = 0; i < r.count; ++i) {
        const std::uint32_t b = r.address + i;  // emulator-spec §8: byte b/8, bit b%8
        out.bits[i] = (bytes[b / 8] >> (b % 8)) & 1;
      }
      return std::nullopt;
    }
    case Function::ReadHoldingRegisters:
    case Function::ReadInputRegisters:
      return read_registers(r.table, *g, r.address, r.count, out, now);
    case Function::WriteSingleCoil:
    case Function::WriteMultipleCoils: {
      if (!within(r.address, r.count, 0, kImageBits))
        return address_error(r.table, r.address, r.count);
      if (outputs_read_only_) return read_only_error();
      for (std::uint32_t i = 0; i < r.count; ++i) {
        const std::uint32_t b = r.address + i;
        const bool on = r.function == Function::WriteSingleCoil ? r.register_value(0) == kCoilOn
                                                                : r.coil_value(i);
        const auto mask = static_cast<std::uint8_t>(1u << (b % 8));
        q[b / 8] = static_cast<std::uint8_t>(on ? (q[b / 8] | mask) : (q[b / 8] & ~mask));
      }
      return std::nullopt;
    }
    case Function::WriteSingleRegister:
    case Function::WriteMultipleRegisters:
    case Function::MaskWriteRegister:
    case Function::ReadWriteMultipleRegisters: {
      const std::uint16_t wa = r.write_address, wc = r.write_count;
      const bool image = within(wa, wc, 0, kImageRegisters);
      const bool control = within(wa, wc, kControlRegister, kControlRegisters);
      if (!image && !control) return address_error(Table::HoldingRegisters, wa, wc);
      if (image && outputs_read_only_) return read_only_error();
      // FC 23: both ranges are checked before anything is written (all or nothing).
      if (r.function == Function::ReadWriteMultipleRegisters &&
          !within(r.address, r.count, 0, kImageRegisters) &&
          !within(r.address, r.count, kControlRegister, kControlRegisters))
        return address_error(Table::HoldingRegisters, r.address, r.count);
      auto value = [&](std::size_t i) -> std::uint16_t {
        if (r.function != Function::MaskWriteRegister) return r.register_value(i);
        // MB spec §6.16: (current AND and_mask) OR (or_mask AND NOT and_mask).
        const std::uint16_t current = image                        ? image_register(q, wa)
                                      : wa == kControlRegister     ? last_control(g->dp_address())
                                      : wa == kForcedStateRegister ? g->forced_bus_state()
                                                                   : g->drop_remaining();
        return static_cast<std::uint16_t>((current & r.and_mask) | (r.or_mask & ~r.and_mask));
      };
      if (control) {
        // All values are checked before any is applied (all or nothing).
        for (std::uint32_t i = 0; i < wc; ++i) {
          const std::uint16_t v = value(i);
          const std::uint32_t a = wa + i;
          if (a == kControlRegister && v > static_cast<std::uint16_t>(Control::MasterResumes))
            return DecodeFailure{Exception::IllegalDataValue,
                                 "control command " + std::to_string(v) +
                                     " (1 power cycle, 2 re-parameterize, 3 master stops, 4 "
                                     "master resumes)"};
          if (a == kControlRegister)
            if (auto why = g->refuses(static_cast<Control>(v)))
              return DecodeFailure{Exception::ServerDeviceFailure, std::move(*why)};
          if (a == kForcedStateRegister && v > 3)
            return DecodeFailure{Exception::IllegalDataValue,
                                 "forced CAN state " + std::to_string(v) +
                                     " (0 real, 1 warning, 2 error-passive, 3 bus-off)"};
        }
        for (std::uint32_t i = 0; i < wc; ++i) {
          const std::uint16_t v = value(i);
          const std::uint32_t a = wa + i;
          if (a == kControlRegister) {
            for (std::size_t k = 0; k < gateways_.size(); ++k)
              if (gateways_[k] == g) last_control_[k] = v;
            g->control(static_cast<Control>(v), now);
          } else if (a == kForcedStateRegister) {
            if (!g->force_bus_state(v, now))
              return DecodeFailure{Exception::IllegalDataValue, "forcing not supported"};
          } else {
            g->drop_received(v, now);
          }
        }
      } else {
        for (std::uint32_t i = 0; i < wc; ++i) {
          const std::uint16_t v = value(i);
          q[2 * (wa + i)] = static_cast<std::uint8_t>(v >> 8);
          q[2 * (wa + i) + 1] = static_cast<std::uint8_t>(v & 0xFF);
        }
      }
      if (r.function == Function::ReadWriteMultipleRegisters)
        return read_registers(Table::HoldingRegisters, *g, r.address, r.count, out, now);
      return std::nullopt;
    }
  }
  return DecodeFailure{Exception::IllegalFunction, "function not supported"};
}

}  // namespace candp2::modbus

#include "modbus/registers.hpp"

#include <algorithm>

namespace candp2::modbus {

// ---------------------------------------------------------------------------------- status

std::span<const StatusField> status_fields() {
  using namespace status;
  static constexpr StatusField kFields[] = {
      {kDpState, 1, "dp_state", "DP slave state: 0 Wait_Prm, 1 Wait_Cfg, 2 Data_Exch"},
      {kDiag, 11, "diag", "Slave_Diag bytes 0..10, one per register (docs/dp-slave.md)"},
      {kMasterState, 1, "master_state",
       "master's view: 0 Init, 1 Set_Prm, 2 Chk_Cfg, 3 Check_Diag, 4 Data_Exch, 5 Retry"},
      {kBusState, 1, "bus_state", "CAN controller: 0 ok, 1 warning, 2 error-passive, 3 bus-off"},
      {kReleased, 1, "released", "CAN transmission released: 0 no, 1 yes (docs/canopen.md)"},
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
       "PROFIBUS line (docs/profibus.md): 0 none (in-process), 1 role slaves, 2 role master"},
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
  if (in.leds) {
    const auto leds = led::codes(g);
    b[kLedD] = leds.d;
    b[kLedE] = leds.e;
    b[kLedP] = leds.p;
    b[kLedC] = leds.c;
  }
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

}  // namespace candp2::modbus

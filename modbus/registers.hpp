// The register layout of the Modbus face (docs/modbus.md): the process image, the per-gateway
// status block from input register 8192 and how a gateway's state is encoded into it, the LED
// codes, the control and fault registers. One source of truth: `candp2d --print-modbus-map`
// (text and --json) and the candp2 Python package read these tables.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "bitrate/bitrate_status.hpp"
#include "gateway/gateway.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::modbus {

// ---- the map of docs/modbus.md ---------------------------------------------------------------

inline constexpr std::uint16_t kImageRegisters = 4096;   // registers 0..4095 = image bytes 0..8191
inline constexpr std::uint32_t kImageBits = 65536;       // coils / discrete inputs 0..65535
inline constexpr std::uint16_t kStatusBase = 8192;       // input registers 8192.. per gateway
inline constexpr std::uint16_t kControlRegister = 8192;  // holding register 8192
// Fault injection (docs/faults.md): holding register 8193 = forced CAN controller state (0 real,
// 1 warning, 2 error-passive, 3 bus-off), 8194 = drop the next N received frames (reads:
// remaining).
inline constexpr std::uint16_t kForcedStateRegister = 8193;
inline constexpr std::uint16_t kDropRxRegister = 8194;
inline constexpr std::uint16_t kControlRegisters = 3;  // 8192..8194
// A generic slave's faults (docs/faults.md "Generic slaves"), holding registers of its DP-address
// unit: 8195 on the bus (1) or off it (0), 8196 / 8197 a Prm / Cfg fault forced (1) or not (0),
// 8198 the diagnosis alarm's length n (0: none; writing it applies the alarm), 8199..8229 its bytes
// (1..62, byte 2i high and 2i+1 low in register 8199 + i).
inline constexpr std::uint16_t kSlaveFaultBase = 8195;
inline constexpr std::uint16_t kSlaveOnBus = 0;  // offsets from kSlaveFaultBase
inline constexpr std::uint16_t kSlavePrmFault = 1;
inline constexpr std::uint16_t kSlaveCfgFault = 2;
inline constexpr std::uint16_t kSlaveAlarmLength = 3;
inline constexpr std::uint16_t kSlaveAlarmBytes = 4;
inline constexpr std::uint16_t kSlaveAlarmMax = 62;  // device-related Ext_Diag bytes
inline constexpr std::uint16_t kSlaveFaultRegisters = kSlaveAlarmBytes + kSlaveAlarmMax / 2;

// The status block from input register 8192 (docs/modbus.md). Offsets from kStatusBase.
namespace status {
inline constexpr std::uint16_t kDpState = 0;       // 0 Wait_Prm, 1 Wait_Cfg, 2 Data_Exch
inline constexpr std::uint16_t kDiag = 1;          // 1..11: diagnosis bytes 0..10
inline constexpr std::uint16_t kMasterState = 12;  // the master's view of this slave
inline constexpr std::uint16_t kBusState = 13;     // 0 ok, 1 warning, 2 error-passive, 3 bus-off
inline constexpr std::uint16_t kReleased = 14;     // CAN transmission released (docs/canopen.md)
inline constexpr std::uint16_t kNmtState =
    15;  // 0 initialising, 1 pre-op, 2 operational, 3 stopped
inline constexpr std::uint16_t kRxFrames = 16;   // 16-17, 32 bit, high word first
inline constexpr std::uint16_t kTxFrames = 18;   // 18-19
inline constexpr std::uint16_t kIrqLost = 20;    // 20-21 (docs/dp-slave.md "Diagnosis")
inline constexpr std::uint16_t kMsgLost = 22;    // 22-23 (docs/dp-slave.md "Diagnosis")
inline constexpr std::uint16_t kFifoLevel = 24;  // Communication Window FIFO (manual §5.3)
inline constexpr std::uint16_t kFifoHighWater = 25;
inline constexpr std::uint16_t kSyncMs = 26;         // effective SYNC time
inline constexpr std::uint16_t kWakeupS = 27;        // stored wake-up time
inline constexpr std::uint16_t kDataExchanges = 28;  // 28-29, gateway side
inline constexpr std::uint16_t kLedD = 30;           // manual table 3.3.1 (led:: codes)
inline constexpr std::uint16_t kLedE = 31;
inline constexpr std::uint16_t kLedP = 32;
inline constexpr std::uint16_t kLedC = 33;
inline constexpr std::uint16_t kDpAddress = 34;
inline constexpr std::uint16_t kParameterizations = 35;  // 35-36, master side
// ---- The CAN bit rate (SocketCAN "bitrate": "check" / "apply", docs/transports.md).
// One contiguous group; 0 where unknown (not a SocketCAN bus, no Set_Prm yet, vcan).
inline constexpr std::uint16_t kBitrateMode = 37;        // 0 none, 1 check, 2 apply
inline constexpr std::uint16_t kBitrateConfigured = 38;  // 38-39 bit/s from Set_Prm byte 8
inline constexpr std::uint16_t kBitrateInterface = 40;   // 40-41 bit/s of the interface
inline constexpr std::uint16_t kBitrateMismatch = 42;    // 1 = they differ by more than 1 %
// The PROFIBUS line (docs/profibus.md; zero without a `profibus` section).
inline constexpr std::uint16_t kLineRole = 43;         // 0 in-process, 1 role slaves, 2 role master
inline constexpr std::uint16_t kLineTelegrams = 44;    // 44-45 good telegrams on the line
inline constexpr std::uint16_t kLineFcsErrors = 46;    // 46-47
inline constexpr std::uint16_t kLineOtherErrors = 48;  // 48-49 framing, parity, truncated
inline constexpr std::uint16_t kStationRequests = 50;  // 50-51 requests to this station
inline constexpr std::uint16_t kStationRetries = 52;   // 52-53 repetitions (FCB / master retries)
inline constexpr std::uint16_t kResponseUs = 54;       // last response time, µs (max 65535)
inline constexpr std::uint16_t kResponseMaxUs = 55;    // highest response time, µs
inline constexpr std::uint16_t kStationPresent = 56;   // 1 talking to a master / answering
// Fault injection and transport faults (docs/faults.md).
inline constexpr std::uint16_t kForcedState = 57;   // holding register 8193 as written (0 = real)
inline constexpr std::uint16_t kTxSuppressed = 58;  // 58-59 frames not sent in a forced bus-off
inline constexpr std::uint16_t kRxSuppressed = 60;  // 60-61 not received in a forced bus-off
inline constexpr std::uint16_t kRxDropRemaining = 62;  // holding register 8194 (saturates 0xFFFF)
inline constexpr std::uint16_t kAddressed = 63;   // 1 = the master addresses it, 0 = stopped (3)
inline constexpr std::uint16_t kReconnects = 64;  // 64-65 socketcand client reconnections
// The DP master's cycle (docs/daemon.md "Cycle timing"): the same value in every gateway's block.
inline constexpr std::uint16_t kCyclesMissed = 66;  // 66-67 grid points without a master cycle
inline constexpr std::uint16_t kCount = 68;
}  // namespace status

// A station's whole Slave_Diag answer (docs/modbus.md "Whole diagnosis"), input registers of its
// unit after the status block: 8260 = its length n (0: none yet), 8261.. = the bytes, 2i (high)
// and 2i+1 (low) in register 8261 + i, up to the 244 bytes IEC 61158-6-3 allows. The status
// block's `diag` field holds only the first 11 (the CAN-DP/2's whole diagnosis); a generic slave's
// Ext_Diag_Data may run longer.
inline constexpr std::uint16_t kDiagnosisBase = kStatusBase + status::kCount;  // 8260
inline constexpr std::uint16_t kDiagnosisRegisters = 1 + dp::kDiagMaxLen / 2;  // 8260..8382

// LED codes in the status block (manual §3.3, table 3.3.1).
namespace led {
inline constexpr std::uint16_t kOff = 0;
inline constexpr std::uint16_t kOn = 1;
// LED E: n short flashes (3 = waiting for Set_Prm, 4 = waiting for Chk_Cfg) are the value n.
inline constexpr std::uint16_t kMorseE = 0x45;  // LED C: 'E' CAN error (error passive)
inline constexpr std::uint16_t kMorseW = 0x57;  // LED C: 'W' CAN warning
inline constexpr std::uint16_t kMorseO = 0x4F;  // LED C: 'O' CAN off (bus off)

// The four LEDs' codes for a gateway state (manual table 3.3.1): the status block, the HTTP face's
// page and its JSON all show these.
struct Codes {
  std::uint16_t p = kOn, d = kOff, e = kOff, c = kOn;
};
Codes codes(const gw::GatewayStatus& g);
}  // namespace led

// Holding register 8192 commands (docs/modbus.md).
enum class Control : std::uint16_t {
  None = 0,
  PowerCycle = 1,
  Reparameterize = 2,
  MasterStops = 3,    // the master stops addressing this gateway (docs/faults.md)
  MasterResumes = 4,  // the master addresses it again and parameterizes it
};
// Every command with the name the JSON map (map_json.hpp) and the candp2 Python package use.
struct ControlCommand {
  Control command;
  std::string_view name;
  std::string_view meaning;
};
std::span<const ControlCommand> control_commands();

// Unit IDs that address the first configured gateway (docs/modbus.md "Unit IDs": clients that
// always send 0 or 255 keep working).
inline constexpr std::array<std::uint8_t, 2> kFirstGatewayUnits = {0, 255};

using StatusBlock = std::array<std::uint16_t, status::kCount>;
// A 32-bit field of the status block: high word at `at`, low word at `at + 1` (docs/modbus.md).
inline std::uint32_t get32(const StatusBlock& b, std::uint16_t at) {
  return (static_cast<std::uint32_t>(b[at]) << 16) | b[at + 1];
}

// Everything a status block shows, gathered by the owner of gateway and master.
// The CAN bit rate group (kBitrate*): the daemon's view of the SocketCAN interface.
using bitrate::BitrateStatus;

struct StatusInputs {
  gw::GatewayStatus gateway;
  // The CAN-DP/2's front LEDs (manual table 3.3.1); a generic slave has none: the LED registers
  // read 0.
  bool leds = true;
  BitrateStatus bitrate;
  dp::DpSlave::Diag diag{};
  std::optional<dp::MasterSlaveState> master_state;
  std::uint32_t parameterizations = 0;
  std::uint8_t dp_address = 0;
  struct Line {
    std::uint16_t role = 0;  // 1 slaves, 2 master
    std::uint32_t telegrams = 0, fcs_errors = 0, other_errors = 0;
    std::uint32_t requests = 0, retries = 0;
    std::uint32_t response_us = 0, response_max_us = 0;
    bool present = false;
  };
  std::optional<Line> line;
  bool addressed = true;
  // Fault injection (docs/faults.md).
  std::uint16_t forced_state = 0;
  std::uint32_t tx_suppressed = 0;
  std::uint32_t rx_suppressed = 0;
  std::uint32_t rx_drop_remaining = 0;
  std::uint32_t reconnects = 0;
  std::uint64_t cycles_missed = 0;  // the master's (saturates at 2^32 - 1)
};
StatusBlock encode_status(const StatusInputs& in);

// The status block's fields, for `candp2d --print-modbus-map` and logs.
struct StatusField {
  std::uint16_t offset;     // from kStatusBase
  std::uint16_t registers;  // 1, or 2 for 32-bit values (high word first)
  std::string_view name;
  std::string_view meaning;
};
std::span<const StatusField> status_fields();

}  // namespace candp2::modbus

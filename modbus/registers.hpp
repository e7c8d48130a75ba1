// The register layout of the Modbus face (docs/modbus.md): the process image, the per-gateway
// status block from input register 8192 (the station table of station/status.hpp, one field after
// the other) and how a station's status is encoded into it, the control and fault registers. One
// source of truth: `candp2d --print-modbus-map` (text and --json) and the candp2 Python package
// read these tables.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "common/host_stalls.hpp"
#include "config/config.hpp"
#include "gateway/gateway.hpp"
#include "profibus_sim/fdl/line_stats.hpp"
#include "profibus_sim/fdl/wire_faults.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "station/status.hpp"

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

// The status block from input register 8192 (docs/modbus.md): the fields of the station table
// (station/status.hpp) one after the other, each 1 register (16 bit), 2 (32 bit, high word first)
// or, for the diagnosis, 11.
namespace status {
// A field's offset from kStatusBase; a name the table lacks does not compile.
consteval std::uint16_t offset_of(std::string_view name) {
  std::uint16_t at = 0;
  for (const auto& f : station::kFields) {
    if (f.name == name) return at;
    at = static_cast<std::uint16_t>(at + f.registers);
  }
  throw "no such field in station::kFields";
}
// The fields the faces read by name (offsets from kStatusBase).
inline constexpr std::uint16_t kDpState = offset_of("dp_state");
inline constexpr std::uint16_t kDiag = offset_of("diag");
inline constexpr std::uint16_t kMasterState = offset_of("master_state");
inline constexpr std::uint16_t kBusState = offset_of("bus_state");
inline constexpr std::uint16_t kReleased = offset_of("released");
inline constexpr std::uint16_t kNmtState = offset_of("nmt_state");
inline constexpr std::uint16_t kRxFrames = offset_of("rx_frames");
inline constexpr std::uint16_t kTxFrames = offset_of("tx_frames");
inline constexpr std::uint16_t kIrqLost = offset_of("irq_lost");
inline constexpr std::uint16_t kMsgLost = offset_of("msg_lost");
inline constexpr std::uint16_t kFifoLevel = offset_of("fifo_level");
inline constexpr std::uint16_t kFifoHighWater = offset_of("fifo_high_water");
inline constexpr std::uint16_t kSyncMs = offset_of("sync_ms");
inline constexpr std::uint16_t kWakeupS = offset_of("wakeup_s");
inline constexpr std::uint16_t kDataExchanges = offset_of("data_exchanges");
inline constexpr std::uint16_t kLedD = offset_of("led_d");
inline constexpr std::uint16_t kLedE = offset_of("led_e");
inline constexpr std::uint16_t kLedP = offset_of("led_p");
inline constexpr std::uint16_t kLedC = offset_of("led_c");
inline constexpr std::uint16_t kDpAddress = offset_of("dp_address");
inline constexpr std::uint16_t kParameterizations = offset_of("parameterizations");
inline constexpr std::uint16_t kBitrateMode = offset_of("bitrate_mode");
inline constexpr std::uint16_t kBitrateConfigured = offset_of("bitrate_configured");
inline constexpr std::uint16_t kBitrateInterface = offset_of("bitrate_interface");
inline constexpr std::uint16_t kBitrateMismatch = offset_of("bitrate_mismatch");
inline constexpr std::uint16_t kLineRole = offset_of("line_role");
inline constexpr std::uint16_t kLineTelegrams = offset_of("line_telegrams");
inline constexpr std::uint16_t kLineFcsErrors = offset_of("line_fcs_errors");
inline constexpr std::uint16_t kLineOtherErrors = offset_of("line_other_errors");
inline constexpr std::uint16_t kStationRequests = offset_of("station_requests");
inline constexpr std::uint16_t kStationRetries = offset_of("station_retries");
inline constexpr std::uint16_t kResponseUs = offset_of("response_us");
inline constexpr std::uint16_t kResponseMaxUs = offset_of("response_max_us");
inline constexpr std::uint16_t kStationPresent = offset_of("station_present");
inline constexpr std::uint16_t kForcedState = offset_of("forced_can_state");
inline constexpr std::uint16_t kTxSuppressed = offset_of("tx_suppressed");
inline constexpr std::uint16_t kRxSuppressed = offset_of("rx_suppressed");
inline constexpr std::uint16_t kRxDropRemaining = offset_of("rx_drop_remaining");
inline constexpr std::uint16_t kAddressed = offset_of("addressed");
inline constexpr std::uint16_t kReconnects = offset_of("reconnects");
inline constexpr std::uint16_t kCyclesMissed = offset_of("master_cycles_missed");
// The block's length: every field's registers.
inline constexpr std::uint16_t kCount = [] {
  std::uint16_t n = 0;
  for (const auto& f : station::kFields) n = static_cast<std::uint16_t>(n + f.registers);
  return n;
}();
// Published register numbers (docs/modbus.md): rows never move, new fields go at the end.
static_assert(kRxFrames == 16 && kParameterizations == 35 && kCyclesMissed == 66);
}  // namespace status

// A station's whole Slave_Diag answer (docs/modbus.md "Whole diagnosis"), input registers of its
// unit after the status block: 8260 = its length n (0: none yet), 8261.. = the bytes, 2i (high)
// and 2i+1 (low) in register 8261 + i, up to the 244 bytes IEC 61158-6-3 allows. The status
// block's `diag` field holds only the first 11 (the CAN-DP/2's whole diagnosis); a generic slave's
// Ext_Diag_Data may run longer.
inline constexpr std::uint16_t kDiagnosisBase = 8260;
// The status block ends where the whole diagnosis begins: 8192..8259 are taken, so the next field
// of the station table needs registers of its own first (docs/development.md "Add a counter").
static_assert(kStatusBase + status::kCount <= kDiagnosisBase,
              "the status block runs into the whole diagnosis at 8260 (docs/modbus.md)");
inline constexpr std::uint16_t kDiagnosisRegisters = 1 + dp::kDiagMaxLen / 2;  // 8260..8382

// The line block (docs/modbus.md "Line block"), on a line whose statistics the daemon counts
// (a line in time, profibus role master); elsewhere these addresses answer exception 0x02.
// Input registers of the station's unit: the analyser's counters (fdl::kStationCounters, 32 bit
// each, high word first, in the table's order), its live state, then the line's measured bus
// cycle last/min/mean/max in µs and the rotations measured (32 bit each; the same in every unit).
// Holding registers: a line fault for the station (kind, count, every, for_ms; writing the kind
// applies it) and noise on the whole line (for_ms).
inline constexpr std::uint16_t kLineBase = 8400;
namespace line {
inline constexpr std::uint16_t kCounters = 0;  // 2 registers a counter
inline constexpr std::uint16_t kLive = kCounters + 2 * fdl::kStationCounterCount;
inline constexpr std::uint16_t kBusCycle = kLive + 1;  // last, min, mean, max, cycles
inline constexpr std::uint16_t kCount = kBusCycle + 2 * 5;
static_assert(kLive == 12 && kCount == 23, "published register numbers (docs/modbus.md)");
// Holding registers from kLineBase.
inline constexpr std::uint16_t kFaultKind = 0;  // 0 none (cancel), 1 corrupt .. 4 double_address
inline constexpr std::uint16_t kFaultCount = 1;
inline constexpr std::uint16_t kFaultEvery = 2;
inline constexpr std::uint16_t kFaultForMs = 3;
inline constexpr std::uint16_t kNoiseForMs = 4;
inline constexpr std::uint16_t kFaultRegisters = 5;
}  // namespace line
using LineBlock = std::array<std::uint16_t, line::kCount>;
// Whether a configuration's stations have the line block: a line in time or profibus role master.
inline bool has_line_block(const config::DaemonConfig& c) {
  return c.line.has_value() || c.remote_gateways();
}

// The CAN fault block (docs/modbus.md "CAN fault block"): holding registers of a gateway's unit
// whose bus is a bus in time (docs/can-bus.md "The bus in time"), next to the line faults and with
// their semantics: the kind applies the fault with count, every and for_ms as last written, on
// the gateway's node (its CAN controller), or on its whole bus (noise). Elsewhere these addresses
// answer exception 0x02. The kinds are plant::CanFaultKind's codes (plant/can_fault.hpp).
inline constexpr std::uint16_t kCanFaultBase = 8410;
struct CanFaultField {
  std::string_view name;
  std::string_view meaning;
};
inline constexpr std::array<CanFaultField, 4> kCanFaultFields = {{
    {"kind",
     "the CAN fault (docs/faults.md \"CAN faults\"): 0 none (cancels), 1 error_frames (the "
     "gateway's next frames end in an error frame), 2 unplugged, 3 wrong_bitrate, 4 noise (the "
     "whole bus); applied when written, with the others as last written"},
    {"count", "how many frames (default 1)"},
    {"every", "one frame in every K (1..65535, default 1; 0 is exception 0x03)"},
    {"for_ms",
     "instead of a count, this long (0 = use the count; noise needs it; unplugged and "
     "wrong_bitrate end by themselves after it, 0 = until none)"},
}};
namespace can_fault {
inline constexpr std::uint16_t kKind = 0;  // offsets from kCanFaultBase, the table's order
inline constexpr std::uint16_t kCount = 1;
inline constexpr std::uint16_t kEvery = 2;
inline constexpr std::uint16_t kForMs = 3;
inline constexpr std::uint16_t kRegisters = kCanFaultFields.size();  // 8410..8413
}  // namespace can_fault
static_assert(kLineBase + line::kFaultRegisters <= kCanFaultBase,
              "the CAN fault block follows the line faults (docs/modbus.md)");
static_assert(kCanFaultFields[can_fault::kKind].name == "kind" &&
              kCanFaultFields[can_fault::kForMs].name == "for_ms");

// The host block (docs/modbus.md "Host block"): input registers of every unit, the host stalls
// candp2d's simulated clock kept from the world (docs/daemon.md "Host stalls"), 32 bit each, high
// word first, saturating: how many, their time in all (ms), the longest (ms). Zeros where the
// world never stalls.
inline constexpr std::uint16_t kHostBase = 8440;
struct HostField {
  std::string_view name;
  std::string_view meaning;
  std::uint64_t (*value)(const HostStalls&);
};
inline constexpr std::array<HostField, 3> kHostFields = {{
    {"host_stalls", "host stalls: loop wakes more than master.host_stall_ms late",
     [](const HostStalls& h) { return h.count; }},
    {"host_stall_total_ms", "the host stalls' time in all, ms",
     [](const HostStalls& h) { return static_cast<std::uint64_t>(h.total.count() / 1000); }},
    {"host_stall_longest_ms", "the longest host stall, ms",
     [](const HostStalls& h) { return static_cast<std::uint64_t>(h.longest.count() / 1000); }},
}};
inline constexpr std::uint16_t kHostRegisters = 2 * kHostFields.size();  // 8440..8445
static_assert(kLineBase + line::kCount <= kHostBase, "the host block follows the line block");
static_assert(kCanFaultBase + can_fault::kRegisters <= kHostBase);
// Whether a configuration's gateways have the CAN fault block: one of them is on a bus in time.
inline bool has_can_fault_block(const config::DaemonConfig& c) {
  for (const auto& g : c.gateways)
    for (const auto& b : c.buses)
      if (b.name == g.bus && b.timed_bitrate) return true;
  return false;
}
using HostBlock = std::array<std::uint16_t, kHostRegisters>;
HostBlock encode_host_stalls(const HostStalls& h);

// LED codes in the status block (manual §3.3, table 3.3.1): station/status.hpp.
namespace led = station::led;

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

// Everything a status block shows (station/status.hpp), gathered by the owner of gateway and
// master (plant/station_status.hpp).
using BitrateStatus = station::BitrateStatus;
using StatusInputs = station::Status;
StatusBlock encode_status(const StatusInputs& in);

// The status block's fields with their places, for `candp2d --print-modbus-map` and logs: the
// station table (station/status.hpp) in block order.
struct StatusField {
  std::uint16_t offset;     // from kStatusBase
  std::uint16_t registers;  // 1, 2 for 32-bit values (high word first), 11 for the diagnosis
  std::string_view name;
  std::string_view meaning;
};
std::span<const StatusField> status_fields();
// The offset of a field of station::kFields.
std::uint16_t offset_of(const station::Field& f);
// A field's value in a block: one register, or two combined (high word first).
std::uint32_t field_value(const StatusBlock& b, const station::Field& f);

}  // namespace candp2::modbus

// What a station (a CAN-DP/2 gateway, a generic DP slave, a remote station on a line) shows of
// itself: its status (station::Status, gathered by plant/station_status.hpp from the plant) and the
// one table of its fields and counters (docs/architecture.md "One vocabulary"): name, unit, meaning
// and how to read it. Every face iterates this table: the Modbus status block and its map
// (modbus/registers.hpp, `candp2d --print-modbus-map [--json]`, so the candp2 Python package),
// GET /api/v1/status and GET /metrics (http/), replay's expect_counters (replay/). A new counter
// is one row here and the field of Status it reads.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "gateway/gateway.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "station/line_status.hpp"

namespace candp2::station {

// The CAN bit rate of a gateway on a SocketCAN bus (docs/transports.md): the daemon's view.
struct BitrateStatus {
  std::uint16_t mode = 0;        // 0 none, 1 check, 2 apply
  std::uint32_t configured = 0;  // bit/s, 0 before the first Set_Prm
  std::uint32_t interface = 0;   // bit/s, 0 = no bit timing (virtual) or not readable
  bool mismatch = false;
};

// Everything a station's status shows, gathered by the owner of gateway and master.
struct Status {
  gw::GatewayStatus gateway;
  // The CAN-DP/2's front LEDs (manual table 3.3.1); a generic slave has none: they read 0.
  bool leds = true;
  BitrateStatus bitrate;
  dp::DpSlave::Diag diag{};
  std::optional<dp::MasterSlaveState> master_state;
  std::uint32_t parameterizations = 0;
  std::uint8_t dp_address = 0;
  std::optional<LineStatus> line;  // the plant's line figures (station/line_status.hpp)
  bool addressed = true;
  // Fault injection (docs/faults.md).
  std::uint16_t forced_state = 0;
  std::uint32_t tx_suppressed = 0;
  std::uint32_t rx_suppressed = 0;
  std::uint32_t rx_drop_remaining = 0;
  std::uint32_t reconnects = 0;
  std::uint64_t cycles_missed = 0;  // the master's
};

// LED codes (manual §3.3, table 3.3.1).
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

// A Prometheus family a field feeds in GET /metrics (docs/daemon.md "Metrics"), one series per
// station. `rank` orders the families of one kind of station (1 first; 0 = not a metric). An
// empty `type` continues the family of the row ranked before it with another `reason` label.
struct Metric {
  std::uint8_t rank = 0;
  std::string_view name = {};
  std::string_view type = {};    // "counter", "gauge"; empty: the family's second series
  std::string_view help = {};    // empty: the field's meaning
  std::string_view reason = {};  // the value of a `reason` label, or empty
};

// Where else a field shows (bit set).
enum Shown : std::uint8_t {
  kGatewayCounters = 1,  // a gateway's "counters" object in GET /api/v1/status
  kSlaveCounters = 2,    // a generic slave's "counters" object
};

// One field of a station's status. In the Modbus status block its value is 16 bit (saturating at
// 0xFFFF) or 32 bit (saturating at 2^32 - 1); the diagnosis is the one field of several values
// (Status::diag, one byte a register). The other faces show the value as it is.
struct Field {
  std::string_view name = {};   // status block field, JSON key, expect_counters name (public)
  std::uint16_t registers = 1;  // 1 (16 bit), 2 (32 bit), or the diagnosis' 11
  std::string_view unit = {};   // of the value ("frames", "ms", ...); empty for codes and flags
  std::string_view meaning = {};
  // The value as the status holds it (32 or 64 bit); only the Modbus face saturates it to its
  // registers (modbus::encode_status). Null only for the diagnosis.
  std::uint64_t (*get)(const Status&) = nullptr;
  std::uint8_t shown = 0;   // Shown bits
  Metric gateway_metric{};  // a gateway's /metrics family
  Metric slave_metric{};    // a generic slave's /metrics family
  // Position among replay's expect_counters names (docs/replay-format.md; 0 = not one).
  std::uint8_t replay = 0;
};

// Saturating 16-bit and 32-bit readings (the Modbus registers).
constexpr std::uint32_t sat16(std::uint64_t v) {
  return v > 0xFFFF ? 0xFFFF : static_cast<std::uint32_t>(v);
}
constexpr std::uint32_t sat32(std::uint64_t v) {
  return v > 0xFFFFFFFFu ? 0xFFFFFFFFu : static_cast<std::uint32_t>(v);
}

// Every field, in the order of the Modbus status block (docs/modbus.md): their registers follow
// one another from input register 8192 in this order, so a new field goes at the end.
// clang-format off
inline constexpr Field kFields[] = {
    {.name = "dp_state", .meaning = "DP slave state: 0 Wait_Prm, 1 Wait_Cfg, 2 Data_Exch",
     .get = [](const Status& s) -> std::uint64_t { return std::uint32_t(s.gateway.dp_state); },
     .gateway_metric = {9, "candp2_gateway_dp_state", "gauge", "", ""},
     .slave_metric = {1, "candp2_slave_dp_state", "gauge",
                      "generic DP slave state: 0 Wait_Prm, 1 Wait_Cfg, 2 Data_Exch", ""}},
    {.name = "diag", .registers = 11,
     .meaning = "Slave_Diag bytes 0..10, one per register (docs/dp-slave.md)"},
    {.name = "master_state",
     .meaning = "master's view: 0 Init, 1 Set_Prm, 2 Chk_Cfg, 3 Check_Diag, 4 Data_Exch, 5 Retry",
     .get = [](const Status& s) -> std::uint64_t {
          return s.master_state ? std::uint32_t(*s.master_state) : 0u; }},
    {.name = "bus_state", .meaning = "CAN controller: 0 ok, 1 warning, 2 error-passive, 3 bus-off",
     .get = [](const Status& s) -> std::uint64_t { return std::uint32_t(s.gateway.bus_state); },
     .gateway_metric = {10, "candp2_gateway_can_bus_state", "gauge", "", ""}},
    {.name = "released", .meaning = "CAN transmission released: 0 no, 1 yes (docs/canopen.md)",
     .get = [](const Status& s) -> std::uint64_t { return s.gateway.released ? 1u : 0u; }},
    {.name = "nmt_state",
     .meaning = "CANopen NMT state: 0 initialising, 1 pre-operational, 2 operational, 3 stopped",
     .get = [](const Status& s) -> std::uint64_t { return std::uint32_t(s.gateway.nmt); }},
    {.name = "rx_frames", .registers = 2, .unit = "frames",
     .meaning = "CAN frames received since power-on",
     .get = [](const Status& s) -> std::uint64_t {
          return s.gateway.rx_frames; }, .shown = kGatewayCounters,
     .gateway_metric = {1, "candp2_gateway_can_frames_received_total", "counter",
                        "CAN frames the gateway received since power-on", ""},
     .replay = 3},
    {.name = "tx_frames", .registers = 2, .unit = "frames",
     .meaning = "CAN frames sent since power-on",
     .get = [](const Status& s) -> std::uint64_t {
          return s.gateway.tx_frames; }, .shown = kGatewayCounters,
     .gateway_metric = {2, "candp2_gateway_can_frames_sent_total", "counter",
                        "CAN frames the gateway sent since power-on", ""},
     .replay = 4},
    {.name = "irq_lost", .registers = 2, .unit = "frames",
     .meaning = "frames lost before the gateway saw them (IRQ_LOST)",
     .get = [](const Status& s) -> std::uint64_t {
          return s.gateway.irq_lost; }, .shown = kGatewayCounters,
     .gateway_metric = {3, "candp2_gateway_can_frames_lost_total", "counter",
                        "CAN frames lost: irq = before the gateway saw them (IRQ_LOST), fifo = "
                        "dropped at the full Communication Window FIFO (MSG_LOST), "
                        "docs/dp-slave.md", "irq"},
     .replay = 1},
    {.name = "msg_lost", .registers = 2, .unit = "frames",
     .meaning = "frames dropped at the full CW FIFO (MSG_LOST)",
     .get = [](const Status& s) -> std::uint64_t {
          return s.gateway.msg_lost; }, .shown = kGatewayCounters,
     .gateway_metric = {4, "candp2_gateway_can_frames_lost_total", "", "", "fifo"},
     .replay = 2},
    {.name = "fifo_level", .unit = "frames",
     .meaning = "frames waiting in the Communication Window FIFO",
     .get = [](const Status& s) -> std::uint64_t { return s.gateway.fifo_level; },
     .gateway_metric = {7, "candp2_gateway_fifo_level", "gauge",
                        "frames waiting in the Communication Window FIFO (manual §5.3)", ""}},
    {.name = "fifo_high_water", .unit = "frames", .meaning = "highest FIFO level since power-on",
     .get = [](const Status& s) -> std::uint64_t { return s.gateway.fifo_high_water; },
     .gateway_metric = {8, "candp2_gateway_fifo_high_water", "gauge", "", ""}},
    {.name = "sync_ms", .unit = "ms", .meaning = "effective SYNC time, ms (0 = off)",
     .get = [](const Status& s) -> std::uint64_t { return std::uint32_t{s.gateway.sync_ms}; }},
    {.name = "wakeup_s", .unit = "s", .meaning = "stored wake-up time, s",
     .get = [](const Status& s) -> std::uint64_t { return std::uint32_t{s.gateway.wakeup_s}; }},
    {.name = "data_exchanges", .registers = 2, .unit = "telegrams",
     .meaning = "Data_Exchange telegrams the gateway answered",
     .get = [](const Status& s) -> std::uint64_t { return s.gateway.data_exchanges; },
     .shown = kGatewayCounters | kSlaveCounters,
     .gateway_metric = {5, "candp2_gateway_data_exchanges_total", "counter", "", ""},
     .slave_metric = {2, "candp2_slave_data_exchanges_total", "counter",
                      "Data_Exchange telegrams the built-in master completed with the generic DP "
                      "slave", ""}},
    {.name = "led_d", .meaning = "LED D (Data Exchange): 0 off, 1 on",
     .get = [](const Status& s) -> std::uint64_t {
          return s.leds ? std::uint32_t{led::codes(s.gateway).d} : 0u; }},
    {.name = "led_e",
     .meaning = "LED E (DP status): 0 off, 3 = 3 flashes (waiting for Set_Prm), 4 = 4 flashes "
                "(Chk_Cfg)",
     .get = [](const Status& s) -> std::uint64_t {
          return s.leds ? std::uint32_t{led::codes(s.gateway).e} : 0u; }},
    {.name = "led_p", .meaning = "LED P (power): 1 on",
     .get = [](const Status& s) -> std::uint64_t {
          return s.leds ? std::uint32_t{led::codes(s.gateway).p} : 0u; }},
    {.name = "led_c",
     .meaning = "LED C (CAN): 1 on (ok), 0x45 Morse E (error passive), 0x57 W (warning), 0x4F O "
                "(bus off)",
     .get = [](const Status& s) -> std::uint64_t {
          return s.leds ? std::uint32_t{led::codes(s.gateway).c} : 0u; }},
    {.name = "dp_address", .meaning = "the gateway's DP station address",
     .get = [](const Status& s) -> std::uint64_t { return std::uint32_t{s.dp_address}; }},
    {.name = "parameterizations", .registers = 2, .unit = "telegrams",
     .meaning = "Set_Prm telegrams the master sent",
     .get = [](const Status& s) -> std::uint64_t { return s.parameterizations; },
     .shown = kGatewayCounters | kSlaveCounters,
     .gateway_metric = {6, "candp2_gateway_parameterizations_total", "counter",
                        "Set_Prm telegrams the master sent to the gateway", ""},
     .slave_metric = {3, "candp2_slave_parameterizations_total", "counter",
                      "Set_Prm telegrams the built-in master sent to the generic DP slave", ""}},
    {.name = "bitrate_mode",
     .meaning = "SocketCAN bit rate handling: 0 none (not SocketCAN), 1 check, 2 apply",
     .get = [](const Status& s) -> std::uint64_t { return std::uint32_t{s.bitrate.mode}; }},
    {.name = "bitrate_configured", .registers = 2, .unit = "bit/s",
     .meaning = "CAN bit rate of the gateway's Set_Prm byte 8, bit/s (0 before Set_Prm)",
     .get = [](const Status& s) -> std::uint64_t { return s.bitrate.configured; }},
    {.name = "bitrate_interface", .registers = 2, .unit = "bit/s",
     .meaning = "bit rate of the SocketCAN interface, bit/s (0 = no bit timing, e.g. vcan)",
     .get = [](const Status& s) -> std::uint64_t { return s.bitrate.interface; }},
    {.name = "bitrate_mismatch",
     .meaning = "1 = the interface's bit rate differs from Set_Prm's by more than 1 %",
     .get = [](const Status& s) -> std::uint64_t { return s.bitrate.mismatch ? 1u : 0u; }},
    {.name = "line_role",
     .meaning = "PROFIBUS line (docs/profibus.md): 0 none (in-process), 1 role slaves, 2 role "
                "master",
     .get = [](const Status& s) -> std::uint64_t {
          return s.line ? std::uint32_t{s.line->role} : 0u; }},
    {.name = "line_telegrams", .registers = 2, .unit = "telegrams",
     .meaning = "good FDL telegrams received on the line",
     .get = [](const Status& s) -> std::uint64_t { return s.line ? s.line->telegrams : 0u; }},
    {.name = "line_fcs_errors", .registers = 2, .unit = "telegrams",
     .meaning = "telegrams dropped for a wrong FCS",
     .get = [](const Status& s) -> std::uint64_t { return s.line ? s.line->fcs_errors : 0u; }},
    {.name = "line_other_errors", .registers = 2, .unit = "telegrams",
     .meaning = "telegrams dropped for framing (LE/LEr, ED, truncated) or parity errors",
     .get = [](const Status& s) -> std::uint64_t { return s.line ? s.line->other_errors : 0u; }},
    {.name = "station_requests", .registers = 2, .unit = "telegrams",
     .meaning = "requests addressed to this station",
     .get = [](const Status& s) -> std::uint64_t { return s.line ? s.line->requests : 0u; }},
    {.name = "station_retries", .registers = 2, .unit = "telegrams",
     .meaning = "role slaves: FCB repetitions answered; role master: requests repeated (no answer)",
     .get = [](const Status& s) -> std::uint64_t { return s.line ? s.line->retries : 0u; }},
    {.name = "response_us", .unit = "µs",
     .meaning = "last response time, µs: role slaves request end → answer written; role master "
                "request written → answer complete (65535 = longer)",
     .get = [](const Status& s) -> std::uint64_t { return s.line ? s.line->response_us : 0u; }},
    {.name = "response_max_us", .unit = "µs", .meaning = "highest response time since start, µs",
     .get = [](const Status& s) -> std::uint64_t { return s.line ? s.line->response_max_us : 0u; }},
    {.name = "station_present",
     .meaning = "role slaves: 1 while a master talks to the station; role master: 1 while it "
                "answers",
     .get = [](const Status& s) -> std::uint64_t { return s.line && s.line->present ? 1u : 0u; }},
    {.name = "forced_can_state",
     .meaning = "holding register 8193: 0 real, 1 warning, 2 error-passive, 3 bus-off "
                "(docs/faults.md)",
     .get = [](const Status& s) -> std::uint64_t { return std::uint32_t{s.forced_state}; }},
    {.name = "tx_suppressed", .registers = 2, .unit = "frames",
     .meaning = "frames not sent because of a forced bus-off",
     .get = [](const Status& s) -> std::uint64_t { return s.tx_suppressed; }, .replay = 5},
    {.name = "rx_suppressed", .registers = 2, .unit = "frames",
     .meaning = "frames not received because of a forced bus-off",
     .get = [](const Status& s) -> std::uint64_t { return s.rx_suppressed; }, .replay = 6},
    {.name = "rx_drop_remaining", .unit = "frames",
     .meaning = "holding register 8194: received frames still to drop (each counts in IRQ_LOST)",
     .get = [](const Status& s) -> std::uint64_t { return s.rx_drop_remaining; }},
    {.name = "addressed", .meaning = "1 the master addresses the gateway, 0 stopped (control 3)",
     .get = [](const Status& s) -> std::uint64_t { return s.addressed ? 1u : 0u; }},
    {.name = "reconnects", .registers = 2, .unit = "connections",
     .meaning = "socketcand client: connections re-established",
     .get = [](const Status& s) -> std::uint64_t { return s.reconnects; }},
    {.name = "master_cycles_missed", .registers = 2, .unit = "cycles",
     .meaning = "DP master cycles missed since start: grid points (every cycle_ms) that passed "
                "without a cycle because the previous one started more than a period late; the "
                "same in every block",
     .get = [](const Status& s) -> std::uint64_t { return s.cycles_missed; }},
};
// clang-format on

inline constexpr std::span<const Field> fields() {
  return kFields;
}
// The field named `name`, or null.
constexpr const Field* field(std::string_view name) {
  for (const auto& f : kFields)
    if (f.name == name) return &f;
  return nullptr;
}

}  // namespace candp2::station

// The daemon's JSON configuration (docs/configuration.md), as a user writes it from the SIMATIC
// HW Config dialogs. Parsing is strict: every error names the file, the JSON path and what was
// expected ("demo.json: $.gateways[0].slots[2].comment: expected hex bytes like \"02,89,B8\"").
// Numbers may be JSON numbers or "0x…" strings. Unknown keys are errors (typos must not be
// silently ignored); keys starting with '_' are comments and skipped.
//
// Parsing never touches the network or the CAN side: it turns text into the model below and
// checks what can be checked offline. What the emulated gateway itself would reject (a Set_Prm or
// Chk_Cfg fault, docs/dp-slave.md "User parameters"/docs/slots.md "Chk_Cfg slots") is reported as a
// warning, not an error, because configuring a faulty slave on purpose is a legitimate test (the
// master then shows the fault).
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "config/capture_config.hpp"
#include "config/slaves_config.hpp"
#include "config/warning_kind.hpp"
#include "gateway/user_prm.hpp"
#include "profibus_sim/fdl/line_timing.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::config {

struct Endpoint {
  std::string host = "127.0.0.1";  // numeric IPv4 address
  std::uint16_t port = 0;          // 0 = any free port (the daemon logs the one it got)
  std::string to_string() const { return host + ":" + std::to_string(port); }
};

enum class BusType { Virtual, SocketCan, Socketcand };
std::string_view to_string(BusType t);

// socketcan buses: what candp2d does with the interface's bit rate (docs/transports.md).
enum class BitrateMode { Check, Apply };

struct BusConfig {
  std::string name;
  BusType type = BusType::Virtual;
  std::string interface;  // socketcan: the network interface ("can0", "vcan0")
  // socketcan: "check" compares the interface's bit rate with the gateway's Set_Prm byte 8,
  // "apply" sets it (CAP_NET_ADMIN); restart_ms is the kernel's bus-off auto-restart (apply only).
  BitrateMode bitrate = BitrateMode::Check;
  std::optional<std::uint32_t> restart_ms;
  Endpoint remote;  // socketcand client: the server's host and port
  // socketcand client: the bus to open on the server; virtual bus export: the bus name clients
  // open (defaults to the bus's own name).
  std::string channel;
  std::optional<Endpoint> socketcand_listen;     // virtual: export the bus over socketcand
  std::uint32_t socketcand_max_clients = 32;     // export: at the limit the idlest is evicted
  std::uint32_t socketcand_idle_timeout_s = 60;  // export: close silent clients; 0 = never
  // virtual: the bus's bit rate in bit/s ("bitrate", a rate of manual table 5.1.1 written as
  // can_bitrate is) for the bus in time (docs/can-bus.md); the daemon does
  // not time the bus yet. none: an ideal bus.
  std::optional<std::uint32_t> timed_bitrate;
  std::string json_path;
};

enum class SlotIo { Input, Output };

struct SlotEntry {
  SlotIo io = SlotIo::Output;
  std::uint16_t address = 0;                     // PLC byte address (I or Q)
  std::uint8_t length = 1;                       // bytes (unit byte), 1..64
  bool consistent = true;                        // consistency over the whole length
  std::vector<std::uint8_t> comment;             // manufacturer bytes as typed in SIMATIC
  std::optional<std::vector<std::uint8_t>> cfg;  // raw Chk_Cfg bytes of this slot (cfg_hex)
  std::string json_path;                         // "$.gateways[0].slots[3]" for messages
};

struct ConfigError {
  std::string file;
  std::string json_path;  // "$.gateways[0].slots[2].comment"; empty for file-level errors
  std::string message;    // what was expected
  WarningKind kind = WarningKind::Other;  // as a warning
  std::string to_string() const {
    return file + ": " + (json_path.empty() ? "" : json_path + ": ") + message;
  }
};

struct GatewayConfig {
  std::string name;
  std::uint8_t address = 3;  // as configured; the gateway clamps to 3..124 (manual §2.1)
  std::string bus;
  gw::UserPrm parameters;                            // named parameters
                                                     // (docs/dp-slave.md "User parameters")
  std::optional<std::vector<std::uint8_t>> prm_hex;  // raw Set_Prm telegram overrides parameters
  std::uint16_t watchdog_ms = 0;                     // 0 = WD off
  bool cia301_bootup = false;
  std::uint8_t stored_wakeup_s = 0;  // the gateway's stored values at power-on
  std::uint16_t stored_sync_ms = 0;
  std::vector<SlotEntry> slots;
  std::string json_path;
  std::vector<ConfigError> warnings;  // what the gateway would reject, overlapping addresses

  // The DP address the emulated gateway answers to (manual §2.1: clamped to 3..124).
  std::uint8_t dp_address() const;
};

struct DriveConfig {
  std::string type = "unitek";
  std::string bus;
  std::string name;
  std::uint32_t rx_id = 0x201;
  std::uint32_t tx_id = 0x181;
  std::optional<std::string> state_file;
  // Modbus unit ID of the drive's fault registers (docs/faults.md); must not be a gateway's DP
  // address or 0/255 (those address the first gateway).
  std::optional<std::uint8_t> modbus_unit;
  std::string json_path;
};

// docs/profibus.md: the PROFIBUS line (docs/configuration.md#profibus).
enum class ProfibusRole { Slaves, Master };
std::string_view to_string(ProfibusRole r);

struct ProfibusConfig {
  std::string port;  // serial device path or "pty:PATH"
  std::uint32_t baud = 19200;
  ProfibusRole role = ProfibusRole::Slaves;
  std::optional<std::uint8_t> master_address;  // role slaves: answer only this master
  // The line's bus parameters (docs/profibus.md "Bus parameters"): the DP default profile of
  // `baud` with the keys slot_time_bits, retries (retry_limit), min_tsdr_bits and, in role
  // master, $.master.bus_parameters over it; checked by the rules of fdl::check_bus_parameters.
  // Role master waits the slot time and repeats up to the retry limit; role slaves answers after
  // min_TSDR until a Set_Prm says otherwise.
  fdl::BusParameters bus;
  bool rs485 = false;
  bool echo = false;
  std::string json_path = "$.profibus";
};

// docs/profibus.md "The line in time": the in-process line with a baud rate ($.master.baud) and
// its bus parameters ($.master.bus_parameters, each defaulting to the DP profile of the rate).
struct LineConfig {
  std::uint32_t baud = 0;
  fdl::BusParameters params;
  std::string json_path = "$.master.baud";
};

struct DaemonConfig {
  std::string file;  // where it was loaded from
  Endpoint modbus_listen{"127.0.0.1", 1502};
  std::optional<Endpoint> http_listen;       // status page, JSON API, /metrics (absent = off)
  std::uint32_t http_max_clients = 64;       // at the limit the connection waiting longest goes
  std::uint32_t http_idle_timeout_s = 60;    // close connections without a request; 0 = never
  std::uint32_t modbus_max_clients = 64;     // at the limit the client idle longest is evicted
  std::uint32_t modbus_idle_timeout_s = 60;  // close clients silent this long; 0 = never
  std::uint8_t master_address = 1;
  std::uint32_t cycle_ms = 10;
  std::uint32_t retry_ms = 1000;  // between parameterization attempts after a fault
  // docs/daemon.md "Host stalls": a loop this late is a host stall, which the simulated world
  // does not see; 0 = off (host lateness reaches the world).
  std::uint32_t host_stall_ms = 50;
  std::optional<LineConfig> line;  // $.master.baud; none: the ideal (infinitely fast) line
  std::vector<BusConfig> buses;    // sorted by name
  std::vector<GatewayConfig> gateways;
  std::vector<SlaveConfig> slaves;  // generic DP-V0 slaves from a GSD (config/slaves_config.hpp)
  std::vector<DriveConfig> drives;
  std::string log_level = "info";
  std::optional<std::string> can_log;      // candump -l file (relative paths: to the config file)
  std::optional<std::string> state_file;   // stored wake-up/SYNC values across restarts
  std::vector<ConfigError> warnings;       // from every part of the file
  std::optional<ProfibusConfig> profibus;  // docs/profibus.md; none: everything in-process
                                           // (docs/modbus.md "The simulated master")
  std::optional<CaptureConfig> capture;    // pcapng captures (docs/capture.md); none: off

  bool remote_gateways() const { return profibus && profibus->role == ProfibusRole::Master; }
  const BusConfig* bus(const std::string& name) const;
  const GatewayConfig* gateway_by_dp_address(std::uint8_t dp_address) const;
};

template <typename T>
using Result = std::variant<T, ConfigError>;

Result<DaemonConfig> parse_daemon(const std::string& text, const std::string& file);
Result<DaemonConfig> load_daemon(const std::string& path);
// One gateway entry (same shape as in the daemon's "gateways" array), for the replay runner and
// the validator. `path` prefixes JSON paths in messages. The bus name is not checked here.
Result<GatewayConfig> parse_gateway(const nlohmann::json& j, const std::string& file,
                                    const std::string& path = "$");
// One drive entry (same shape as in the daemon's "drives" array), for the replay runner. The bus
// name is not checked here.
Result<DriveConfig> parse_drive_entry(const nlohmann::json& j, const std::string& file,
                                      const std::string& path);

// What the simulated master sends for a gateway entry.
std::vector<std::uint8_t> set_prm_bytes(const GatewayConfig& g);
std::vector<std::uint8_t> chk_cfg_bytes(const GatewayConfig& g);
// The CAN bit rate (bit/s) of the gateway's Set_Prm byte 8 (docs/dp-slave.md "User parameters");
// nullopt when the byte is missing or out of range (the gateway rejects that Set_Prm).
std::optional<std::uint32_t> configured_bitrate(const GatewayConfig& g);
dp::SlaveParameters slave_parameters(const GatewayConfig& g);

// "88 80 C4" / "8880C4" / "88,80,C4" → bytes. nullopt and *error for anything else.
std::optional<std::vector<std::uint8_t>> parse_hex(std::string_view text, std::string* error);
// "127.0.0.1:1502" → endpoint. The host must be a numeric IPv4 address.
std::optional<Endpoint> parse_endpoint(std::string_view text, std::string* error);

}  // namespace candp2::config

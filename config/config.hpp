// The daemon's JSON configuration (docs/configuration.md), as a user writes it from the SIMATIC
// HW Config dialogs. Parsing is strict: every error names the file, the JSON path and what was
// expected ("demo.json: $.gateways[0].slots[2].comment: expected hex bytes like \"02,89,B8\"").
// Numbers may be JSON numbers or "0x…" strings.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "gateway/user_prm.hpp"
#include "profibus_sim/dp_master.hpp"

namespace candp2::config {

struct Endpoint {
  std::string host = "127.0.0.1";
  std::uint16_t port = 0;
};

enum class BusType { Virtual, SocketCan, Socketcand };

struct BusConfig {
  std::string name;
  BusType type = BusType::Virtual;
  std::string interface;                      // socketcan
  Endpoint remote;                            // socketcand client: host, port
  std::string channel = "vcan0";              // socketcand client channel / server export name
  std::optional<Endpoint> socketcand_listen;  // virtual: export the bus over socketcand
};

enum class SlotIo { Input, Output };

struct SlotEntry {
  SlotIo io = SlotIo::Output;
  std::uint16_t address = 0;                     // PLC byte address (I or Q)
  std::uint8_t length = 1;                       // bytes (unit byte)
  bool consistent = true;                        // consistency over the whole length
  std::vector<std::uint8_t> comment;             // manufacturer bytes as typed in SIMATIC
  std::optional<std::vector<std::uint8_t>> cfg;  // raw Chk_Cfg bytes of this slot (cfg_hex)
  std::string json_path;                         // "$.gateways[0].slots[3]" for messages
};

struct GatewayConfig {
  std::string name;
  std::uint8_t address = 3;
  std::string bus;
  gw::UserPrm parameters;                            // named parameters (emulator-spec §1.1)
  std::optional<std::vector<std::uint8_t>> prm_hex;  // raw Set_Prm (16 bytes) overrides parameters
  std::uint16_t watchdog_ms = 0;                     // 0 = WD off
  bool cia301_bootup = false;
  std::uint8_t stored_wakeup_s = 0;  // the gateway's stored values at power-on
  std::uint16_t stored_sync_ms = 0;
  std::vector<SlotEntry> slots;
  std::string json_path;
};

struct DriveConfig {
  std::string type = "unitek";
  std::string bus;
  std::string name;
  std::uint32_t rx_id = 0x201;
  std::uint32_t tx_id = 0x181;
  std::optional<std::string> state_file;
};

struct DaemonConfig {
  std::string file;  // where it was loaded from
  Endpoint modbus_listen{"127.0.0.1", 1502};
  std::uint8_t master_address = 1;
  std::uint32_t cycle_ms = 10;
  std::vector<BusConfig> buses;
  std::vector<GatewayConfig> gateways;
  std::vector<DriveConfig> drives;
  std::string log_level = "info";
  std::optional<std::string> can_log;
  std::optional<std::string> state_file;  // stored wake-up/SYNC values across restarts
};

struct ConfigError {
  std::string file;
  std::string json_path;  // "$.gateways[0].slots[2].comment"
  std::string message;    // what was expected
  std::string to_string() const { return file + ": " + json_path + ": " + message; }
};

template <typename T>
using Result = std::variant<T, ConfigError>;

Result<DaemonConfig> parse_daemon(const std::string& text, const std::string& file);
Result<DaemonConfig> load_daemon(const std::string& path);
// One gateway entry (same shape as in the daemon's "gateways" array), for the replay runner and
// the validator. `path` prefixes JSON paths in messages.
Result<GatewayConfig> parse_gateway(const nlohmann::json& j, const std::string& file,
                                    const std::string& path = "$");

// What the simulated master sends for a gateway entry.
std::vector<std::uint8_t> set_prm_bytes(const GatewayConfig& g);
std::vector<std::uint8_t> chk_cfg_bytes(const GatewayConfig& g);
dp::SlaveParameters slave_parameters(const GatewayConfig& g);

}  // namespace candp2::config

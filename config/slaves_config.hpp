// Generic DP-V0 slaves in the daemon configuration: the top-level "slaves" array beside
// "gateways" (docs/configuration.md "slaves", docs/slaves.md). Each entry names a GSD file
// (relative to the configuration file), the slave's modules by their GSD names (or its raw
// Chk_Cfg bytes, "cfg_hex"), its DP address and its field_unit; parsing loads the GSD and checks
// everything that can be checked offline. Errors name the file, the JSON path and what was
// expected; what the slave itself would reject (its own Set_Prm or Chk_Cfg, a forced fault on
// purpose) is a warning, as for gateways.
//
// Also what the built-in master sends such a slave (slave_parameters), as config::slave_parameters
// does for a gateway.
#pragma once

#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "config/warning_kind.hpp"
#include "gsd/gsd.hpp"
#include "gsd/prm.hpp"
#include "gsd_slave/gsd_slave.hpp"
#include "gsd_slave/profile.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::config {

struct DaemonConfig;

struct SlaveModuleConfig {
  std::string name;       // as in the GSD
  std::size_t index = 0;  // into model->modules
  std::string json_path;  // "$.slaves[0].modules[2]"; "$.slaves[0].modules" for an added one
  bool added = false;     // a GSD preset module put in front (docs/slaves.md "Preset modules")
};

struct SlaveWarning {
  std::string json_path;
  std::string message;
  WarningKind kind = WarningKind::Other;
};

struct SlaveConfig {
  std::string name;          // "slave8" unless given
  std::uint8_t address = 0;  // DP address 0..125
  std::string gsd;           // the GSD file, resolved against the configuration file's folder
  std::shared_ptr<const gsd::Model> model;
  gsd_slave::Profile profile;
  std::vector<SlaveModuleConfig> modules;            // "modules": by GSD name, slot order
  std::optional<std::vector<std::uint8_t>> cfg_hex;  // or "cfg_hex": the raw Chk_Cfg bytes
  std::optional<std::uint8_t> field_unit;            // Modbus unit ID of the field side
  std::vector<gsd::PrmOverride> parameters;          // "parameters": ExtUserPrmData name → value
  std::optional<std::vector<std::uint8_t>> prm_hex;  // the master's raw Set_Prm telegram
  std::uint16_t watchdog_ms = 0;                     // 0 = WD off
  std::optional<std::uint16_t> input_address;        // PLC I address of the first input byte
  std::optional<std::uint16_t> output_address;       // PLC Q address of the first output byte
  gsd_slave::SafeState safe_state = gsd_slave::SafeState::Zero;
  std::string json_path;  // "$.slaves[0]"
  std::vector<SlaveWarning> warnings;
  // What the configuration completed on its own, as a configuration tool does (the preset modules
  // it added): not a warning; `candp2 validate` shows them.
  std::vector<SlaveWarning> notes;

  // What gsd_slave::GsdSlave::create needs to build the emulated slave.
  gsd_slave::SlaveSetup setup(LogSink* log = nullptr) const;
};

// The hook of parse_daemon: reads $.slaves (`slaves` null: the key is absent) into c.slaves,
// after c's gateways, drives and master were read, and checks DP addresses, names and Modbus unit
// IDs against them; the slaves' warnings are appended to c.warnings. Throws
// json_reader::Failure.
void parse_slaves(const nlohmann::json* slaves, const std::string& file, DaemonConfig& c);

// One entry (same shape as in "slaves"), without the checks against the rest of a configuration;
// for the replay runner and tests. Throws json_reader::Failure.
SlaveConfig parse_slave(const nlohmann::json& j, const std::string& file, const std::string& path);

// What the built-in master sends the slave: Set_Prm (prm_hex, or Lock_Req + the watchdog + the
// GSD's Ident_Number + its default user parameters with the named ones), Chk_Cfg (the modules'
// configuration bytes, or cfg_hex), and the PLC addresses of each Chk_Cfg entry: inputs from
// input_address on, outputs from output_address on, entry after entry.
std::vector<std::uint8_t> set_prm_bytes(const SlaveConfig& s);
std::vector<std::uint8_t> chk_cfg_bytes(const SlaveConfig& s);
dp::SlaveParameters slave_parameters(const SlaveConfig& s);

}  // namespace candp2::config

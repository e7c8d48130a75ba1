// What an emulated generic slave makes of its configuration entry, for `candp2 validate`
// (docs/validate.md "Generic slaves"). As for gateways nothing is re-derived: the master's Set_Prm
// and Chk_Cfg go through a real gsd_slave::GsdSlave via its DP services (Set_Prm, Chk_Cfg,
// Slave_Diag at time 0), so the reported diagnosis and the reason of a fault are the slave's own.
//
// Pure: no files, no JSON parsing; tools/candp2/cmd_validate.cpp builds the input from the daemon
// configuration (config::SlaveConfig).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "gsd_slave/gsd_slave.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "validate/warning.hpp"

namespace candp2::validate {

// Something the configuration did on its own that the report shows.
struct Note {
  std::string json_path;
  std::string message;
};

struct SlaveInput {
  std::string name;
  std::string json_path;                  // "$.slaves[0]"
  std::string gsd_file;                   // as resolved by the configuration
  std::uint8_t master_address = 1;        // the DP master sending Set_Prm
  gsd_slave::SlaveSetup setup;            // the emulated slave (GSD, modules, address)
  dp::SlaveParameters params;             // what the master sends
  std::vector<std::string> module_paths;  // JSON path per module (empty with cfg_hex)
  std::string prm_source;                 // "$.slaves[0].parameters", "$.slaves[0].prm_hex"
  std::string cfg_source;                 // "$.slaves[0].modules", "$.slaves[0].cfg_hex"
  std::optional<std::uint8_t> field_unit;
  // What the configuration completed on its own (config::SlaveConfig::notes: the GSD preset
  // modules it added, docs/slaves.md "Preset modules"); shown, not counted as warnings.
  std::vector<Note> notes;
};

// One module (or, with cfg_hex, the whole configuration) and where its bytes go.
struct SlaveModuleRow {
  std::string name;  // the GSD module name, "" for cfg_hex
  std::string json_path;
  std::vector<std::uint8_t> cfg_bytes;
  std::size_t in_length = 0, out_length = 0;
  std::optional<std::uint16_t> plc_input, plc_output;
};

// A user parameter the master sends with another value than the GSD default.
struct SlaveParamRow {
  std::string name;      // ExtUserPrmData name (UTF-8, trimmed)
  std::string module;    // "" for the device's block
  std::size_t byte = 0;  // Set_Prm telegram byte
  std::string bits;      // "" or "3-5" / "7"
  std::int64_t value = 0;
  std::string text;  // the PrmText of the value, or ""
};

struct SlaveReport {
  SlaveInput input;
  std::optional<std::string> error;  // the GSD cannot describe a slave: nothing else is set
  std::string device;                // "SIEMENS AG SIMOCODE-DP, Ident_Number 0x8031"
  bool prm_accepted = false;
  bool cfg_accepted = false;
  bool not_supported = false;
  dp::SlaveState state = dp::SlaveState::WaitPrm;
  std::vector<std::uint8_t> diag;  // Slave_Diag after Set_Prm and Chk_Cfg
  std::string prm_problem, cfg_problem;
  std::size_t user_prm_len = 0;
  std::vector<SlaveModuleRow> modules;
  std::vector<SlaveParamRow> parameters;
  std::vector<Warning> warnings;

  bool valid() const { return !error && prm_accepted && cfg_accepted; }
};

// Set_Prm, Chk_Cfg, Slave_Diag on a fresh GsdSlave at time 0.
SlaveReport check_slave(SlaveInput input);

// "Data_Exch: the slave accepts the parameters and the configuration", or the fault and why.
std::string explain_slave(const SlaveReport& s);

// `line`: the line's warnings about this slave (station_warnings()), listed with its own.
void format_slave(std::ostream& os, const SlaveReport& s, const std::vector<Warning>& line);
nlohmann::ordered_json slave_json(const SlaveReport& s, const std::vector<Warning>& line);

}  // namespace candp2::validate

// What the emulated CAN-DP/2 makes of a gateway configuration, for `candp2 validate`
// (docs/validate.md). The Set_Prm and Chk_Cfg telegrams go through a real gw::Gateway via its DP
// services (Set_Prm, Chk_Cfg, Slave_Diag), so the reported diagnosis is the gateway's own answer,
// never re-derived. On top come the warnings the manual and
// docs/slots.md "Chk_Cfg slots"/docs/modbus.md ask for: behaviour the gateway accepts but a user
// rarely wants.
//
// Pure: no files, no JSON parsing, no clock. The input is what the simulated master would send
// (dp::SlaveParameters); cmd_validate.cpp builds it from the daemon configuration.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gateway/slot_config.hpp"
#include "gateway/user_prm.hpp"
#include "profibus_sim/dp/dp_slave.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "validate/buses.hpp"
#include "validate/line.hpp"
#include "validate/slaves.hpp"
#include "validate/warning.hpp"

namespace candp2::validate {

struct GatewayInput {
  std::string name;
  std::string json_path;  // "$.gateways[0]"
  std::string bus;
  std::uint8_t address = 3;              // as configured (the gateway clamps to 3..124)
  std::uint8_t master_address = 1;       // the DP master sending Set_Prm
  std::uint16_t stored_sync_ms = 0;      // the gateway's stored SYNC time at power-on
  dp::SlaveParameters params;            // Set_Prm, Chk_Cfg, PLC address per Chk_Cfg entry
  std::vector<std::string> entry_paths;  // JSON path per Chk_Cfg entry
  std::string prm_source;                // "$.gateways[0].parameters (built-in encoding)", ...
  std::vector<Warning> warnings;  // found while building the input (GSD encoding); reported first
};

// One Chk_Cfg entry with its PLC address and, when the gateway accepted the configuration, the
// slot the gateway made of it.
struct SlotRow {
  std::size_t index = 0;
  std::string json_path;
  dp::CfgIo io = dp::CfgIo::Empty;
  std::size_t in_length = 0, out_length = 0;  // bytes of the entry in the DP images
  std::optional<std::uint16_t> plc_input;     // PLC I address of the input bytes
  std::optional<std::uint16_t> plc_output;    // PLC Q address of the output bytes
  std::vector<std::uint8_t> cfg_bytes;        // the entry's Chk_Cfg bytes
  std::optional<gw::Slot> slot;               // the gateway's decoding (accepted configurations)
  std::optional<std::uint8_t> fault_code;     // this entry is the one the Cfg fault names
};

struct GatewayReport {
  GatewayInput input;
  std::uint8_t dp_address = 3;  // the address the gateway answers to
  bool prm_accepted = false;
  bool cfg_accepted = false;
  std::optional<gw::UserPrm> prm;  // as the gateway decoded it (when accepted)
  dp::SlaveState state = dp::SlaveState::WaitPrm;
  dp::DpSlave::Diag diag{};  // Slave_Diag after Set_Prm and Chk_Cfg
  std::optional<dp::PrmFault> prm_fault;
  std::optional<dp::CfgFault> cfg_fault;
  bool not_supported = false;  // Station_Status_1 bit 4 (Sync_Req/Freeze_Req, docs/dp-slave.md)
  std::optional<std::string> cfg_decode_error;  // Chk_Cfg bytes truncated
  std::vector<SlotRow> slots;
  std::vector<Warning> warnings;
  std::uint16_t sync_ms = 0;  // the effective SYNC time after Chk_Cfg (0: no SYNC)

  bool valid() const { return prm_accepted && cfg_accepted; }
};

// Set_Prm, Chk_Cfg, Slave_Diag on a fresh gw::Gateway at time 0; then the per-gateway warnings.
GatewayReport check_gateway(GatewayInput input);

// Overlapping PLC addresses of slots of the same direction, across all gateways (the master has
// one process image, docs/modbus.md). The warning goes to the later slot's gateway.
void check_overlaps(std::vector<GatewayReport>& reports);

// Overlapping PLC addresses of a slave's bytes with a gateway's slot or another slave's bytes
// (one process image, docs/modbus.md); reported at the slave.
void check_slave_overlaps(const std::vector<GatewayReport>& gateways,
                          std::vector<SlaveReport>& slaves);

struct Report {
  std::string file;      // the configuration file as given
  std::string gsd_file;  // --gsd FILE, or ""
  std::string gsd_name;  // "esd CAN-DP/2, Ident_Number 0x04A4"
  std::vector<GatewayReport> gateways;
  std::vector<SlaveReport> slaves;  // generic DP-V0 slaves (validate/slaves.hpp)
  LineReport line;                  // the line in time (validate/line.hpp); no baud: ideal
  std::vector<BusReport> buses;     // the timed CAN buses (validate/buses.hpp), by name

  bool valid() const;
  std::size_t warning_count() const;
};

// Exit status of `candp2 validate`: 0 valid, 1 invalid (a gateway rejects Set_Prm or Chk_Cfg; with
// `strict` also any warning). 2 (unusable input) is decided before a report exists.
int exit_code(const Report& r, bool strict);

// The bytes of a Set_Prm fault, named (docs/dp-slave.md "User parameters"): "flags (byte 9)".
std::string prm_byte_name(std::size_t telegram_byte);

}  // namespace candp2::validate

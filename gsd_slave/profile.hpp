// What a GSD says about a DP-V0 slave's behaviour, read once from the typed model (gsd/gsd.hpp):
// its identity, the optional DP services it offers, its configuration limits and, for a DP-V1
// slave, what its three DPV1_Status bytes may switch on. Keywords of the PNO GSD specification
// (docs/slaves.md "What the slave takes from its GSD"). Pure.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>

#include "gsd/gsd.hpp"
#include "profibus_sim/dp/dp_slave.hpp"

namespace candp2::gsd_slave {

// What DPV1_Status_1..3 (the first three user parameter bytes of a DP-V1 slave) may set.
struct Dpv1Support {
  bool wd_base_1ms = false;          // WD_Base_1ms_supp: DPV1_Status_1 bit 2
  bool publisher = false;            // Publisher_supp: DPV1_Status_1 bit 5
  bool fail_safe = false;            // Fail_Safe: DPV1_Status_1 bit 6
  bool update_alarm = false;         // Update_Alarm_supp: DPV1_Status_2 bit 2
  bool status_alarm = false;         // Status_Alarm_supp: bit 3
  bool manufacturer_alarm = false;   // Manufacturer_Specific_Alarm_supp: bit 4
  bool diagnostic_alarm = false;     // Diagnostic_Alarm_supp: bit 5
  bool process_alarm = false;        // Process_Alarm_supp: bit 6
  bool pull_plug_alarm = false;      // Pull_Plug_Alarm_supp: bit 7
  bool prm_block_structure = false;  // Prm_Block_Structure_supp: DPV1_Status_3 bit 3
  bool isochron = false;             // Isochron_Mode_supp: DPV1_Status_3 bit 4
  bool prm_cmd = false;              // PrmCmd_supp: DPV1_Status_3 bit 7
};

struct Profile {
  std::uint16_t ident_number = 0;
  std::string vendor, model;  // as in the file (ISO-8859-1 or UTF-8)
  bool modular = false;       // Modular_Station
  std::optional<std::size_t> max_module, max_input_len, max_output_len, max_data_len;
  std::optional<std::size_t> max_user_prm_len;  // Max_User_Prm_Data_Len
  std::size_t max_diag_len = dp::kDiagMaxLen;   // Max_Diag_Data_Len (absent: 244)
  bool sync = false;                            // Sync_Mode_supp
  bool freeze = false;                          // Freeze_Mode_supp
  bool set_slave_add = false;                   // Set_Slave_Add_supp
  bool fail_safe = false;                       // Fail_Safe
  bool dpv1 = false;                            // DPV1_Slave
  Dpv1Support dpv1_support;

  // The dp::DpSlave options of a slave with this GSD (DpProfile::Standard).
  dp::SlaveOptions options() const;
  // "SIEMENS SIMOCODE-DP, Ident_Number 0x8031" (UTF-8)
  std::string name() const;
};

// The profile, or why the GSD cannot describe a slave ("no Ident_Number", "Ident_Number 70000
// outside 0..0xFFFF").
std::variant<Profile, std::string> read_profile(const gsd::Model& model);

}  // namespace candp2::gsd_slave

// The DP-V0 services (EN 50170 vol. 2) and their names as the standard spells them: the one place
// a DP service becomes text, for the master's log, the FDL describer (candp2 sniff) and reports.
// Which SAP each uses on the wire: docs/profibus.md "DP services over FDL".
#pragma once

#include <cstdint>
#include <string_view>

namespace candp2::dp {

enum class Service : std::uint8_t {
  SlaveDiag,  // SAP 60: answer = the diagnosis bytes (6..244; the CAN-DP/2: 11, docs/dp-slave.md)
  SetPrm,     // SAP 61, data = the whole Set_Prm telegram: answer = acknowledge
  ChkCfg,     // SAP 62, data = Chk_Cfg bytes: answer = acknowledge
  GetCfg,     // SAP 59: answer = the configuration bytes
  DataExchange,   // default SAP, data = output bytes: answer = input bytes
  GlobalControl,  // SAP 58, data = Control_Command, Group_Select: unacknowledged (SDN)
  // Services of a class 2 master (or a commissioning tool). The simulated master never sends them;
  // the FDL describer names them when it sees them on a line.
  SetSlaveAdd,  // SAP 55
  RdInp,        // SAP 56: answer = the input bytes
  RdOutp,       // SAP 57: answer = the output bytes
};

// "Slave_Diag", "Set_Prm", "Chk_Cfg", "Get_Cfg", "Data_Exchange", "Global_Control",
// "Set_Slave_Add", "Rd_Inp", "Rd_Outp".
std::string_view to_string(Service s);

}  // namespace candp2::dp

// DP service names (profibus_sim/dp/dp_service.hpp).
#include "profibus_sim/dp/dp_service.hpp"

namespace candp2::dp {

std::string_view to_string(Service s) {
  switch (s) {
    case Service::SlaveDiag:
      return "Slave_Diag";
    case Service::SetPrm:
      return "Set_Prm";
    case Service::ChkCfg:
      return "Chk_Cfg";
    case Service::GetCfg:
      return "Get_Cfg";
    case Service::DataExchange:
      return "Data_Exchange";
    case Service::GlobalControl:
      return "Global_Control";
    case Service::SetSlaveAdd:
      return "Set_Slave_Add";
    case Service::RdInp:
      return "Rd_Inp";
    case Service::RdOutp:
      return "Rd_Outp";
  }
  return "?";
}

}  // namespace candp2::dp

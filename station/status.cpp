#include "station/status.hpp"

namespace candp2::station {

led::Codes led::codes(const gw::GatewayStatus& g) {
  // manual table 3.3.1.
  Codes c;
  c.d = g.dp_state == dp::SlaveState::DataExch ? kOn : kOff;
  c.e = g.dp_state == dp::SlaveState::WaitPrm   ? 3  // 3 short flashes: waiting for Set_Prm
        : g.dp_state == dp::SlaveState::WaitCfg ? 4  // 4 short flashes: waiting for Chk_Cfg
                                                : kOff;
  c.p = kOn;
  switch (g.bus_state) {
    case can::BusState::Ok:
      c.c = kOn;
      break;
    case can::BusState::Warning:
      c.c = kMorseW;
      break;
    case can::BusState::ErrorPassive:
      c.c = kMorseE;
      break;
    case can::BusState::BusOff:
      c.c = kMorseO;
      break;
  }
  return c;
}

}  // namespace candp2::station

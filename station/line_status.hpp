// A station's line figures (docs/modbus.md "Status block"): what the plant's slave line (role
// slaves) or master line (role master) counts for one station. One type: the plant's lines fill
// it, a station's status (station/status.hpp) holds it, every face reads it through the station
// table. Header only and pure, below the plant, beside the station table.
#pragma once

#include <cstdint>

namespace candp2::station {

struct LineStatus {
  std::uint16_t role = 0;  // 1 role slaves, 2 role master
  std::uint32_t telegrams = 0, fcs_errors = 0, other_errors = 0;
  std::uint32_t requests = 0, retries = 0;
  std::uint32_t response_us = 0, response_max_us = 0;
  bool present = false;
};

}  // namespace candp2::station

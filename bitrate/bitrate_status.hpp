// What the bit-rate supervisor knows of one gateway's SocketCAN interface (docs/transports.md "Bit
// rate"): the group of the Modbus status block that shows it (docs/modbus.md, kBitrate*), filled by
// BitrateSupervisor::status (bitrate/bitrate_supervisor.hpp).
#pragma once

#include <cstdint>

namespace candp2::bitrate {

struct BitrateStatus {
  std::uint16_t mode = 0;        // 0 none, 1 check, 2 apply
  std::uint32_t configured = 0;  // bit/s, 0 before the first Set_Prm
  std::uint32_t interface = 0;   // bit/s, 0 = no bit timing (virtual) or not readable
  bool mismatch = false;
};

}  // namespace candp2::bitrate

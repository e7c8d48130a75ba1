// The host stalls candp2d's simulated clock took out of the in-process world (docs/daemon.md
// "Host stalls"): one type, counted by the daemon's clock and shown by every face (status JSON,
// /metrics, the Modbus host block, the panel header, Python).
#pragma once

#include <cstdint>

#include "common/time.hpp"

namespace candp2 {

struct HostStalls {
  std::uint64_t count = 0;  // loop wakes later than master.host_stall_ms after a deadline
  Duration total{0};        // their lateness in all
  Duration longest{0};
};

}  // namespace candp2

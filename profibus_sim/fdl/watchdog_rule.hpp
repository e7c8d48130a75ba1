// The watchdog rule (docs/validate.md "The watchdog rule"): how long a DP master may take to come
// back to a station, from the line's arithmetic (line_timing.hpp), and what that makes of a
// station's watchdog. One rule, one text, for `candp2 validate`, `candp2d --check` and candp2d's
// start warnings. Pure: numbers in, a verdict out.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "common/time.hpp"
#include "profibus_sim/fdl/line_timing.hpp"

namespace candp2::fdl {

// One station as the rule sees it: its Data_Exchange bytes and what its parameterization sends
// and gets (the whole Set_Prm telegram, the Chk_Cfg data, the Slave_Diag answer).
struct WatchdogStation {
  std::size_t outputs = 0, inputs = 0;
  std::size_t prm_bytes = 7, cfg_bytes = 0, diag_bytes = 6;
};

// The master and its line: `baud` 0 is the ideal line (no wire time); `late_ms` is how late a
// master cycle may come without the host stall guard taking it out of simulated time
// (master.host_stall_ms; 0 when nothing bounds it).
struct WatchdogLine {
  std::uint32_t baud = 0;
  BusParameters params;
  std::uint32_t cycle_ms = 10;
  std::uint32_t late_ms = 0;
  bool gap = true;  // a free address above the master up to HSA (line_timing.hpp predict_cycle)
  std::vector<WatchdogStation> stations;
};

// The longest times between two telegrams of the master to one station.
struct WatchdogBounds {
  Duration cycle{0};      // every rotation: cycle_ms, or the bus cycle with a GAP request if longer
  Duration bus_cycle{0};  // the bus cycle with a GAP request (0: the ideal line)
  Duration retries{0};    // one station's unanswered request repeated retry_limit times
  Duration startup{0};    // the rotation that parameterizes every station (cycle_ms at least)
  Duration late{0};       // the master cycle's lateness (late_ms)
  Duration needed() const;  // max(cycle + retries, startup) + late
};
WatchdogBounds watchdog_bounds(const WatchdogLine& line);

// The rotation in which the master parameterizes every station in one go: FDL_Status, Slave_Diag,
// Set_Prm, Chk_Cfg, Slave_Diag and the first Data_Exchange of each, the GAP request, the token.
std::uint64_t startup_rotation_bits(const BusParameters& p,
                                    const std::vector<WatchdogStation>& stations, bool gap);

enum class WatchdogVerdict { Holds, WillExpire, NeverHolds };
struct WatchdogFinding {
  WatchdogVerdict verdict = WatchdogVerdict::Holds;
  std::string message;  // empty when it holds; else what happens and the value to write
};
// A watchdog of `watchdog_ms` (0: off, always holds): shorter than `cycle` it expires every
// rotation (NeverHolds, the configuration is invalid); shorter than needed() it expires when a
// retry, a parameterization or a late cycle comes (WillExpire, a warning).
WatchdogFinding judge_watchdog(const WatchdogBounds& b, std::uint32_t watchdog_ms);

}  // namespace candp2::fdl

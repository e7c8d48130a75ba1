// candp2d's simulated clock (docs/daemon.md "Host stalls"): the in-process world (master, line,
// gateways, generic slaves, drives, their timers and watchdogs) runs on the loop's
// CLOCK_MONOTONIC minus the time the host stalled the daemon. A loop that wakes more than the
// tolerance after the simulated deadline it was to wake for was stalled (SIGSTOP, a loaded host,
// a VM's steal time): the whole lateness is taken out of the simulated time, which therefore
// goes on exactly at that deadline, and counted. Lateness up to the tolerance is the world's own
// jitter and stays in. Pure: times passed in.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>

#include "common/host_stalls.hpp"
#include "common/time.hpp"

namespace candp2::daemon {

class SimClock {
 public:
  // `tolerance` 0: never a stall (the simulated time is the loop's, docs/configuration.md
  // master.host_stall_ms).
  explicit SimClock(Duration tolerance) : tolerance_(tolerance) {}

  // The simulated time at the loop's time `loop_now`. `due`: the simulated time the loop was to
  // wake at for the world (its next deadline, not earlier than when it was armed), if any.
  // The stall just found, if this call found one.
  Time now(Time loop_now, std::optional<Time> due, Duration* stall = nullptr) {
    if (stall) *stall = Duration(0);
    if (tolerance_ > Duration(0) && due) {
      const Duration late = loop_now - stalled_ - *due;
      if (late > tolerance_) {
        stalled_ += late;
        ++stalls_.count;
        stalls_.total += late;
        stalls_.longest = std::max(stalls_.longest, late);
        if (stall) *stall = late;
      }
    }
    return loop_now - stalled_;
  }
  // A simulated time on the loop's clock (for timers and engines on the loop's clock).
  Time to_loop(Time simulated) const { return simulated + stalled_; }
  const HostStalls& stalls() const { return stalls_; }
  Duration tolerance() const { return tolerance_; }

 private:
  Duration tolerance_;
  Duration stalled_{0};
  HostStalls stalls_;
};

}  // namespace candp2::daemon

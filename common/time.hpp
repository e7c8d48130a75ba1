// Time as the protocol code sees it: a monotonic point passed in by the caller.
// The gateway core never reads a clock; the daemon, tests and the replay runner own time.
#pragma once

#include <chrono>
#include <cstdint>

namespace candp2 {

using Duration = std::chrono::microseconds;
// Microseconds since an arbitrary origin chosen by the owner of the clock (daemon start, 0 in
// tests).
using Time = std::chrono::microseconds;

using std::chrono::microseconds;
using std::chrono::milliseconds;
using std::chrono::seconds;

}  // namespace candp2

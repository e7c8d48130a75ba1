// A LogThrottle (common/log_throttle.hpp) with its flush timer on the event loop: what a face
// logs through for every event an outside party can repeat by the thousand (docs/daemon.md
// "Logging"). The first line of a kind at once, then at most one a second with the count.
#pragma once

#include <string>
#include <string_view>

#include "common/log_throttle.hpp"
#include "event_loop/deadline_timer.hpp"
#include "event_loop/event_loop.hpp"

namespace candp2 {

class ThrottledLog {
 public:
  ThrottledLog(EventLoop& loop, Logger log)
      : loop_(loop), throttle_(std::move(log)), timer_(loop, [this] {
          throttle_.flush(loop_.now());
          arm();
        }) {}

  void log(std::string_view kind, LogLevel level, std::string line) {
    throttle_.log(loop_.now(), kind, level, std::move(line));
    arm();
  }
  void info(std::string_view kind, std::string line) { log(kind, LogLevel::Info, std::move(line)); }
  void warn(std::string_view kind, std::string line) { log(kind, LogLevel::Warn, std::move(line)); }
  // Stops the timer; what is still suppressed stays uncounted in the log (shutdown).
  void stop() { timer_.disarm(); }

 private:
  void arm() { timer_.arm(throttle_.next_flush(), loop_.now()); }

  EventLoop& loop_;
  LogThrottle throttle_;
  DeadlineTimer timer_;
};

}  // namespace candp2

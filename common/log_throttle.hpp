// One mechanism for every log line that a party outside candp2d can cause by the thousand
// (hostile or broken Modbus and HTTP clients; docs/daemon.md "Logging"): the first line of a
// kind is written at once, then at most one line of that kind per second. A line written after
// suppressed ones says how many there were ("(and 41 more like it before)"); flush() writes the
// count of those still suppressed once their second is over ("41 more in the last second, the
// last: ..."), so nothing is lost from the count. Pure: time passed in; the owner arms one loop
// timer at next_flush() and calls flush() from it.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "common/log.hpp"
#include "common/time.hpp"

namespace candp2 {

class LogThrottle {
 public:
  explicit LogThrottle(Logger log, Duration interval = seconds(1))
      : log_(std::move(log)), interval_(interval) {}

  // Writes `line` now, or counts it as suppressed when a line of `kind` was written less than
  // an interval ago. True when written.
  bool log(Time now, std::string_view kind, LogLevel level, std::string line);

  // When flush() has a count to write (the earliest kind whose interval ends), if any.
  std::optional<Time> next_flush() const;
  // Writes one summary line for each kind whose suppressed lines' interval is over.
  void flush(Time now);

  // Lines counted but not written yet, over all kinds (tests, shutdown).
  std::uint64_t suppressed() const;

 private:
  struct Kind {
    std::optional<Time> last;  // when the last line of this kind was written
    std::uint64_t suppressed = 0;
    std::string last_line;  // the last suppressed line
    LogLevel level = LogLevel::Info;
  };
  Logger log_;
  Duration interval_;
  std::map<std::string, Kind, std::less<>> kinds_;
};

}  // namespace candp2

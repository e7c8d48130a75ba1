#include "common/log_throttle.hpp"

namespace candp2 {

bool LogThrottle::log(Time now, std::string_view kind, LogLevel level, std::string line) {
  auto it = kinds_.find(kind);
  if (it == kinds_.end()) it = kinds_.emplace(std::string(kind), Kind{}).first;
  Kind& k = it->second;
  if (k.last && now - *k.last < interval_) {
    ++k.suppressed;
    k.last_line = std::move(line);
    k.level = level;
    return false;
  }
  if (k.suppressed) line += " (and " + std::to_string(k.suppressed) + " more like it before)";
  log_.log(level, line);
  k.last = now;
  k.suppressed = 0;
  k.last_line.clear();
  return true;
}

std::optional<Time> LogThrottle::next_flush() const {
  std::optional<Time> next;
  for (const auto& [name, k] : kinds_)
    if (k.suppressed && (!next || *k.last + interval_ < *next)) next = *k.last + interval_;
  return next;
}

void LogThrottle::flush(Time now) {
  for (auto& [name, k] : kinds_) {
    if (!k.suppressed || now - *k.last < interval_) continue;
    log_.log(k.level,
             std::to_string(k.suppressed) + " more in the last second, the last: " + k.last_line);
    k.last = now;
    k.suppressed = 0;
    k.last_line.clear();
  }
}

std::uint64_t LogThrottle::suppressed() const {
  std::uint64_t n = 0;
  for (const auto& [name, k] : kinds_) n += k.suppressed;
  return n;
}

}  // namespace candp2

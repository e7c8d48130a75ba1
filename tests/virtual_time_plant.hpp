// A plant run in virtual time by a test program, as replay runs it (tests/wireshark/demo_capture,
// tests/validate/timed_bus_run): errors of the plant to stderr, every event up to a time.
#pragma once

#include <algorithm>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "common/log.hpp"
#include "plant/plant.hpp"

namespace candp2::test {

// The plant's errors on stderr, one line each.
class StderrErrors final : public LogSink {
 public:
  bool enabled(LogLevel level) const override { return level >= LogLevel::Error; }
  void write(LogLevel level, std::string_view component, std::string_view message) override {
    std::fprintf(stderr, "%s %.*s: %.*s\n", std::string(to_string(level)).c_str(),
                 static_cast<int>(component.size()), component.data(),
                 static_cast<int>(message.size()), message.data());
  }
};

// The plant in virtual time: every event at or before `until`, as replay runs it; with `wakes`,
// the time of each advance appended to it.
inline void run_until(plant::Plant& p, Time until, std::vector<Time>* wakes = nullptr) {
  auto advance = [&](Time t) {
    if (wakes) wakes->push_back(t);
    p.advance(t);
  };
  while (true) {
    const auto next = p.next_deadline();
    if (!next || std::max(*next, p.now()) > until) break;
    advance(std::max(*next, p.now()));
  }
  advance(until);
}

}  // namespace candp2::test

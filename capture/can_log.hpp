// The CAN log file (log.can_log): every frame in `candump -l` notation,
// "(1700000000.123456) can0 309#0B0A0F0E0D0C", readable by canplayer and `candp2 replay`.
// Reopened on SIGHUP (logrotate moves the file, then signals the daemon).
#pragma once

#include <cstdio>
#include <functional>
#include <string>
#include <string_view>

#include "can/frame.hpp"
#include "common/time.hpp"
#include "plant/tap.hpp"

namespace candp2::capture {

class CanLog {
 public:
  CanLog() = default;
  ~CanLog();
  CanLog(const CanLog&) = delete;
  CanLog& operator=(const CanLog&) = delete;

  // Opens (appending) or creates the file. false and *error when it cannot be opened.
  bool open(const std::string& path, std::string* error);
  // Closes and opens the same path again (after a rotation). false and *error on failure; the log
  // is closed then and writes are dropped until the next successful reopen.
  bool reopen(std::string* error);
  bool is_open() const { return file_ != nullptr; }
  const std::string& path() const { return path_; }

  // wall_time: microseconds since the Unix epoch (candump stamps are wall-clock time).
  void write(const can::Frame& frame, Time wall_time, std::string_view interface);
  std::uint64_t lines() const { return lines_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  std::uint64_t lines_ = 0;
};

// The CAN log as an observer of the plant's tap: every frame on every bus once, stamped with the
// wall clock at the moment it is written (candump stamps are wall-clock time), under the bus's
// configured name.
class CanLogTap final : public plant::Tap {
 public:
  CanLogTap(CanLog& log, std::function<Time()> wall_clock)
      : log_(log), wall_clock_(std::move(wall_clock)) {}
  void on_can(const plant::CanRecord& r) override {
    if (log_.is_open()) log_.write(r.frame, wall_clock_(), r.bus_name);
  }

 private:
  CanLog& log_;
  std::function<Time()> wall_clock_;
};

}  // namespace candp2::capture

// The CAN log file (log.can_log): every frame in `candump -l` notation,
// "(1700000000.123456) can0 309#0B0A0F0E0D0C", readable by canplayer and `candp2 replay`.
// Reopened on SIGHUP (logrotate moves the file, then signals the daemon).
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

#include "can/frame.hpp"
#include "common/time.hpp"

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

}  // namespace candp2::capture

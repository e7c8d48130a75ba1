#include "capture/can_log.hpp"

#include <cerrno>
#include <cstring>

namespace candp2::capture {

CanLog::~CanLog() {
  if (file_) std::fclose(file_);
}

bool CanLog::open(const std::string& path, std::string* error) {
  path_ = path;
  return reopen(error);
}

bool CanLog::reopen(std::string* error) {
  if (file_) std::fclose(file_);
  file_ = std::fopen(path_.c_str(), "ae");  // append, close-on-exec
  if (!file_) {
    if (error) *error = "cannot open the CAN log " + path_ + ": " + std::strerror(errno);
    return false;
  }
  // Whole lines reach the file at once (tail -f, a crash loses at most a partial line).
  std::setvbuf(file_, nullptr, _IOLBF, 4096);
  return true;
}

void CanLog::write(const can::Frame& frame, Time wall_time, std::string_view interface) {
  if (!file_) return;
  const auto us = wall_time.count();
  can::LogLine line{us / 1000000, static_cast<std::uint32_t>(us % 1000000), std::string(interface),
                    frame};
  const std::string text = can::format_log_line(line) + "\n";
  std::fputs(text.c_str(), file_);
  ++lines_;
}

}  // namespace candp2::capture

// candp2::LogSink (common/log.hpp) written through spdlog, one line per message with time, level
// and component ("2024-05-01 12:00:00.123 info  [gw5] Set_Prm accepted"), or "<6>[gw5] Set_Prm
// accepted" under systemd's journal. Shared by the applications (candp2d, candp2-drive); below
// both, so neither reaches into the other's folder.
#pragma once

#include <memory>
#include <optional>
#include <string_view>

#include "common/log.hpp"

namespace spdlog {
class logger;
}

namespace candp2::logsink {

// True when standard error is systemd's journal stream ($JOURNAL_STREAM, systemd.exec(5)).
bool stderr_is_journal();

// "trace", "debug", "info", "warn" (or "warning"), "error".
std::optional<LogLevel> parse_level(std::string_view name);

class SpdlogSink final : public LogSink {
 public:
  // Writes to `logger`; a null logger writes to standard error, in journald's format ("<6>[gw5]
  // ...": syslog priority prefix, no time) when standard error is the journal.
  explicit SpdlogSink(LogLevel level, std::shared_ptr<spdlog::logger> logger = nullptr);
  ~SpdlogSink() override;
  bool enabled(LogLevel level) const override { return level >= level_; }
  void write(LogLevel level, std::string_view component, std::string_view message) override;
  void set_level(LogLevel level);
  LogLevel level() const { return level_; }
  void flush();

 private:
  LogLevel level_;
  std::shared_ptr<spdlog::logger> logger_;
  bool journal_ = false;
};

}  // namespace candp2::logsink

// A replaceable log sink with levels, so tests read what was logged. Components take a LogSink*;
// a null pointer or NullLog discards. The daemon installs a sink that writes through spdlog.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace candp2 {

enum class LogLevel { Trace, Debug, Info, Warn, Error };

std::string_view to_string(LogLevel level);

class LogSink {
 public:
  virtual ~LogSink() = default;
  virtual bool enabled(LogLevel level) const { return level >= LogLevel::Info; }
  virtual void write(LogLevel level, std::string_view component, std::string_view message) = 0;
};

// Collects lines; used by tests to assert on what was logged.
class MemoryLog : public LogSink {
 public:
  struct Line {
    LogLevel level;
    std::string component;
    std::string message;
  };
  bool enabled(LogLevel) const override { return true; }
  void write(LogLevel level, std::string_view component, std::string_view message) override {
    lines.push_back({level, std::string(component), std::string(message)});
  }
  bool contains(std::string_view needle) const {
    for (const auto& l : lines)
      if (l.message.find(needle) != std::string::npos) return true;
    return false;
  }
  std::vector<Line> lines;
};

// Logs only when a sink is set and the level is enabled; formatting is skipped otherwise.
class Logger {
 public:
  Logger() = default;
  Logger(LogSink* sink, std::string component) : sink_(sink), component_(std::move(component)) {}
  bool enabled(LogLevel level) const { return sink_ && sink_->enabled(level); }
  void log(LogLevel level, std::string_view message) const {
    if (enabled(level)) sink_->write(level, component_, message);
  }
  void debug(std::string_view m) const { log(LogLevel::Debug, m); }
  void info(std::string_view m) const { log(LogLevel::Info, m); }
  void warn(std::string_view m) const { log(LogLevel::Warn, m); }
  void error(std::string_view m) const { log(LogLevel::Error, m); }
  LogSink* sink() const { return sink_; }

 private:
  LogSink* sink_ = nullptr;
  std::string component_;
};

inline std::string_view to_string(LogLevel level) {
  switch (level) {
    case LogLevel::Trace:
      return "trace";
    case LogLevel::Debug:
      return "debug";
    case LogLevel::Info:
      return "info";
    case LogLevel::Warn:
      return "warn";
    case LogLevel::Error:
      return "error";
  }
  return "?";
}

}  // namespace candp2

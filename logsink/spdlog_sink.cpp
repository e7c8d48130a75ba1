#include "logsink/spdlog_sink.hpp"

#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

namespace candp2::logsink {

namespace {

spdlog::level::level_enum to_spdlog(LogLevel l) {
  switch (l) {
    case LogLevel::Trace:
      return spdlog::level::trace;
    case LogLevel::Debug:
      return spdlog::level::debug;
    case LogLevel::Info:
      return spdlog::level::info;
    case LogLevel::Warn:
      return spdlog::level::warn;
    case LogLevel::Error:
      return spdlog::level::err;
  }
  return spdlog::level::info;
}

}  // namespace

std::optional<LogLevel> parse_level(std::string_view name) {
  if (name == "trace") return LogLevel::Trace;
  if (name == "debug") return LogLevel::Debug;
  if (name == "info") return LogLevel::Info;
  if (name == "warn" || name == "warning") return LogLevel::Warn;
  if (name == "error") return LogLevel::Error;
  return std::nullopt;
}

SpdlogSink::SpdlogSink(LogLevel level, std::shared_ptr<spdlog::logger> logger)
    : level_(level), logger_(std::move(logger)) {
  if (!logger_) {
    // Unsynchronized (_st): the daemon logs from its one event-loop thread only. Standard error,
    // so that systemd's journal or a redirect captures it; no colours (they end up in files).
    logger_ = std::make_shared<spdlog::logger>("candp2d",
                                               std::make_shared<spdlog::sinks::stderr_sink_st>());
    logger_->set_pattern("%Y-%m-%d %H:%M:%S.%e %-5l %v");
  }
  set_level(level);
}

SpdlogSink::~SpdlogSink() {
  flush();
}

void SpdlogSink::set_level(LogLevel level) {
  level_ = level;
  logger_->set_level(to_spdlog(level));
  // Warnings and errors reach the terminal or journal at once; the rest is flushed by the
  // stream's own buffering (stderr is unbuffered anyway).
  logger_->flush_on(spdlog::level::warn);
}

void SpdlogSink::write(LogLevel level, std::string_view component, std::string_view message) {
  logger_->log(to_spdlog(level), "[{}] {}", component, message);
}

void SpdlogSink::flush() {
  logger_->flush();
}

}  // namespace candp2::logsink

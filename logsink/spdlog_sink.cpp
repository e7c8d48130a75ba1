#include "logsink/spdlog_sink.hpp"

#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <systemd/sd-daemon.h>

#include <cstdio>
#include <cstdlib>

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

// sd-daemon.h: "<N>" syslog priority prefixes that journald reads from a service's output.
const char* journal_priority(LogLevel l) {
  switch (l) {
    case LogLevel::Trace:
    case LogLevel::Debug:
      return SD_DEBUG;
    case LogLevel::Info:
      return SD_INFO;
    case LogLevel::Warn:
      return SD_WARNING;
    case LogLevel::Error:
      return SD_ERR;
  }
  return SD_INFO;
}

}  // namespace

bool stderr_is_journal() {
  // systemd.exec(5), $JOURNAL_STREAM: "DEVICE:INODE" of the stream connected to the journal; the
  // process's standard error is that stream when fstat(2) reports the same pair.
  const char* env = std::getenv("JOURNAL_STREAM");
  if (!env) return false;
  unsigned long long dev = 0, ino = 0;
  char end = 0;
  if (std::sscanf(env, "%llu:%llu%c", &dev, &ino, &end) != 2) return false;
  struct stat st {};
  if (::fstat(2, &st) != 0) return false;
  return static_cast<unsigned long long>(st.st_dev) == dev &&
         static_cast<unsigned long long>(st.st_ino) == ino;
}

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
    // Under systemd's journal: the level as a syslog priority prefix, no time (journald stamps
    // every line itself).
    journal_ = stderr_is_journal();
    logger_->set_pattern(journal_ ? "%v" : "%Y-%m-%d %H:%M:%S.%e %-5l %v");
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
  if (journal_)
    logger_->log(to_spdlog(level), "{}[{}] {}", journal_priority(level), component, message);
  else
    logger_->log(to_spdlog(level), "[{}] {}", component, message);
}

void SpdlogSink::flush() {
  logger_->flush();
}

}  // namespace candp2::logsink

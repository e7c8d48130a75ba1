// A tiny script runner for golden tests of the drive simulator in candp2 notation.
//
//   > 201#3D4000        the master sends this frame (candump notation)
//   < 181#40810100      the drive's next frame must be this one; "**" matches any byte
//   ~ 100               time passes: advance by 100 ms
//   ? 31 = 0CCD         register 0x31 holds 0x0CCD
//   ! limit+ 1          input change: limit+ / limit- / enable / power (0|1), errors HEX
//   $ saves 1           the drive's parameter store was written once (EEPROM write 0x84)
//   # ...               comment
//
// Strict: before every '>', '~', '!' and at the end, every frame the drive sent must have been
// matched by a '<' line. Failures name the line and print the whole trace.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <deque>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "can/frame.hpp"
#include "drive_sim/parameter_store.hpp"
#include "drive_sim/unitek_drive.hpp"

namespace candp2::drive::test {

struct CollectSink final : can::FrameSink {
  void send(const can::Frame& f) override { frames.push_back(f); }
  std::vector<can::Frame> frames;
};

// "181#40**3100": identifier and bytes, "**" for any byte.
struct FramePattern {
  std::uint32_t id = 0;
  std::vector<std::optional<std::uint8_t>> bytes;

  static std::optional<FramePattern> parse(std::string_view text) {
    const auto hash = text.find('#');
    if (hash != 3) return std::nullopt;
    FramePattern p;
    p.id = static_cast<std::uint32_t>(std::stoul(std::string(text.substr(0, 3)), nullptr, 16));
    const auto data = text.substr(4);
    if (data.size() % 2 != 0 || data.size() > 16) return std::nullopt;
    for (std::size_t i = 0; i < data.size(); i += 2) {
      const auto pair = data.substr(i, 2);
      if (pair == "**") {
        p.bytes.emplace_back();
      } else {
        p.bytes.emplace_back(static_cast<std::uint8_t>(std::stoul(std::string(pair), nullptr, 16)));
      }
    }
    return p;
  }

  bool matches(const can::Frame& f) const {
    if (f.extended || f.remote || f.id != id || f.dlc != bytes.size()) return false;
    for (std::size_t i = 0; i < bytes.size(); ++i)
      if (bytes[i] && *bytes[i] != f.data[i]) return false;
    return true;
  }
};

struct TraceLine {
  Time time;
  bool from_master;
  can::Frame frame;
};

class Replay {
 public:
  // `step_ms` > 0 slices every '~' into advance() calls of that many ms (determinism checks).
  explicit Replay(UnitekDrive::Options options, Time start = Time{5'000'250},
                  std::int64_t step_ms = 0)
      : drive_(std::move(options), &log_, &store_), now_(start), step_ms_(step_ms) {
    drive_.advance(now_, sink_);
  }

  // Runs the script; returns false (with gtest failures) at the first mismatch.
  bool run(const std::vector<std::string_view>& script) {
    for (std::size_t n = 0; n < script.size(); ++n) {
      const std::string_view line = script[n];
      SCOPED_TRACE("script line " + std::to_string(n + 1) + ": " + std::string(line));
      if (line.empty() || line[0] == '#') continue;
      const char op = line[0];
      const std::string_view arg = line.size() > 2 ? line.substr(2) : std::string_view();
      if (op != '<' && op != '?' && op != '$' && !all_matched()) return false;
      switch (op) {
        case '>': {
          const auto parsed = can::parse_candump(arg);
          if (!parsed) {
            ADD_FAILURE() << "bad frame in script: " << parsed.error.message;
            return false;
          }
          trace_.push_back({now_, true, *parsed.frame});
          drive_.on_frame(*parsed.frame, now_, sink_);
          collect();
          break;
        }
        case '<': {
          const auto pattern = FramePattern::parse(arg);
          if (!pattern) {
            ADD_FAILURE() << "bad pattern in script";
            return false;
          }
          if (pending_.empty()) {
            ADD_FAILURE() << "expected " << arg << ", the drive sent nothing\n" << dump();
            return false;
          }
          const can::Frame got = pending_.front();
          pending_.pop_front();
          if (!pattern->matches(got)) {
            ADD_FAILURE() << "expected " << arg << ", got " << can::format_candump(got) << "\n"
                          << dump();
            return false;
          }
          break;
        }
        case '~': {
          const std::int64_t ms = std::stoll(std::string(arg));
          const Time end = now_ + milliseconds(ms);
          if (step_ms_ > 0) {
            while (now_ + milliseconds(step_ms_) < end) {
              now_ += milliseconds(step_ms_);
              drive_.advance(now_, sink_);
              collect();
            }
          }
          now_ = end;
          drive_.advance(now_, sink_);
          collect();
          break;
        }
        case '?': {
          unsigned regid = 0, value = 0;
          char eq = 0;
          std::istringstream in{std::string(arg)};
          in >> std::hex >> regid >> eq >> value;
          if (!in || eq != '=' || regid > 0xFF) {
            ADD_FAILURE() << "bad register check in script";
            return false;
          }
          if (drive_.reg(static_cast<std::uint8_t>(regid)) != value) {
            ADD_FAILURE() << "register 0x" << std::hex << regid << " is 0x"
                          << drive_.reg(static_cast<std::uint8_t>(regid)) << ", expected 0x"
                          << value << "\n"
                          << dump();
            return false;
          }
          break;
        }
        case '!': {
          std::istringstream in{std::string(arg)};
          std::string what;
          unsigned value = 0;
          in >> what;
          if (what == "errors")
            in >> std::hex >> value;
          else
            in >> value;
          if (!in) {
            ADD_FAILURE() << "bad input change in script";
            return false;
          }
          if (what == "limit+")
            drive_.set_limit_switch(LimitSwitch::Plus, value != 0, now_, sink_);
          else if (what == "limit-")
            drive_.set_limit_switch(LimitSwitch::Minus, value != 0, now_, sink_);
          else if (what == "enable")
            drive_.set_enable_input(value != 0, now_, sink_);
          else if (what == "power")
            drive_.set_power_ok(value != 0, now_, sink_);
          else if (what == "errors")
            drive_.set_errors(value, now_, sink_);
          else {
            ADD_FAILURE() << "unknown input " << what;
            return false;
          }
          collect();
          break;
        }
        case '$': {
          int saves = -1;
          std::istringstream in{std::string(arg.substr(arg.find(' ') + 1))};
          in >> saves;
          EXPECT_EQ(store_.saves, saves);
          if (store_.saves != saves) return false;
          break;
        }
        default:
          ADD_FAILURE() << "unknown script operation '" << op << "'";
          return false;
      }
    }
    return all_matched();
  }

  UnitekDrive& drive() { return drive_; }
  MemoryParameterStore& store() { return store_; }
  MemoryLog& log() { return log_; }
  const std::vector<TraceLine>& trace() const { return trace_; }
  Time now() const { return now_; }

  std::string dump() const {
    std::ostringstream out;
    out << "trace (ms since start, > master, < drive):\n";
    for (const auto& t : trace_)
      out << "  " << (t.time - trace_start_).count() / 1000.0 << (t.from_master ? " > " : " < ")
          << can::format_candump(t.frame) << "\n";
    return out.str();
  }

 private:
  void collect() {
    for (const auto& f : sink_.frames) {
      pending_.push_back(f);
      trace_.push_back({now_, false, f});
    }
    sink_.frames.clear();
  }

  bool all_matched() {
    if (pending_.empty()) return true;
    ADD_FAILURE() << "the drive sent " << can::format_candump(pending_.front())
                  << " that the script does not expect\n"
                  << dump();
    return false;
  }

  MemoryLog log_;
  MemoryParameterStore store_;
  UnitekDrive drive_;
  CollectSink sink_;
  Time now_;
  Time trace_start_ = now_;
  std::int64_t step_ms_;
  std::deque<can::Frame> pending_;
  std::vector<TraceLine> trace_;
};

}  // namespace candp2::drive::test

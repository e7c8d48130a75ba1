#include "replay/scenario.hpp"

#include <cstdio>

#include "common/hex.hpp"
#include "replay/step_names.hpp"

namespace candp2::replay {

// ---------------------------------------------------------------- patterns

bool BytePattern::matches(std::span<const std::uint8_t> actual) const {
  if (actual.size() < bytes.size()) return false;
  for (std::size_t i = 0; i < bytes.size(); ++i)
    if (care[i] && actual[i] != bytes[i]) return false;
  return true;
}

std::string BytePattern::text() const {
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i) out += ' ';
    out += care[i] ? hex_bytes(std::span(&bytes[i], 1)) : "??";
  }
  return out;
}

bool FramePattern::matches(const can::Frame& f) const {
  if (any) return true;
  if (any_data) return !f.remote && f.id == frame.id && f.extended == frame.extended;
  return f == frame;
}

std::string FramePattern::text() const {
  if (any) return "*";
  if (!any_data) return can::format_candump(frame);
  std::string s = can::format_candump(frame);
  return s.substr(0, s.find('#') + 1) + "*";
}

std::string_view to_string(Db db) {
  switch (db) {
    case Db::WriteConfig:
      return "WRITE_CONFIG_DB";
    case Db::ReadConfig:
      return "READ_CONFIG_DB";
    case Db::Write:
      return "WRITE_DB";
    case Db::Read:
      return "READ_DB";
  }
  return "?";
}

std::string_view to_string(Action a) {
  if (a == Action::Note) return "note";
  for (const auto& n : kActions)
    if (n.action == a) return n.key;
  return "?";
}

bool Step::expectation() const {
  switch (action) {
    case Action::ExpectFrame:
    case Action::ExpectFrames:
    case Action::ExpectNoFrame:
    case Action::ExpectInput:
    case Action::ExpectOutput:
    case Action::ExpectDiag:
    case Action::ExpectDpState:
    case Action::ExpectDb:
    case Action::ExpectRx:
    case Action::ExpectRetValue:
    case Action::ExpectCounters:
    case Action::ExpectField:
      return true;
    default:
      return false;
  }
}

namespace {

std::string ms_text(Duration d) {
  const auto us = d.count();
  if (us % 1000 == 0) return std::to_string(us / 1000) + " ms";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f ms", static_cast<double>(us) / 1000.0);
  return buf;
}

std::string frames_text(const std::vector<FramePattern>& v) {
  std::string s;
  for (const auto& p : v) {
    if (!s.empty()) s += ' ';  // not `" " + p.text()`: GCC 12 -O3 false -Wrestrict
    s += p.text();
  }
  return s;
}

}  // namespace

std::string Step::describe() const {
  // Steps that name their gateway say so first: "left: expect_frame 201#... within 20 ms".
  const std::string& who = slave_name.empty() ? gateway_name : slave_name;
  return who.empty() ? describe_action() : who + ": " + describe_action();
}

std::string Step::describe_action() const {
  std::string s(to_string(action));
  auto window_text = [&](const char* word) {
    return window ? std::string(" ") + word + " " + ms_text(*window) : std::string();
  };
  switch (action) {
    case Action::Note:
      return "note";
    case Action::Advance:
      return s + " " + ms_text(advance);
    case Action::Cycles:
      return s + " " + std::to_string(cycles);
    case Action::Write:
      return s + " Q" + std::to_string(address) + ": " + hex_bytes(bytes);
    case Action::Inject: {
      std::string f;
      for (const auto& fr : frames) {
        if (!f.empty()) f += ' ';  // not `" " + ...`: GCC 12 -O3 false -Wrestrict
        f += can::format_candump(fr);
      }
      return s + " " + f;
    }
    case Action::ExpectFrame:
    case Action::ExpectFrames:
      return s + " " + frames_text(frame_patterns) + window_text("within");
    case Action::ExpectNoFrame:
      return s + " " + frames_text(frame_patterns) + window_text("for");
    case Action::ExpectInput:
      return s + " I" + std::to_string(address) + ": " + pattern.text() + window_text("within");
    case Action::ExpectOutput:
      return s + " Q" + std::to_string(address) + ": " + pattern.text() + window_text("within");
    case Action::ExpectDiag:
      return s + " " + pattern.text() + window_text("within");
    case Action::ExpectDpState:
      return s + " " + std::string(dp::to_string(dp_state)) + window_text("within");
    case Action::Freigabe:
      return s + (on ? " 1" : " 0");
    case Action::DbWrite:
      return s + " " + std::string(to_string(db)) + "[" + std::to_string(db_index) + "]+" +
             std::to_string(offset) + ": " + hex_bytes(bytes);
    case Action::ExpectDb:
      return s + " " + std::string(to_string(db)) + "[" + std::to_string(db_index) + "]+" +
             std::to_string(offset) + ": " + pattern.text() + window_text("within");
    case Action::SetTx:
      return s + " " + std::to_string(entry) +
             (force ? " force " + std::to_string(*force) : std::string()) +
             (has_data ? " data " + hex_bytes(bytes) : std::string());
    case Action::ExpectRx:
      return s + " " + std::to_string(entry) +
             (count_in ? " count_in " + std::to_string(*count_in) : std::string()) +
             (has_data ? " data " + pattern.text() : std::string()) + window_text("within");
    case Action::ExpectRetValue:
      return s + " " + std::to_string(ret_value) + window_text("within");
    case Action::PowerCycle:
    case Action::Reparameterize:
    case Action::MasterStop:
    case Action::MasterResume:
      return s;
    case Action::ForceCanState:
      return s + " " + kCanStates[can_state];
    case Action::DropRx:
      return s + " " + std::to_string(count);
    case Action::ExpectCounters: {
      std::string c;
      for (const auto& [name, value] : counters)
        c += (c.empty() ? " " : ", ") + name + " " + std::to_string(value);
      return s + c + window_text("within");
    }
    case Action::DriveMute:
      return s + " " + drive_name + (on ? " on" : " off");
    case Action::DriveErrorBits:
    case Action::DriveWarningBits: {
      char b[8];
      std::snprintf(b, sizeof b, "%04X", static_cast<unsigned>(bits));
      return s + " " + drive_name + " 0x" + b;
    }
    case Action::DriveRestart:
      return s + " " + drive_name;
    case Action::SlaveOnline:
    case Action::SlavePrmFault:
    case Action::SlaveCfgFault:
      return s + (on ? " true" : " false");
    case Action::SlaveAlarm:
      if (bytes.empty()) return s + " cleared";
      s += ' ';  // not `" " + ...`: GCC 12 -O3 false -Wrestrict
      return s + hex_bytes(bytes);
    case Action::FieldWrite:
      return s + " +" + std::to_string(offset) + ": " + hex_bytes(bytes);
    case Action::ExpectField:
      return s + " +" + std::to_string(offset) + ": " + pattern.text() + window_text("within");
  }
  return s;
}

}  // namespace candp2::replay

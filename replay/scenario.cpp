#include "replay/scenario.hpp"

#include "common/hex.hpp"
#include "replay/actions.hpp"

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
  return a < Action::Count ? spec(a).key : "?";
}

bool Step::expectation() const {
  return spec(action).kind != Kind::Act;
}

std::string Step::describe() const {
  // Steps that name their gateway say so first: "left: expect_frame 201#... within 20 ms".
  const std::string& who = slave_name.empty() ? gateway_name : slave_name;
  return who.empty() ? describe_action() : who + ": " + describe_action();
}

std::string Step::describe_action() const {
  return spec(action).describe(*this, std::string(to_string(action)));
}

}  // namespace candp2::replay

#include "drive_sim/parameter_store.hpp"

#include <charconv>
#include <cstdio>

#include "drive_sim/registers.hpp"

namespace candp2::drive {

namespace {

constexpr std::string_view kHeader =
    "# candp2-drive parameter memory (REGID 0x84 EEPROM write), format 1\n";

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

std::optional<std::uint64_t> parse_hex(std::string_view s) {
  if (s.size() < 3 || s[0] != '0' || (s[1] != 'x' && s[1] != 'X')) return std::nullopt;
  s.remove_prefix(2);
  if (s.size() > 8) return std::nullopt;
  std::uint64_t v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v, 16);
  if (ec != std::errc{} || ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

}  // namespace

std::string format_state_file(const StoredParameters& parameters) {
  std::string out(kHeader);
  char line[96];
  for (const auto& [regid, value] : parameters.values) {
    const RegisterInfo& info = register_info(regid);
    if (info.width == Width::W32)
      std::snprintf(line, sizeof line, "0x%02X = 0x%08X  # %.*s\n", regid, value,
                    static_cast<int>(info.name.size()), info.name.data());
    else
      std::snprintf(line, sizeof line, "0x%02X = 0x%04X  # %.*s\n", regid, value & 0xFFFFu,
                    static_cast<int>(info.name.size()), info.name.data());
    out += line;
  }
  return out;
}

StateFileParse parse_state_file(std::string_view text) {
  StateFileParse result;
  StoredParameters params;
  std::size_t line_no = 0;
  auto fail = [&](std::string message) {
    result.line = line_no;
    result.error = "line " + std::to_string(line_no) + ": " + std::move(message);
    return result;
  };
  while (!text.empty()) {
    ++line_no;
    const auto nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text.remove_prefix(nl == std::string_view::npos ? text.size() : nl + 1);
    if (const auto hash = line.find('#'); hash != std::string_view::npos)
      line = line.substr(0, hash);
    line = trim(line);
    if (line.empty()) continue;
    const auto eq = line.find('=');
    if (eq == std::string_view::npos) return fail("expected 'REGID = VALUE'");
    const auto regid = parse_hex(trim(line.substr(0, eq)));
    const auto value = parse_hex(trim(line.substr(eq + 1)));
    if (!regid || *regid > 0xFF) return fail("REGID must be a hex number 0x00..0xFF");
    if (!value) return fail("value must be a hex number of at most 8 digits");
    const RegisterInfo& info = register_info(static_cast<std::uint8_t>(*regid));
    if (info.width == Width::W16 && *value > 0xFFFF)
      return fail("value does not fit the 16-bit register " + std::string(info.name));
    if (!params.values
             .emplace(static_cast<std::uint8_t>(*regid), static_cast<std::uint32_t>(*value))
             .second)
      return fail("REGID listed twice");
  }
  result.parameters = std::move(params);
  return result;
}

}  // namespace candp2::drive

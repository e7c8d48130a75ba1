#include "can/frame.hpp"

#include <algorithm>
#include <charconv>
#include <cstdio>

#include "common/hex.hpp"

namespace candp2::can {

namespace {

ParseResult fail(std::size_t column, std::string message) {
  ParseResult r;
  r.error = {column, std::move(message)};
  return r;
}

}  // namespace

Frame Frame::data_frame(std::uint32_t id, bool extended, std::span<const std::uint8_t> bytes) {
  Frame f;
  f.extended = extended;
  f.id = id & (extended ? kMaxExtId : kMaxStdId);
  f.dlc = static_cast<std::uint8_t>(std::min<std::size_t>(bytes.size(), kMaxDlc));
  std::copy_n(bytes.begin(), f.dlc, f.data.begin());
  return f;
}

Frame Frame::std_data(std::uint32_t id, std::span<const std::uint8_t> bytes) {
  return data_frame(id, false, bytes);
}

Frame Frame::ext_data(std::uint32_t id, std::span<const std::uint8_t> bytes) {
  return data_frame(id, true, bytes);
}

Frame Frame::rtr(std::uint32_t id, bool extended, std::uint8_t dlc) {
  Frame f;
  f.extended = extended;
  f.id = id & (extended ? kMaxExtId : kMaxStdId);
  f.remote = true;
  f.dlc = std::min(dlc, kMaxDlc);
  return f;
}

ParseResult parse_candump(std::string_view text) {
  const auto hash = text.find('#');
  if (hash == std::string_view::npos) return fail(text.size(), "expected '#' after the identifier");
  const auto id_text = text.substr(0, hash);
  if (id_text.size() != 3 && id_text.size() != 8)
    return fail(0, "identifier must have 3 (11-bit) or 8 (29-bit) hex digits, got " +
                       std::to_string(id_text.size()));
  std::size_t bad = 0;
  const auto parsed = parse_hex_u32(id_text, &bad);
  if (!parsed) return fail(bad, std::string("not a hex digit: '") + id_text[bad] + "'");
  const std::uint32_t id = *parsed;
  const bool extended = id_text.size() == 8;
  if (!extended && id > kMaxStdId) return fail(0, "11-bit identifier above 0x7FF");
  if (extended && id > kMaxExtId) return fail(0, "29-bit identifier above 0x1FFFFFFF");

  std::size_t pos = hash + 1;
  if (pos < text.size() && (text[pos] == 'R' || text[pos] == 'r')) {
    ++pos;
    std::uint8_t dlc = 0;
    if (pos < text.size()) {
      const int v = hex_digit(text[pos]);
      if (v < 0 || v > kMaxDlc) return fail(pos, "remote frame length must be a digit 0..8");
      dlc = static_cast<std::uint8_t>(v);
      ++pos;
    }
    if (pos != text.size()) return fail(pos, "unexpected text after remote frame length");
    ParseResult r;
    r.frame = Frame::rtr(id, extended, dlc);
    return r;
  }

  std::array<std::uint8_t, 8> bytes{};
  std::size_t n = 0;
  while (pos < text.size()) {
    if (text[pos] == '.') {
      ++pos;
      continue;
    }
    if (n == kMaxDlc) return fail(pos, "more than 8 data bytes");
    if (pos + 1 >= text.size()) return fail(pos, "odd number of hex digits in data");
    const int hi = hex_digit(text[pos]);
    const int lo = hex_digit(text[pos + 1]);
    if (hi < 0) return fail(pos, std::string("not a hex digit: '") + text[pos] + "'");
    if (lo < 0) return fail(pos + 1, std::string("not a hex digit: '") + text[pos + 1] + "'");
    bytes[n++] = static_cast<std::uint8_t>((hi << 4) | lo);
    pos += 2;
  }
  ParseResult r;
  r.frame = Frame::data_frame(id, extended, std::span(bytes.data(), n));
  return r;
}

std::string format_candump(const Frame& f) {
  std::string out = ident_text(ident_of(f));
  out += '#';
  if (f.remote) {
    out += 'R';
    if (f.dlc != 0) out += static_cast<char>('0' + f.dlc);
    return out;
  }
  static constexpr char kHex[] = "0123456789ABCDEF";
  for (std::uint8_t i = 0; i < f.dlc; ++i) {
    out += kHex[f.data[i] >> 4];
    out += kHex[f.data[i] & 0xF];
  }
  return out;
}

LogParseResult parse_log_line(std::string_view text) {
  LogParseResult r;
  auto err = [&](std::size_t col, std::string msg) {
    r.error = {col, std::move(msg)};
    return r;
  };
  // Trim trailing newline / CR / spaces.
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' '))
    text.remove_suffix(1);
  if (text.empty() || text.front() != '(') return err(0, "expected '(' starting the timestamp");
  const auto close = text.find(')');
  if (close == std::string_view::npos) return err(text.size(), "expected ')' after the timestamp");
  const auto stamp = text.substr(1, close - 1);
  const auto dot = stamp.find('.');
  if (dot == std::string_view::npos || stamp.size() - dot - 1 != 6)
    return err(1, "timestamp must be SECONDS.MICROSECONDS with 6 fraction digits");
  LogLine line;
  {
    auto [p, ec] = std::from_chars(stamp.data(), stamp.data() + dot, line.sec);
    if (ec != std::errc{} || p != stamp.data() + dot) return err(1, "bad seconds in timestamp");
    auto [p2, ec2] =
        std::from_chars(stamp.data() + dot + 1, stamp.data() + stamp.size(), line.usec);
    if (ec2 != std::errc{} || p2 != stamp.data() + stamp.size())
      return err(dot + 2, "bad microseconds in timestamp");
  }
  std::size_t pos = close + 1;
  if (pos >= text.size() || text[pos] != ' ') return err(pos, "expected ' ' after the timestamp");
  ++pos;
  const auto sp = text.find(' ', pos);
  if (sp == std::string_view::npos || sp == pos) return err(pos, "expected an interface name");
  line.interface = std::string(text.substr(pos, sp - pos));
  pos = sp + 1;
  auto frame_text = text.substr(pos);
  // candump -l may append " T"/" R" direction flags; accept and ignore them.
  if (const auto extra = frame_text.find(' '); extra != std::string_view::npos)
    frame_text = frame_text.substr(0, extra);
  auto parsed = parse_candump(frame_text);
  if (!parsed) return err(pos + parsed.error.column, parsed.error.message);
  line.frame = *parsed.frame;
  r.line = std::move(line);
  return r;
}

std::string format_log_line(const LogLine& line) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "(%lld.%06u) ", static_cast<long long>(line.sec),
                static_cast<unsigned>(line.usec));
  return buf + line.interface + " " + format_candump(line.frame);
}

std::string ident_text(const Ident& id) {
  char buf[16];
  std::snprintf(buf, sizeof buf, id.extended ? "%08X" : "%03X", static_cast<unsigned>(id.id));
  return buf;
}

}  // namespace candp2::can

// CAN frames and the candump text notation (can-utils lib.c conventions).
//
// Pure value types and pure functions: no sockets, no clock.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace candp2::can {

// ISO 11898-1: 11-bit base identifiers, 29-bit extended identifiers, DLC 0..8 (classic CAN).
inline constexpr std::uint32_t kMaxStdId = 0x7FF;
inline constexpr std::uint32_t kMaxExtId = 0x1FFFFFFF;
inline constexpr std::uint8_t kMaxDlc = 8;

struct Frame {
  std::uint32_t id = 0;                // 11- or 29-bit value, without flag bits
  bool extended = false;               // 29-bit identifier
  bool remote = false;                 // remote transmission request
  std::uint8_t dlc = 0;                // 0..8; for remote frames the requested length
  std::array<std::uint8_t, 8> data{};  // bytes past dlc are always zero

  std::span<const std::uint8_t> payload() const { return {data.data(), remote ? 0u : dlc}; }

  friend bool operator==(const Frame&, const Frame&) = default;

  // Builders that keep the invariants (bytes past dlc zero, ids in range, dlc <= 8).
  static Frame std_data(std::uint32_t id, std::span<const std::uint8_t> bytes);
  static Frame ext_data(std::uint32_t id, std::span<const std::uint8_t> bytes);
  static Frame data_frame(std::uint32_t id, bool extended, std::span<const std::uint8_t> bytes);
  static Frame rtr(std::uint32_t id, bool extended, std::uint8_t dlc);
};

// A key that identifies "the same identifier" for Rx matching: value plus 11/29-bit kind.
struct Ident {
  std::uint32_t id = 0;
  bool extended = false;
  friend bool operator==(const Ident&, const Ident&) = default;
  friend auto operator<=>(const Ident&, const Ident&) = default;
};
inline Ident ident_of(const Frame& f) {
  return {f.id, f.extended};
}
// An identifier as candump writes it: 3 hex digits for 11 bits, 8 for 29 bits ("181",
// "12345678"). Every log line, report and decoder that names an identifier uses this.
std::string ident_text(const Ident& id);

// candump "compact" notation, as cansend accepts it:
//   123#1122        11-bit data frame (3 hex digits)
//   12345678#       29-bit data frame (8 hex digits), DLC 0
//   123#R           remote frame, DLC 0
//   123#R4          remote frame, DLC 4
// Data bytes may be separated by '.' (cansend allows 11.22.33).
struct ParseError {
  std::size_t column = 0;  // 0-based character position in the input
  std::string message;
};

struct ParseResult {
  std::optional<Frame> frame;
  ParseError error;  // meaningful when !frame
  explicit operator bool() const { return frame.has_value(); }
};

ParseResult parse_candump(std::string_view text);
std::string format_candump(const Frame& f);  // canonical: uppercase hex, no separators

// candump -l log line: "(1700000000.123456) can0 123#1122"
struct LogLine {
  std::int64_t sec = 0;
  std::uint32_t usec = 0;  // 0..999999
  std::string interface;
  Frame frame;
};

struct LogParseResult {
  std::optional<LogLine> line;
  ParseError error;
  explicit operator bool() const { return line.has_value(); }
};

LogParseResult parse_log_line(std::string_view text);
std::string format_log_line(const LogLine& line);

}  // namespace candp2::can

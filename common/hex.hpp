// Hex as text, both ways: the one writer for logs, reports, the HTTP documents and golden tests
// ("11 22 33", upper case, space separated; one byte as "0x1F") and the one reader for bytes a
// user writes in hex (a slot's comment field, prm_hex/cfg_hex, a replay scenario's byte patterns)
// and for a hex number (a CAN identifier).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace candp2 {

inline std::string hex_bytes(std::span<const std::uint8_t> bytes, char sep = ' ') {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  out.reserve(bytes.size() * 3);
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i && sep) out += sep;
    out += kHex[bytes[i] >> 4];
    out += kHex[bytes[i] & 0xF];
  }
  return out;
}

// One byte with its prefix, "0x1F" (the low 8 bits of v): a form byte, a Set_Prm byte in a
// report or a finding.
inline std::string hex8(unsigned v) {
  const std::uint8_t b = static_cast<std::uint8_t>(v & 0xFFu);
  return "0x" + hex_bytes(std::span(&b, 1));
}

// 0..15 for 0-9, a-f, A-F; -1 for anything else.
int hex_digit(char c);

// The value of 1 to 8 hex digits without prefix or sign ("181", "1FFFFFFF"): a CAN identifier in
// candump or socketcand notation, an error class. nullopt for no digits, more than 8 digits or a
// character that is not a hex digit; *bad (when given) is then that character's position (0 for
// an empty or too long text).
std::optional<std::uint32_t> parse_hex_u32(std::string_view text, std::size_t* bad = nullptr);

// How the bytes are written. Spaces, commas and tabs separate bytes in every form.
enum class HexForm : std::uint8_t {
  // "02,89,B8", "FF EF 00 00 00": every byte is its own two digits between separators, as in a
  // SIMATIC comment field (manual §5.1.4).
  Separated,
  // "88 80 C4", "8880C4", "88,80,C4": runs of digits, two per byte.
  Runs,
  // "00 33 ?? 00", "0033??00": two digits or "??" (any byte) per byte.
  Patterns,
};

struct HexBytes {
  std::vector<std::uint8_t> bytes;
  std::vector<bool> care;  // per byte: false for "??" (HexForm::Patterns); true otherwise
};

// Reads `text` in the given form. nullopt and *error (when given) for malformed text, naming the
// 0-based position: "position 3: 'G' is not a hex digit". Text without any byte is an error
// ("no bytes given") unless `allow_empty`.
std::optional<HexBytes> parse_hex_bytes(std::string_view text, HexForm form, std::string* error,
                                        bool allow_empty = false);

}  // namespace candp2

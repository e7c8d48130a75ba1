// Hex dumps for logs, reports and golden tests: "11 22 33" (upper case, space separated).
#pragma once

#include <cstdint>
#include <span>
#include <string>

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

}  // namespace candp2

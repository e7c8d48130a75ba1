// The telegrams of docs/profibus.md "A real master's first telegrams" (an independent open-source
// class 1 master at address 2 parameterizing slave 3 at 19200 baud) and small helpers shared by
// the FDL tests.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/hex.hpp"

namespace candp2::fdl::test {

// "10 03 02" -> bytes. Characters other than hex digits separate.
inline std::vector<std::uint8_t> B(std::string_view text) {
  std::vector<std::uint8_t> out;
  int nibbles = 0;
  unsigned v = 0;
  auto digit = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  for (char c : text) {
    const int d = digit(c);
    if (d < 0) {
      if (nibbles) out.push_back(static_cast<std::uint8_t>(v));
      nibbles = 0;
      v = 0;
      continue;
    }
    v = v * 16 + static_cast<unsigned>(d);
    if (++nibbles == 2) {
      out.push_back(static_cast<std::uint8_t>(v));
      nibbles = 0;
      v = 0;
    }
  }
  if (nibbles) out.push_back(static_cast<std::uint8_t>(v));
  return out;
}

inline std::string H(const std::vector<std::uint8_t>& b) {
  return hex_bytes(b);
}

// the capture in docs/profibus.md "A real master's first telegrams", bytes as on the wire.
inline constexpr const char* kCapFdlStatus = "10 03 02 49 4E 16";
inline constexpr const char* kCapSlaveDiag1 = "68 05 05 68 83 82 6D 3C 3E EC 16";  // FCB=1 FCV=0
inline constexpr const char* kCapSetPrm =
    "68 15 15 68 83 82 5D 3D 3E 88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF 2C 16";
inline constexpr const char* kCapChkCfg =
    "68 0F 0F 68 83 82 7D 3E 3E 43 85 02 89 B8 83 85 03 09 B8 D5 16";
inline constexpr const char* kCapSlaveDiag2 = "68 05 05 68 83 82 5D 3C 3E DC 16";
inline constexpr const char* kCapDataExch1 = "68 09 09 68 03 02 7D 11 22 33 44 55 66 E7 16";
inline constexpr const char* kCapDataExch2 = "68 09 09 68 03 02 5D 11 22 33 44 55 66 C7 16";

}  // namespace candp2::fdl::test

// The PROFIBUS line's physics, the one definition (docs/profibus.md "The line's physics"): the
// rates, 11 bits a character, TSYN, the least min_TSDR, and bit times in microseconds. In the base
// room because the serial PHY (serial/) and the FDL above it (profibus_sim/fdl/line_timing.hpp,
// which adds the bus parameters and telegram lengths) both need it. Pure: numbers in, numbers out.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>

#include "common/time.hpp"

namespace candp2::phy {

// Every character is 11 bits on the wire: start, 8 data, even parity, stop (IEC 61158-2 UART).
inline constexpr std::uint64_t kBitsPerChar = 11;
// TSYN: the idle a station must see before it may send a request or a token; a receiver that
// sees it ends a partial telegram.
inline constexpr std::uint64_t kTsynBits = 33;
// The least min_TSDR, and the one a station uses until a Set_Prm sets another (IEC 61158-6-3).
inline constexpr std::uint32_t kMinTsdrBits = 11;

// The ten DP rates (bit/s), slowest first; 45450 is the "45.45 kbit/s" rate.
inline constexpr std::array<std::uint32_t, 10> kLineRates = {
    9600, 19200, 45450, 93750, 187500, 500000, 1500000, 3000000, 6000000, 12000000};

constexpr bool is_line_rate(std::uint32_t baud) {
  return std::find(kLineRates.begin(), kLineRates.end(), baud) != kLineRates.end();
}
// "9600, 19200, 45450, ..." for error messages.
inline std::string line_rates_text() {
  std::string s;
  for (auto r : kLineRates) s += (s.empty() ? "" : ", ") + std::to_string(r);
  return s;
}

// Bit times → microseconds at `baud`, rounded up: for every timer and deadline (a line event
// happens no earlier than its last bit). 0 at baud 0. Whole seconds apart, so that a bit count
// since a daemon's start never overflows (a CAN bus in time counts its bits so too).
constexpr Duration bits_to_time(std::uint32_t baud, std::uint64_t bits) {
  if (baud == 0) return Duration(0);
  const std::uint64_t q = bits / baud, r = bits % baud;
  return Duration(
      static_cast<std::int64_t>(q * 1'000'000ull + (r * 1'000'000ull + baud - 1) / baud));
}
// Bit times → microseconds at `baud`, rounded down: for a time stamp of something captured (a
// clock shows the microsecond a bit falls in, as candp2 sniff stamps a raw file's telegrams).
constexpr Duration bits_to_timestamp(std::uint32_t baud, std::uint64_t bits) {
  if (baud == 0) return Duration(0);
  return Duration(static_cast<std::int64_t>(bits * 1'000'000ull / baud));
}
// Microseconds → whole bit times at `baud`, rounded up.
constexpr std::uint64_t time_to_bits(std::uint32_t baud, Duration d) {
  if (d.count() <= 0) return 0;
  const auto us = static_cast<std::uint64_t>(d.count());
  const std::uint64_t q = us / 1'000'000ull, r = us % 1'000'000ull;
  return q * baud + (r * baud + 999'999ull) / 1'000'000ull;
}
// The wire time of `chars` characters at `baud`, rounded up.
constexpr Duration char_time(std::uint32_t baud, std::uint64_t chars = 1) {
  return bits_to_time(baud, kBitsPerChar * chars);
}

}  // namespace candp2::phy

// The CAN-DP/2 on a PROFIBUS line in time (docs/profibus.md "The line in time"): the latest it
// answers a request at each rate, MaxTsdr in bit times, as its GSD states it (gsd/CDPS04A4.GSD,
// V1.04). It runs at all ten DP rates. A test holds this table to the shipped GSD.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

namespace candp2::gw {

struct LineRateLimit {
  std::uint32_t baud = 0;
  std::uint32_t max_tsdr_bits = 0;
};

inline constexpr std::array<LineRateLimit, 10> kLineRateLimits{{{9600, 60},
                                                                {19200, 60},
                                                                {45450, 60},
                                                                {93750, 60},
                                                                {187500, 60},
                                                                {500000, 100},
                                                                {1500000, 150},
                                                                {3000000, 250},
                                                                {6000000, 450},
                                                                {12000000, 800}}};

// MaxTsdr at `baud`; nullopt: not a rate the gateway runs at.
constexpr std::optional<std::uint32_t> max_tsdr_bits(std::uint32_t baud) {
  for (const auto& r : kLineRateLimits)
    if (r.baud == baud) return r.max_tsdr_bits;
  return std::nullopt;
}

}  // namespace candp2::gw

// What a fault does to a telegram on the wire (docs/faults.md "Line faults"): a corrupt answer,
// two stations' answers that collide, a telegram garbled by noise. Characters are UART frames of
// 11 bits (start 0, 8 data bits LSB first, even parity, stop 1); the line idles at 1, and where
// two transmitters drive it at once a 0 wins (the model of a collision, deterministic). Pure.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace candp2::fdl {

// The faults a station's answers can be given on cue (docs/faults.md "Line faults"); public
// names, and the codes of the Modbus line fault register (docs/modbus.md).
enum class StationFault : std::uint8_t {
  None = 0,
  Corrupt = 1,
  Silent = 2,
  Late = 3,
  DoubleAddress = 4
};
inline constexpr std::array<std::string_view, 5> kStationFaultNames = {"none", "corrupt", "silent",
                                                                       "late", "double_address"};
inline constexpr std::string_view to_string(StationFault f) {
  return kStationFaultNames.at(static_cast<std::size_t>(f));
}
std::optional<StationFault> station_fault(std::string_view name);

// How many bits later the second station at the same address starts its answer (its TSDR
// differs): half a character, so the two answers garble each other.
inline constexpr std::uint64_t kTwinOffsetBits = 5;

// The telegram with a wrong frame check sequence (the byte before the end delimiter inverted);
// a short acknowledgement (SC) or a token (SD4), which have none, arrive with another first
// character (0xE4, 0xDD): no start delimiter.
std::vector<std::uint8_t> corrupt_fcs(std::span<const std::uint8_t> telegram);

// Two telegrams on the wire at once, `b` starting `offset_bits` after `a`: the bytes a receiver
// reads from the first start bit on, one 11-bit frame after the other until both are over.
// `parity_errors` counts the characters whose parity bit does not match.
struct Superposed {
  std::vector<std::uint8_t> bytes;
  std::uint32_t parity_errors = 0;
  std::uint64_t bits = 0;  // how long the line is busy, from a's first bit
};
Superposed superpose(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b,
                     std::uint64_t offset_bits);

// The telegram as noise on the line leaves it: every character with bits flipped by a pattern
// drawn from `seed` (the same seed, the same damage), never a telegram that still decodes.
std::vector<std::uint8_t> garble(std::span<const std::uint8_t> telegram, std::uint64_t seed);

}  // namespace candp2::fdl

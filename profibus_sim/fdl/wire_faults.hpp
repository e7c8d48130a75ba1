// What a fault does to a telegram on the wire (docs/faults.md "Line faults"): a corrupt answer,
// two stations' answers that collide, a telegram garbled by noise. Characters are UART frames of
// 11 bits (start 0, 8 data bits LSB first, even parity, stop 1); the line idles at 1, and where
// two transmitters drive it at once a 0 wins (the model of a collision, deterministic). Pure.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace candp2::fdl {

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

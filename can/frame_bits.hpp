// A classic CAN frame on the wire (ISO 11898-1; docs/can-bus.md "Frames on the wire"): the bits of
// SOF..CRC as the controller sends them, the real CRC-15, bit stuffing counted on that stream, the
// frame's length in bit times and its duration at a bit rate, the worst-case length of the
// schedulability analysis, and the order bitwise arbitration gives two frames. One arithmetic for
// the bus load, the timing and `candp2 validate`. Pure: numbers in, numbers out; no sockets, no
// clock. CAN FD is not modelled.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>

#include "can/frame.hpp"

namespace candp2::can {

// ISO 11898-1: CRC delimiter, ACK slot, ACK delimiter (3), end of frame (7) and the intermission
// (3) between two frames; none of them is stuffed.
inline constexpr std::uint32_t kTrailerBits = 3 + 7 + 3;
// CRC-15 generator x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1, initial value 0.
inline constexpr std::uint16_t kCrc15Polynomial = 0x4599;
// A transmitter inserts a complementary bit after this many equal bits (stuff bits count in runs).
inline constexpr unsigned kStuffRun = 5;

// The bits SOF..CRC before stuffing, in the order they are sent (0 = dominant, 1 = recessive).
struct BitStream {
  std::array<std::uint8_t, 128> bits{};  // the longest: 29-bit, 8 bytes = 118 bits
  std::size_t size = 0;
  void push(std::uint32_t value, unsigned width);  // `width` bits of `value`, MSB first
  std::span<const std::uint8_t> view() const { return {bits.data(), size}; }
};

// CRC-15 of `bits` (MSB-first shift register, no reflection, no final XOR).
std::uint16_t crc15(std::span<const std::uint8_t> bits);
// The same over bytes, MSB first (the catalogued "CRC-15/CAN": check value 0x059E over
// "123456789").
std::uint16_t crc15_bytes(std::span<const std::uint8_t> bytes);

// SOF..data (what the CRC covers): SOF, identifier (11-bit: ID, RTR, IDE, r0; 29-bit: base ID,
// SRR, IDE, extended ID, RTR, r1, r0), DLC, data (none in a remote frame).
BitStream crc_region(const Frame& f);
// SOF..CRC: crc_region followed by its CRC-15, the part bit stuffing applies to.
BitStream stuffed_region(const Frame& f);
// Stuff bits a transmitter inserts into `bits`: after kStuffRun equal bits one complementary bit,
// which itself starts the next run; one after the last bit too when the last run is complete.
std::uint32_t stuff_bits(std::span<const std::uint8_t> bits);

// The frame's length in bit times, SOF through intermission, with its real stuff bits.
std::uint32_t frame_bits_exact(const Frame& f);
// The frame's length without stuff bits, SOF through intermission: 34 (11-bit) or 54 (29-bit) +
// 8·DLC + 13 (no data bits in a remote frame).
std::uint32_t frame_bits_unstuffed(bool extended, bool remote, std::uint8_t dlc);
inline std::uint32_t frame_bits_unstuffed(const Frame& f) {
  return frame_bits_unstuffed(f.extended, f.remote, f.dlc);
}
// The longest a frame of this kind and DLC can be (Davis, Burns, Bril, Lukkien 2007, eq. 1):
// g + 8·DLC + 13 + floor((g + 8·DLC − 1) / 4), g = 34 (11-bit) or 54 (29-bit); no data bits in a
// remote frame.
std::uint32_t frame_bits_worst(bool extended, bool remote, std::uint8_t dlc);
inline std::uint32_t frame_bits_worst(const Frame& f) {
  return frame_bits_worst(f.extended, f.remote, f.dlc);
}
// The longest a frame with this identifier, kind and DLC can be, whatever its data bytes: stuff
// bits counted on its real header (SOF, arbitration and control fields) and on data and CRC bits
// chosen to stuff the most (docs/can-bus.md "Frames on the wire"). The CRC follows from the data,
// and this bound lets it free, so a real frame reaches it or falls short by a bit or two: never
// below frame_bits_exact(f) with any data, never above frame_bits_worst(f). Without data bits (a
// remote frame, DLC 0) the data is known: frame_bits_exact(f).
std::uint32_t frame_bits_longest(const Frame& f);
// `bits` bit times at `bitrate` bit/s.
std::chrono::nanoseconds bits_duration(std::uint64_t bits, std::uint32_t bitrate);
inline std::chrono::nanoseconds frame_duration(const Frame& f, std::uint32_t bitrate) {
  return bits_duration(frame_bits_exact(f), bitrate);
}

// Bitwise arbitration (ISO 11898-1): the arbitration field as one number whose smaller value wins.
// 11-bit frames and 29-bit frames with the same base identifier meet at RTR against SRR and at IDE,
// so a base frame beats an extended one, and a data frame beats a remote frame of its identifier.
// Inline: asked at every request on a bus in time (docs/can-bus.md "Performance").
inline std::uint32_t arbitration_key(const Ident& id, bool remote) {
  // 32 bits: base ID (11), RTR or SRR, IDE, extended ID (18), RTR of an extended frame.
  const std::uint32_t rtr = remote ? 1 : 0;
  if (id.extended)
    return ((id.id >> 18) & 0x7FF) << 21 | 1u << 20 | 1u << 19 | (id.id & 0x3FFFF) << 1 | rtr;
  return (id.id & 0x7FF) << 21 | rtr << 20;
}
inline std::uint32_t arbitration_key(const Frame& f) {
  return arbitration_key(ident_of(f), f.remote);
}
// The identifier and kind an arbitration key was made of (its inverse).
struct ArbitrationField {
  Ident id;
  bool remote = false;
};
inline ArbitrationField arbitration_field(std::uint32_t key) {
  if ((key >> 19 & 1u) != 0)  // IDE recessive: extended
    return {{(key >> 21) << 18 | (key >> 1 & 0x3FFFFu), true}, (key & 1u) != 0};
  return {{key >> 21, false}, (key >> 20 & 1u) != 0};
}

}  // namespace candp2::can

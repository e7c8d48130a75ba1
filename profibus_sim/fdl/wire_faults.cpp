// What a fault does to a telegram on the wire (docs/faults.md "Line faults").
#include "profibus_sim/fdl/wire_faults.hpp"

#include <algorithm>
#include <bit>

#include "common/line_physics.hpp"
#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl {

namespace {

constexpr unsigned kCharBits = phy::kBitsPerChar;

// The bits of one character, bit 0 first on the wire.
std::uint16_t frame(std::uint8_t b) {
  const unsigned parity = std::popcount(b) & 1u;  // even parity: the bit makes the ones even
  return static_cast<std::uint16_t>((std::uint16_t{b} << 1) | (parity << 9) | (1u << 10));
}

// The line level at `bit` when `t` starts at bit 0: idle (1) outside it.
bool level(std::span<const std::uint8_t> t, std::uint64_t bit) {
  const std::uint64_t c = bit / kCharBits;
  if (c >= t.size()) return true;
  return (frame(t[c]) >> (bit % kCharBits)) & 1u;
}

}  // namespace

std::optional<StationFault> station_fault(std::string_view name) {
  for (std::size_t i = 0; i < kStationFaultNames.size(); ++i)
    if (kStationFaultNames[i] == name) return static_cast<StationFault>(i);
  return std::nullopt;
}

std::vector<std::uint8_t> corrupt_fcs(std::span<const std::uint8_t> telegram) {
  std::vector<std::uint8_t> out(telegram.begin(), telegram.end());
  if (out.size() == 1 || (!out.empty() && out[0] == kSD4)) {
    // No FCS (SC, token): the start delimiter is hit instead (SC 0xE5 -> 0xE4, SD4 0xDC ->
    // 0xDD: no delimiter). Inverting a token's DA would make a valid token to another station.
    out[0] = static_cast<std::uint8_t>(out[0] ^ 0x01);
  } else if (out.size() >= 2) {
    out[out.size() - 2] = static_cast<std::uint8_t>(~out[out.size() - 2]);
  }
  return out;
}

Superposed superpose(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b,
                     std::uint64_t offset_bits) {
  Superposed s;
  const std::uint64_t end =
      std::max<std::uint64_t>(a.size() * kCharBits, offset_bits + b.size() * kCharBits);
  auto at = [&](std::uint64_t bit) {
    const bool lb = bit < offset_bits ? true : level(b, bit - offset_bits);
    return level(a, bit) && lb;  // a 0 on either driver wins
  };
  // A receiver: wait for a start bit (0), sample 11 bits, repeat.
  std::uint64_t bit = 0;
  while (bit < end) {
    if (at(bit)) {
      ++bit;
      continue;
    }
    std::uint16_t f = 0;
    for (unsigned i = 0; i < kCharBits; ++i)
      if (at(bit + i)) f = static_cast<std::uint16_t>(f | (1u << i));
    const auto byte = static_cast<std::uint8_t>(f >> 1);
    if (((f >> 9) & 1u) != (std::popcount(byte) & 1u)) ++s.parity_errors;
    s.bytes.push_back(byte);
    bit += kCharBits;
  }
  s.bits = std::max(end, bit);
  return s;
}

std::vector<std::uint8_t> garble(std::span<const std::uint8_t> telegram, std::uint64_t seed) {
  std::vector<std::uint8_t> out(telegram.begin(), telegram.end());
  std::uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
  for (auto& b : out) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    b = static_cast<std::uint8_t>(b ^ (1u << (x % 8)));  // one bit a character
  }
  if (decode(out).telegram) out[0] = static_cast<std::uint8_t>(out[0] ^ 0x01);
  if (decode(out).telegram && !out.empty()) out.back() = static_cast<std::uint8_t>(~out.back());
  return out;
}

}  // namespace candp2::fdl

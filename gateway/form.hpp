// The `form` swap byte (manual §5.2.2, docs/slots.md "Data exchange in normal mode"): Motorola
// (PLC) <-> Intel (CAN) byte order.
//
// Bit 7 belongs to data byte 1, bit 0 to data byte 8. A run of 1-bits followed by the next 0-bit
// marks a group of bytes (the 0-bit's byte included); each group's byte order is reversed. A 0-bit
// not closing a run leaves its byte unchanged; a group still open at the last data byte ends there.
// The function is its own inverse, so the same call converts in both directions.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <utility>

namespace candp2::gw {

// manual §5.2.2 examples: 0x8E swaps bytes 1-2 and 5-8, 0xFE all eight, 0x00 nothing.
inline constexpr std::uint8_t kFormNone = 0x00;

inline void form_swap(std::span<std::uint8_t> data, std::uint8_t form) {
  if (form == kFormNone) return;
  const std::size_t n = data.size() < 8 ? data.size() : 8;
  std::size_t start = 0;
  bool open = false;
  auto reverse = [&](std::size_t first, std::size_t last) {
    while (first < last) std::swap(data[first++], data[last--]);
  };
  for (std::size_t i = 0; i < n; ++i) {
    const bool bit = (form >> (7 - i)) & 1u;
    if (bit && !open) {
      open = true;
      start = i;
    } else if (!bit && open) {
      reverse(start, i);
      open = false;
    }
  }
  if (open && n > 0) reverse(start, n - 1);
}

// The same conversion as a permutation: out[i] = in[perm[i]]. Precomputed per slot so the hot
// path is a table lookup instead of a bit walk.
inline std::array<std::uint8_t, 8> form_permutation(std::uint8_t form, std::size_t n) {
  std::array<std::uint8_t, 8> perm{0, 1, 2, 3, 4, 5, 6, 7};
  form_swap(std::span(perm.data(), n < 8 ? n : 8), form);
  return perm;
}

}  // namespace candp2::gw

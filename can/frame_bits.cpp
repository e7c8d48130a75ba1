// A classic CAN frame on the wire (docs/can-bus.md "Frames on the wire").
#include "can/frame_bits.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>

namespace candp2::can {

void BitStream::push(std::uint32_t value, unsigned width) {
  for (unsigned i = width; i-- > 0;) bits[size++] = static_cast<std::uint8_t>((value >> i) & 1u);
}

namespace {
std::uint16_t crc15_step(std::uint16_t crc, std::uint8_t bit) {
  const bool feedback = (((crc >> 14) & 1u) ^ bit) != 0;
  crc = static_cast<std::uint16_t>((crc << 1) & 0x7FFF);
  return feedback ? static_cast<std::uint16_t>(crc ^ kCrc15Polynomial) : crc;
}
}  // namespace

std::uint16_t crc15(std::span<const std::uint8_t> bits) {
  std::uint16_t crc = 0;
  for (const auto b : bits) crc = crc15_step(crc, b);
  return crc;
}

std::uint16_t crc15_bytes(std::span<const std::uint8_t> bytes) {
  std::uint16_t crc = 0;
  for (const auto byte : bytes)
    for (unsigned i = 8; i-- > 0;)
      crc = crc15_step(crc, static_cast<std::uint8_t>((byte >> i) & 1));
  return crc;
}

namespace {
// The fields of the CRC region in the order they are sent, each as out(value, width).
template <class Out>
void region_fields(const Frame& f, Out&& out) {
  const std::uint32_t rtr = f.remote ? 1 : 0;
  out(0, 1);  // SOF (dominant)
  if (f.extended) {
    out(f.id >> 18, 11);  // base identifier
    out(1, 1);            // SRR (recessive)
    out(1, 1);            // IDE (recessive: extended)
    out(f.id & 0x3FFFF, 18);
    out(rtr, 1);
    out(0, 2);  // r1, r0
  } else {
    out(f.id, 11);
    out(rtr, 1);
    out(0, 2);  // IDE (dominant: base format), r0
  }
  out(f.dlc, 4);
  for (const auto byte : f.payload()) out(byte, 8);
}

// A transmitter's stuffing: after kStuffRun equal bits one complementary bit, which itself starts
// the next run.
struct Stuffer {
  std::uint32_t stuffed = 0;
  unsigned run = 0;
  std::uint8_t last = 2;  // no bit yet
  void bit(std::uint8_t b) {
    run = b == last ? run + 1 : 1;
    last = b;
    if (run == kStuffRun) {  // the complement goes out next and starts a run of its own
      ++stuffed;
      last = static_cast<std::uint8_t>(b ^ 1);
      run = 1;
    }
  }
};
}  // namespace

BitStream crc_region(const Frame& f) {
  BitStream s;
  region_fields(f, [&s](std::uint32_t value, unsigned width) { s.push(value, width); });
  return s;
}

BitStream stuffed_region(const Frame& f) {
  BitStream s = crc_region(f);
  s.push(crc15(s.view()), 15);
  return s;
}

std::uint32_t stuff_bits(std::span<const std::uint8_t> bits) {
  Stuffer st;
  for (const auto b : bits) st.bit(b);
  return st.stuffed;
}

namespace {
// The CRC-15 of up to four bytes at once and the stuffing a byte at a time, for
// frame_bits_exact(), computed bit by bit once. The register is linear and starts at 0:
// crc[k][b] is byte b followed by 8·k zero bits through a zero register, so four bytes w0..w3
// after a register r give crc[3][x0] ^ crc[2][x1] ^ crc[1][x2] ^ crc[0][x3] for the bytes x of
// (w0..w3) ^ r << 17 (the register's 15 bits meet the first 15 message bits).
// The stuffing has 8 states (last bit, run 1..4), numbered last · 4 + run − 1; what some bits do
// from a state is one byte, the next state times 8 (bits 0..5) and the stuff bits (bits 6..7, at
// most 2). `step`: per byte of the stream one 64-bit word whose byte k is what that byte does from
// state k: the next state is a shift and a mask of a word loaded without waiting for the state
// (the state only picks the byte), so the chain from byte to byte is two instructions, not a
// load (docs/can-bus.md "Performance"). `part`: per state what fewer than 8 bits do, the k bits
// written as (1 << k) | bits (the bits before the first whole byte and after the last).
struct ByteTables {
  static constexpr unsigned kStates = 2 * (kStuffRun - 1);
  std::array<std::array<std::uint16_t, 256>, 4> crc{};
  std::array<std::uint64_t, 256> step{};
  std::array<std::array<std::uint8_t, 256>, kStates> part{};
  static unsigned state(const Stuffer& st) { return st.last * (kStuffRun - 1) + st.run - 1; }
  static std::uint8_t effect(const Stuffer& st) {
    return static_cast<std::uint8_t>(8 * state(st) | st.stuffed << 6);
  }
  ByteTables() {
    for (unsigned i = 0; i < 256; ++i) {
      std::uint16_t c = 0;
      for (unsigned k = 8; k-- > 0;) c = crc15_step(c, static_cast<std::uint8_t>((i >> k) & 1u));
      for (auto& table : crc) {
        table[i] = c;
        for (unsigned k = 0; k < 8; ++k) c = crc15_step(c, 0);
      }
    }
    for (std::uint8_t last = 0; last < 2; ++last)
      for (unsigned run = 1; run < kStuffRun; ++run) {
        const unsigned from = state(Stuffer{0, run, last});
        for (unsigned byte = 0; byte < 256; ++byte) {
          Stuffer st{0, run, last};
          for (unsigned i = 8; i-- > 0;) st.bit(static_cast<std::uint8_t>((byte >> i) & 1u));
          step[byte] |= std::uint64_t{effect(st)} << (8 * from);
        }
        for (unsigned k = 0; k < 8; ++k)
          for (unsigned bits = 0; bits < (1u << k); ++bits) {
            Stuffer st{0, run, last};
            for (unsigned i = k; i-- > 0;) st.bit(static_cast<std::uint8_t>((bits >> i) & 1u));
            part[from][(1u << k) | bits] = effect(st);
          }
      }
  }
};
}  // namespace

// What stuffed_region() and stuff_bits() give, without the stream and without a loop over its
// bits (a bus in time asks it for every frame: docs/can-bus.md "Performance"). SOF and the fields
// after it, padded in front with zeros to whole bytes (3 bytes 11-bit, 5 bytes 29-bit), then the
// data: the CRC register starts at 0, so the zeros in front change nothing and the region goes
// through the CRC four bytes at a time. The stuffing starts after SOF (last bit dominant, a run
// of one): the header's bits in SOF's byte (2 of 11-bit, 6 of 29-bit) through `part`, the
// region's other bytes and the CRC's first 8 bits through `step`, its last 7 bits through `part`.
std::uint32_t frame_bits_exact(const Frame& f) {
  static const ByteTables tables;
  const std::uint64_t rtr = f.remote ? 1 : 0, dlc = f.dlc & 0xFu;
  // After SOF: 11-bit: ID (11), RTR, IDE (dominant), r0, DLC (4); 29-bit: base ID (11), SRR and
  // IDE (recessive), extended ID (18), RTR, r1, r0, DLC (4). As region_fields() sends them.
  const bool ext = f.extended;
  const unsigned header_bits = ext ? 38 : 18;
  const std::uint64_t header = ext ? std::uint64_t{(f.id >> 18) & 0x7FFu} << 27 |
                                         std::uint64_t{3} << 25 |
                                         std::uint64_t{f.id & 0x3FFFFu} << 7 | rtr << 6 | dlc
                                   : std::uint64_t{f.id & 0x7FFu} << 7 | rtr << 6 | dlc;
  const auto data_bytes = static_cast<unsigned>(f.payload().size());
  // The region as two big-endian words: the header in front (zeros before it), then all 8 data
  // bytes (only the payload's are read: the loops stop at region_bytes). Two stores that do not
  // overlap, so that the loads below take their bytes from one store each.
  std::array<std::uint8_t, 16> region;  // at most 5 + 8 bytes
  const unsigned header_bytes = ext ? 5 : 3;
  std::uint64_t data_be;
  std::memcpy(&data_be, f.data.data(), 8);
  auto big_endian = [](std::uint64_t v) {
    return std::endian::native == std::endian::little ? __builtin_bswap64(v) : v;
  };
  data_be = big_endian(data_be);  // data[0] in the top byte
  const std::uint64_t w0 = header << (64 - 8 * header_bytes) | data_be >> (8 * header_bytes);
  const std::uint64_t w1 = data_be << (64 - 8 * header_bytes);
  const std::uint64_t w0_bytes = big_endian(w0), w1_bytes = big_endian(w1);
  std::memcpy(region.data(), &w0_bytes, 8);
  std::memcpy(region.data() + 8, &w1_bytes, 8);
  const unsigned region_bytes = header_bytes + data_bytes;
  std::uint32_t crc = 0;
  unsigned i = 0;
  for (; i + 4 <= region_bytes; i += 4) {
    std::uint32_t word;
    std::memcpy(&word, region.data() + i, 4);
    if constexpr (std::endian::native == std::endian::little) word = __builtin_bswap32(word);
    const std::uint32_t x = word ^ crc << 17;
    crc = tables.crc[3][x >> 24] ^ tables.crc[2][(x >> 16) & 0xFF] ^
          tables.crc[1][(x >> 8) & 0xFF] ^ tables.crc[0][x & 0xFF];
  }
  for (; i < region_bytes; ++i)
    crc = ((crc << 8) ^ tables.crc[0][((crc >> 7) ^ region[i]) & 0xFF]) & 0x7FFF;

  // `at`: 8 × the stuffing state; after SOF, state 0 (last bit dominant, a run of one).
  const unsigned lead = header_bits % 8;  // the header's bits in SOF's byte
  unsigned n = tables.part[0][(1u << lead) | (region[0] & ((1u << lead) - 1))];
  std::uint32_t stuffed = n >> 6;
  unsigned at = n & 0x3Fu;
  for (unsigned k = 1; k < region_bytes; ++k) {
    n = static_cast<unsigned>(tables.step[region[k]] >> at) & 0xFFu;
    stuffed += n >> 6;
    at = n & 0x3Fu;
  }
  n = static_cast<unsigned>(tables.step[crc >> 7] >> at) & 0xFFu;
  stuffed += n >> 6;
  at = n & 0x3Fu;
  stuffed += tables.part[at / 8][(1u << 7) | (crc & 0x7Fu)] >> 6;
  return 1 + header_bits + 8 * data_bytes + 15 + stuffed + kTrailerBits;
}

std::uint32_t frame_bits_longest(const Frame& f) {
  if (f.payload().empty()) return frame_bits_exact(f);
  const BitStream s = crc_region(f);
  const std::size_t free_bits = f.payload().size() * 8 + 15;  // data and CRC, chosen freely
  const std::span<const std::uint8_t> header = s.view().first(s.size - f.payload().size() * 8);
  // The stuffing state after the header: the last bit, the length of its run, the stuff bits.
  Stuffer st;
  for (const auto b : header) st.bit(b);
  // The most stuff bits the free bits can add from each state (last bit, run 1..4): a dynamic
  // programme over the run state, one step per free bit; -1 = state not reachable.
  using States = std::array<std::array<int, kStuffRun>, 2>;
  States most{};
  for (auto& by_run : most) by_run.fill(-1);
  most[st.last][st.run] = 0;
  for (std::size_t i = 0; i < free_bits; ++i) {
    States next{};
    for (auto& by_run : next) by_run.fill(-1);
    for (unsigned l = 0; l < 2; ++l)
      for (unsigned r = 1; r < kStuffRun; ++r) {
        if (most[l][r] < 0) continue;
        for (unsigned b = 0; b < 2; ++b) {
          unsigned nl = b, nr = b == l ? r + 1 : 1;
          int gain = 0;
          if (nr == kStuffRun) {  // a stuff bit: its complement starts the next run
            nl = b ^ 1u;
            nr = 1;
            gain = 1;
          }
          next[nl][nr] = std::max(next[nl][nr], most[l][r] + gain);
        }
      }
    most = next;
  }
  int best = 0;
  for (const auto& by_run : most)
    for (const int v : by_run) best = std::max(best, v);
  return static_cast<std::uint32_t>(s.size + 15) + st.stuffed + static_cast<std::uint32_t>(best) +
         kTrailerBits;
}

std::uint32_t frame_bits_unstuffed(bool extended, bool remote, std::uint8_t dlc) {
  return (extended ? 54u : 34u) + (remote ? 0u : 8u * dlc) + kTrailerBits;
}

std::uint32_t frame_bits_worst(bool extended, bool remote, std::uint8_t dlc) {
  const std::uint32_t stuffed = frame_bits_unstuffed(extended, remote, dlc) - kTrailerBits;
  return stuffed + kTrailerBits + (stuffed - 1) / 4;
}

std::chrono::nanoseconds bits_duration(std::uint64_t bits, std::uint32_t bitrate) {
  return std::chrono::nanoseconds(bitrate == 0 ? 0 : bits * 1'000'000'000ull / bitrate);
}

}  // namespace candp2::can

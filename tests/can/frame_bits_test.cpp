// A classic CAN frame on the wire (can/frame_bits.hpp, docs/can-bus.md "Frames on the wire"):
// hand-worked frames. Each comment writes the stream SOF..CRC as sent, 0 dominant, 1 recessive,
// fields separated by '|': SOF | identifier | RTR IDE r0 (29-bit: base ID | SRR IDE | extended ID |
// RTR r1 r0) | DLC | data | CRC-15. Below it the same bits in runs, each stuff bit in brackets
// after five equal bits (a stuff bit starts the next run: "[1]0000" is a run of five again).
#include "can/frame_bits.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string_view>
#include <vector>

namespace candp2::can {
namespace {

std::string stream_text(const BitStream& s) {
  std::string t;
  for (const auto b : s.view()) t += static_cast<char>('0' + b);
  return t;
}

const std::array<std::uint8_t, 8> kCounting = {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88};
const std::array<std::uint8_t, 8> kOnes = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};
const std::array<std::uint8_t, 8> kZeros{};

// CRC-15/CAN as catalogued (width 15, poly 0x4599, init 0, no reflection, xorout 0): check value
// over the ASCII bytes "123456789".
TEST(Crc15, CatalogueCheckValue) {
  constexpr std::string_view check = "123456789";
  const std::array<std::uint8_t, 9> bytes = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  static_assert(check.size() == bytes.size());
  EXPECT_EQ(crc15_bytes(bytes), 0x059E);
  // The bitwise form over the same bits agrees.
  BitStream s;
  for (const auto b : bytes) s.push(b, 8);
  EXPECT_EQ(crc15(s.view()), 0x059E);
  EXPECT_EQ(crc15_bytes({}), 0);
}

// 000# (11-bit 0x000, DLC 0): every bit SOF..DLC is dominant, so the CRC is 0 too.
//   0 | 00000000000 | 000 | 0000 | 000000000000000          34 bits, all 0
//   00000[1]00000[1]00000[1]00000[1]00000[1]00000[1]0000    34 = 6·5 + 4: 6 stuff bits
//   34 + 6 + 13 (CRC del, ACK, ACK del, EOF 7, intermission 3) = 53
TEST(FrameBits, StandardId0Dlc0) {
  const auto f = Frame::std_data(0x000, {});
  EXPECT_EQ(crc15(crc_region(f).view()), 0x0000);
  EXPECT_EQ(stuff_bits(stuffed_region(f).view()), 6u);
  EXPECT_EQ(frame_bits_exact(f), 53u);
}

// 080# (the CANopen SYNC, 11-bit, DLC 0): CRC 0x1C05 = 001110000000101.
//   0 | 00010000000 | 000 | 0000 | 001110000000101
//   0000 1 00000[1] 00000[1] 00000[1] 0 111 00000[1] 00101      4 stuff bits
//   (the ID's seven zeros, RTR IDE r0, DLC and the CRC's "00": 16 zeros = 3·5 + 1; then
//   the CRC's seven zeros: 1)
//   34 + 4 + 13 = 51
TEST(FrameBits, Sync080Dlc0) {
  const auto f = Frame::std_data(0x080, {});
  EXPECT_EQ(stream_text(crc_region(f)), "0000100000000000000");
  EXPECT_EQ(crc15(crc_region(f).view()), 0x1C05);
  EXPECT_EQ(stuff_bits(stuffed_region(f).view()), 4u);
  EXPECT_EQ(frame_bits_exact(f), 51u);
}

// 123#1122334455667788 (11-bit, DLC 8): CRC 0x4237 = 100001000110111.
//   0 | 00100100011 | 000 | 1000 | 00010001 00100010 00110011 01000100 01010101 01100110
//   01110111 10001000 | 100001000110111
//   the DLC's "000" and the first byte's "00" are five zeros: "1 00000[1]010001 ..."; nothing
//   else repeats five times (0x55 alternates, 0x88 = 10001000, the CRC's "1 0000 1" has four
//   zeros). 1 stuff bit.
//   98 + 1 + 13 = 112
TEST(FrameBits, StandardDlc8Counting) {
  const auto f = Frame::std_data(0x123, kCounting);
  EXPECT_EQ(crc15(crc_region(f).view()), 0x4237);
  EXPECT_EQ(stuffed_region(f).size, 98u);
  EXPECT_EQ(stuff_bits(stuffed_region(f).view()), 1u);
  EXPECT_EQ(frame_bits_exact(f), 112u);
}

// 7FF#FFFFFFFFFFFFFFFF (11-bit, DLC 8, all ones): CRC 0x4C89 = 100110010001001.
//   0 | 11111111111 | 000 | 1000 | 64 × 1 | 100110010001001
//   the ID's 11 ones: "0 11111[0]11111[0]1" (2); "000 1000" (none); then 64 data ones and the
//   CRC's leading 1, 65 ones = 13·5: "11111[0]" thirteen times (13); the CRC's rest
//   "00110010001001" follows the last [0] with "00": three zeros (none).
//   2 + 13 = 15 stuff bits; 98 + 15 + 13 = 126
TEST(FrameBits, StandardDlc8AllOnes) {
  const auto f = Frame::std_data(0x7FF, kOnes);
  EXPECT_EQ(crc15(crc_region(f).view()), 0x4C89);
  EXPECT_EQ(stuff_bits(stuffed_region(f).view()), 15u);
  EXPECT_EQ(frame_bits_exact(f), 126u);
}

// 123#R4 (11-bit remote, DLC 4): a remote frame carries no data whatever its DLC.
//   0 | 00100100011 | 100 | 0100 | 100001101010010     CRC 0x4352
//   longest runs: "0001" "1 00" "0 1" "0000 11": at most four equal bits: no stuff bit.
//   34 + 0 + 13 = 47
TEST(FrameBits, StandardRemoteDlc4) {
  const auto f = Frame::rtr(0x123, false, 4);
  EXPECT_EQ(stream_text(crc_region(f)), "0001001000111000100");
  EXPECT_EQ(crc15(crc_region(f).view()), 0x4352);
  EXPECT_EQ(stuff_bits(stuffed_region(f).view()), 0u);
  EXPECT_EQ(frame_bits_exact(f), 47u);
}

// 12345678# (29-bit, DLC 0): base ID 0x12345678 >> 18 = 0x48D = 10010001101, extended ID
// 0x12345678 & 0x3FFFF = 0x05678 = 000101011001111000; CRC 0x6C97 = 110110010010111.
//   0 | 10010001101 | 11 | 000101011001111000 | 000 | 0000 | 110110010010111
//   the extended ID's last "000", RTR r1 r0 and the DLC are ten zeros: "00000[1]00000[1]" (2)
//   (the runs elsewhere are at most four).  54 + 2 + 13 = 69
TEST(FrameBits, ExtendedDlc0) {
  const auto f = Frame::ext_data(0x12345678, {});
  EXPECT_EQ(stream_text(crc_region(f)), "010010001101110001010110011110000000000");
  EXPECT_EQ(crc15(crc_region(f).view()), 0x6C97);
  EXPECT_EQ(stuff_bits(stuffed_region(f).view()), 2u);
  EXPECT_EQ(frame_bits_exact(f), 69u);
}

// 1FFFFFFF#R8 (29-bit remote, DLC 8): base ID, SRR, IDE, extended ID and RTR are 11 + 2 + 18 + 1
// = 32 ones after SOF; CRC 0x1B4A = 001101101001010.
//   0 | 11111111111 | 11 | 111111111111111111 | 100 | 1000 | 001101101001010
//   0 11111[0] 11111[0] 11111[0] 11111[0] 11111[0] 11111[0] 11 00 1 00000[1] 1101101001010
//   32 ones = 6·5 + 2: 6 stuff bits; then r1 r0 "00", the DLC "1000" whose three zeros and the
//   CRC's leading "00" are five zeros: 1 more.
//   54 + 7 + 13 = 74
TEST(FrameBits, ExtendedRemoteDlc8) {
  const auto f = Frame::rtr(0x1FFFFFFF, true, 8);
  EXPECT_EQ(crc15(crc_region(f).view()), 0x1B4A);
  EXPECT_EQ(stuff_bits(stuffed_region(f).view()), 7u);
  EXPECT_EQ(frame_bits_exact(f), 74u);
}

// 00000000#0000000000000000 (29-bit 0, DLC 8 zeros): CRC 0x3DAF = 011110110101111.
//   0 | 00000000000 | 11 | 000000000000000000 | 000 | 1000 | 64 × 0 | 011110110101111
//   SOF and base ID, 12 zeros: "00000[1]00000[1]00" (2); SRR IDE "11"; the extended ID and
//   RTR r1 r0, 21 zeros: "00000[1]" four times and "0" (4); the DLC's "1"; its "000", 64 data
//   zeros and the CRC's leading "0", 68 zeros = 13·5 + 3 (13); the CRC's rest "11110110101111"
//   has no run of five. 2 + 4 + 13 = 19 stuff bits; 118 + 19 + 13 = 150
TEST(FrameBits, ExtendedDlc8Zeros) {
  const auto f = Frame::ext_data(0x00000000, kZeros);
  EXPECT_EQ(stuffed_region(f).size, 118u);
  EXPECT_EQ(crc15(crc_region(f).view()), 0x3DAF);
  EXPECT_EQ(stuff_bits(stuffed_region(f).view()), 19u);
  EXPECT_EQ(frame_bits_exact(f), 150u);
}

// The rule in isolation: a stuff bit counts in the next run, and one follows a last complete run.
TEST(StuffBits, StuffBitStartsTheNextRun) {
  const std::array<std::uint8_t, 9> a = {0, 0, 0, 0, 0, 1, 1, 1, 1};  // 00000[1]1111: 1 + 1
  EXPECT_EQ(stuff_bits(a), 2u);  // [1] + "1111" is five ones: a second stuff bit after them
  const std::array<std::uint8_t, 4> b = {1, 1, 1, 1};
  EXPECT_EQ(stuff_bits(b), 0u);
  const std::array<std::uint8_t, 5> c = {1, 1, 1, 1, 1};
  EXPECT_EQ(stuff_bits(c), 1u);  // a run that ends the region is still stuffed
}

// Davis, Burns, Bril, Lukkien 2007 eq. 1; the bound holds for every frame above.
TEST(FrameBits, WorstCase) {
  EXPECT_EQ(frame_bits_worst(false, false, 0), 34u + 13u + 8u);                  // 55
  EXPECT_EQ(frame_bits_worst(false, false, 8), 98u + 13u + 24u);                 // 135
  EXPECT_EQ(frame_bits_worst(true, false, 8), 118u + 13u + 29u);                 // 160
  EXPECT_EQ(frame_bits_worst(true, true, 8), frame_bits_worst(true, false, 0));  // no data
  for (const auto& f : {Frame::std_data(0x000, {}), Frame::std_data(0x7FF, kOnes),
                        Frame::ext_data(0x00000000, kZeros), Frame::rtr(0x1FFFFFFF, true, 8)})
    EXPECT_LE(frame_bits_exact(f), frame_bits_worst(f)) << format_candump(f);
}

// frame_bits_longest: the longest exact length a frame's identifier, kind and DLC allow, whatever
// the data. Against every data value of DLC 1 and 2 (all 256 and 65 536): never below the longest
// real frame, at most 2 bits above it (the CRC, which the bound lets free, follows from the data).
TEST(FrameBits, LongestOverAllData) {
  for (const std::uint32_t id : {0x000u, 0x123u, 0x555u, 0x7FFu})
    for (const std::uint8_t dlc : {1, 2}) {
      std::uint32_t longest_real = 0;
      std::vector<std::uint8_t> data(dlc);
      for (std::uint32_t v = 0; v < (1u << (8 * dlc)); ++v) {
        for (std::size_t i = 0; i < dlc; ++i) data[i] = static_cast<std::uint8_t>(v >> (8 * i));
        longest_real = std::max(longest_real, frame_bits_exact(Frame::std_data(id, data)));
      }
      const auto bound = frame_bits_longest(Frame::std_data(id, data));
      EXPECT_GE(bound, longest_real) << std::hex << id << " DLC " << int{dlc};
      EXPECT_LE(bound, longest_real + 2) << std::hex << id << " DLC " << int{dlc};
    }
  // Worked with a dynamic programme over the data and CRC bits (the real CRC): 0x123 DLC 1 reaches
  // 60 bits, the bound says 61; 0x000 DLC 1 reaches 61, the bound 63; 0x101 DLC 8 reaches 131,
  // the bound 132 (Davis et al.'s formula: 65 and 135).
  EXPECT_EQ(frame_bits_longest(Frame::std_data(0x123, std::vector<std::uint8_t>{0})), 61u);
  EXPECT_EQ(frame_bits_longest(Frame::std_data(0x000, std::vector<std::uint8_t>{0})), 63u);
  EXPECT_EQ(frame_bits_longest(Frame::std_data(0x101, kZeros)), 132u);
}

// Without data bits the data is known: the exact length. Any frame: exact <= longest <= worst.
TEST(FrameBits, LongestBetweenExactAndWorst) {
  for (const auto& f : {Frame::std_data(0x080, {}), Frame::rtr(0x123, false, 4),
                        Frame::rtr(0x1FFFFFFF, true, 8), Frame::ext_data(0x12345678, {})})
    EXPECT_EQ(frame_bits_longest(f), frame_bits_exact(f)) << format_candump(f);
  std::mt19937 rng(36);
  for (int i = 0; i < 20000; ++i) {
    const bool ext = rng() % 2 != 0;
    const auto id = static_cast<std::uint32_t>(rng() & (ext ? 0x1FFFFFFFu : 0x7FFu));
    std::vector<std::uint8_t> data(rng() % 9);
    for (auto& b : data) b = static_cast<std::uint8_t>(rng());
    const Frame f = ext ? Frame::ext_data(id, data) : Frame::std_data(id, data);
    EXPECT_LE(frame_bits_exact(f), frame_bits_longest(f)) << format_candump(f);
    EXPECT_LE(frame_bits_longest(f), frame_bits_worst(f)) << format_candump(f);
  }
}

// frame_bits_exact() counts in one pass without building the stream (docs/can-bus.md
// "Performance"): the same as the stream with its CRC, stuffed, and the trailer.
TEST(FrameBits, ExactIsTheStuffedStream) {
  std::mt19937 rng(361);
  for (int i = 0; i < 20000; ++i) {
    const bool ext = rng() % 2 != 0;
    const auto id = static_cast<std::uint32_t>(rng() & (ext ? 0x1FFFFFFFu : 0x7FFu));
    std::vector<std::uint8_t> data(rng() % 9);
    for (auto& b : data) b = static_cast<std::uint8_t>(rng() % 3 == 0 ? 0 : rng());
    const Frame f = rng() % 5 == 0 ? Frame::rtr(id, ext, static_cast<std::uint8_t>(data.size()))
                    : ext          ? Frame::ext_data(id, data)
                                   : Frame::std_data(id, data);
    const BitStream s = stuffed_region(f);
    EXPECT_EQ(frame_bits_exact(f), s.size + stuff_bits(s.view()) + kTrailerBits)
        << format_candump(f);
  }
}

// The same with data bytes that make long runs across the byte and field boundaries (the stuff
// bits a byte-wise count must carry from one byte to the next, docs/can-bus.md "Performance").
TEST(FrameBits, ExactIsTheStuffedStreamWithRuns) {
  constexpr std::uint8_t kRuns[] = {0x00, 0xFF, 0x0F, 0xF0, 0x07, 0xE0, 0x1F, 0xF8, 0x83, 0x7C};
  std::mt19937 rng(362);
  for (int i = 0; i < 20000; ++i) {
    const bool ext = rng() % 2 != 0;
    const auto id =
        static_cast<std::uint32_t>(rng() % 4 == 0 ? (ext ? 0x1FFFFFFFu : 0x7FFu) * (rng() % 2)
                                                  : rng() & (ext ? 0x1FFFFFFFu : 0x7FFu));
    std::vector<std::uint8_t> data(rng() % 9);
    for (auto& b : data) b = kRuns[rng() % std::size(kRuns)];
    const auto dlc = static_cast<std::uint8_t>(data.size());
    const Frame f = rng() % 7 == 0 ? Frame::rtr(id, ext, dlc) : Frame::data_frame(id, ext, data);
    const BitStream stream = stuffed_region(f);
    const std::uint32_t bit_by_bit =
        static_cast<std::uint32_t>(stream.size) + stuff_bits(stream.view()) + kTrailerBits;
    EXPECT_EQ(frame_bits_exact(f), bit_by_bit) << format_candump(f);
  }
}

TEST(FrameBits, Duration) {
  EXPECT_EQ(frame_duration(Frame::std_data(0x000, {}), 1'000'000), std::chrono::microseconds(53));
  EXPECT_EQ(bits_duration(53, 125'000), std::chrono::nanoseconds(424'000));
  EXPECT_EQ(bits_duration(1, 800'000), std::chrono::nanoseconds(1250));
}

// Smaller key wins: lower identifier; at equal base ID the 11-bit frame (RTR or dominant IDE
// against the 29-bit frame's recessive SRR/IDE); data before remote of the same identifier.
TEST(Arbitration, Order) {
  EXPECT_LT(arbitration_key({0x100, false}, false), arbitration_key({0x101, false}, false));
  EXPECT_LT(arbitration_key({0x100, false}, false), arbitration_key({0x100, false}, true));
  EXPECT_LT(arbitration_key({0x100, false}, true), arbitration_key({0x100u << 18, true}, false));
  EXPECT_LT(arbitration_key({0x100u << 18, true}, false), arbitration_key({0x101, false}, false));
  EXPECT_LT(arbitration_key({0x0400000, true}, false), arbitration_key({0x0400000, true}, true));
}

// The key's inverse gives back the identifier and kind it was made of (identifiers() shows them,
// docs/can-bus.md "Seen from outside").
TEST(Arbitration, FieldIsTheKeysInverse) {
  for (const Ident id : {Ident{0x000, false}, Ident{0x7FF, false}, Ident{0x123, false},
                         Ident{0x00000000, true}, Ident{0x1FFFFFFF, true}, Ident{0x12345678, true}})
    for (const bool remote : {false, true}) {
      const ArbitrationField f = arbitration_field(arbitration_key(id, remote));
      EXPECT_EQ(f.id, id);
      EXPECT_EQ(f.remote, remote);
    }
}

}  // namespace
}  // namespace candp2::can

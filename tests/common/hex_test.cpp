// Hex bytes as text (common/hex.hpp): the writer, and the one reader in its three forms, with the
// exact messages the configuration, the slot comment fields and replay scenarios show.
#include "common/hex.hpp"

#include <gtest/gtest.h>

namespace candp2 {
namespace {

std::string read(std::string_view text, HexForm form, bool allow_empty = false) {
  std::string error;
  const auto r = parse_hex_bytes(text, form, &error, allow_empty);
  if (!r) return "error: " + error;
  std::string out = hex_bytes(r->bytes);
  for (std::size_t i = 0; i < r->care.size(); ++i)
    if (!r->care[i]) out.replace(3 * i, 2, "??");
  return out;
}

TEST(HexBytes, WritesUpperCaseWithSeparator) {
  const std::uint8_t b[] = {0x02, 0x89, 0xB8};
  EXPECT_EQ(hex_bytes(b), "02 89 B8");
  EXPECT_EQ(hex_bytes(b, ','), "02,89,B8");
  EXPECT_EQ(hex_bytes(b, 0), "0289B8");
  EXPECT_EQ(hex_bytes({}), "");
}

TEST(HexBytes, OneByteWithItsPrefix) {
  EXPECT_EQ(hex8(0x0F), "0x0F");
  EXPECT_EQ(hex8(0xAB), "0xAB");
  EXPECT_EQ(hex8(0x1FF), "0xFF");  // the low 8 bits
}

// A CAN identifier in candump or socketcand notation, an error class: 1 to 8 hex digits.
TEST(HexBytes, NumberOfUpToEightDigits) {
  EXPECT_EQ(parse_hex_u32("181"), 0x181u);
  EXPECT_EQ(parse_hex_u32("1fffffff"), 0x1FFFFFFFu);
  EXPECT_EQ(parse_hex_u32("FFFFFFFF"), 0xFFFFFFFFu);
  std::size_t bad = 99;
  EXPECT_FALSE(parse_hex_u32("", &bad));
  EXPECT_EQ(bad, 0u);
  EXPECT_FALSE(parse_hex_u32("123456789", &bad));  // nine digits
  EXPECT_EQ(bad, 0u);
  EXPECT_FALSE(parse_hex_u32("12G", &bad));
  EXPECT_EQ(bad, 2u);
  EXPECT_FALSE(parse_hex_u32("0x1"));
  EXPECT_FALSE(parse_hex_u32("-1"));
}

TEST(HexBytes, Digits) {
  EXPECT_EQ(hex_digit('0'), 0);
  EXPECT_EQ(hex_digit('9'), 9);
  EXPECT_EQ(hex_digit('a'), 10);
  EXPECT_EQ(hex_digit('F'), 15);
  EXPECT_EQ(hex_digit('g'), -1);
  EXPECT_EQ(hex_digit('?'), -1);
  EXPECT_EQ(hex_digit(' '), -1);
}

TEST(HexBytes, SeparatedIsOneByteBetweenSeparators) {
  EXPECT_EQ(read("02,89,B8", HexForm::Separated), "02 89 B8");
  EXPECT_EQ(read("FF EF 00\t00 00", HexForm::Separated), "FF EF 00 00 00");
  EXPECT_EQ(read("03,09,b8,", HexForm::Separated), "03 09 B8");
  EXPECT_EQ(read("", HexForm::Separated, true), "");
  EXPECT_EQ(read(" , ", HexForm::Separated), "error: no bytes given");
  EXPECT_EQ(read("02,8G", HexForm::Separated), "error: position 4: 'G' is not a hex digit");
  EXPECT_EQ(read("2,89", HexForm::Separated),
            "error: position 0: '2' is not one byte (write two hex digits per byte, e.g. "
            "02,89,B8)");
  EXPECT_EQ(read("0289", HexForm::Separated),
            "error: position 0: '0289' is not one byte (write two hex digits per byte, e.g. "
            "02,89,B8)");
  // Every character of the token is checked before its length.
  EXPECT_EQ(read("0x12", HexForm::Separated), "error: position 1: 'x' is not a hex digit");
}

TEST(HexBytes, RunsAreTwoDigitsPerByte) {
  EXPECT_EQ(read("88 80,c4", HexForm::Runs), "88 80 C4");
  EXPECT_EQ(read("8880C4", HexForm::Runs), "88 80 C4");
  EXPECT_EQ(read("8880 C4", HexForm::Runs), "88 80 C4");
  EXPECT_EQ(read("", HexForm::Runs), "error: no bytes given");
  EXPECT_EQ(read("", HexForm::Runs, true), "");
  EXPECT_EQ(read("888", HexForm::Runs),
            "error: position 0: '888' has an odd number of hex digits (write two digits per "
            "byte)");
  EXPECT_EQ(read("88 G0", HexForm::Runs), "error: position 3: 'G' is not a hex digit");
  // A run ends at the first character that is not a digit; the run's length is checked first.
  EXPECT_EQ(read("0x12", HexForm::Runs),
            "error: position 0: '0' has an odd number of hex digits (write two digits per byte)");
  EXPECT_EQ(read("00x12", HexForm::Runs), "error: position 2: 'x' is not a hex digit");
}

TEST(HexBytes, PatternsTakeWildcards) {
  EXPECT_EQ(read("00 33 ?? 00", HexForm::Patterns), "00 33 ?? 00");
  EXPECT_EQ(read("0033??00", HexForm::Patterns), "00 33 ?? 00");
  EXPECT_EQ(read("??,ab", HexForm::Patterns), "?? AB");
  EXPECT_EQ(read("", HexForm::Patterns), "error: no bytes given");
  EXPECT_EQ(read("003", HexForm::Patterns),
            "error: position 2: expected two hex digits or ?? per byte, e.g. \"00 33 ?? 00\"");
  EXPECT_EQ(read("00 ?3", HexForm::Patterns),
            "error: position 3: expected two hex digits or ?? per byte, e.g. \"00 33 ?? 00\"");
  // Outside the pattern form "??" is no byte.
  EXPECT_EQ(read("??", HexForm::Runs), "error: position 0: '?' is not a hex digit");
  EXPECT_EQ(read("??", HexForm::Separated), "error: position 0: '?' is not a hex digit");
}

TEST(HexBytes, ErrorIsOptional) {
  EXPECT_FALSE(parse_hex_bytes("zz", HexForm::Runs, nullptr));
  EXPECT_TRUE(parse_hex_bytes("12", HexForm::Runs, nullptr));
}

}  // namespace
}  // namespace candp2

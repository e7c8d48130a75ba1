// Configuration (Chk_Cfg identifier) bytes: general and special format decoding, and the
// CAN-DP/2 meaning of the comment bytes (manual §5.2, §5.3.2, §7; emulator-spec §2).
#include "gsd/cfg.hpp"

#include <gtest/gtest.h>

namespace candp2::gsd {
namespace {

CfgDecode dec(std::initializer_list<std::uint8_t> b) {
  const std::vector<std::uint8_t> v(b);
  return decode_config(v);
}

TEST(GsdCfg, GeneralFormat) {
  const CfgDecode d = dec({0x10, 0x2F, 0xD1, 0x30});
  ASSERT_FALSE(d.error);
  ASSERT_EQ(d.entries.size(), 4u);
  EXPECT_EQ(describe(d.entries[0]), "input 1 byte");
  EXPECT_EQ(describe(d.entries[1]), "output 16 bytes");
  EXPECT_EQ(describe(d.entries[2]), "input 4 bytes (2 words) consistent");
  EXPECT_EQ(describe(d.entries[3]), "output 1 byte, input 1 byte");
  EXPECT_EQ(d.input_len, 6u);
  EXPECT_EQ(d.output_len, 17u);
}

TEST(GsdCfg, SpecialFormat) {
  // SI1180fd.gse: 0xC0 -> output length byte, then input length byte, no manufacturer bytes.
  CfgDecode d = dec({0xC0, 0x83, 0x89});
  ASSERT_FALSE(d.error);
  ASSERT_EQ(d.entries.size(), 1u);
  EXPECT_EQ(describe(d.entries[0]), "output 4 bytes consistent, input 10 bytes consistent");
  // SIEM8031.GSE: 0x04 -> no data, 4 manufacturer bytes.
  d = dec({0x04, 0x00, 0x00, 0xAD, 0xC0, 0x10});
  ASSERT_FALSE(d.error);
  ASSERT_EQ(d.entries.size(), 2u);
  EXPECT_EQ(describe(d.entries[0]), "no data (empty slot), manufacturer bytes 00 00 AD C0");
  EXPECT_EQ(d.entries[1].offset, 5u);
  // manual §7: 0x83 = output, 3 manufacturer bytes; 0x05 = 6 bytes.
  d = dec({0x83, 0x05, 0x02, 0x03, 0x00});
  ASSERT_EQ(d.entries.size(), 1u);
  EXPECT_EQ(describe(d.entries[0]), "output 6 bytes, manufacturer bytes 02 03 00");
  EXPECT_EQ(d.entries[0].size, 5u);
}

TEST(GsdCfg, TruncatedOrReservedIsAnErrorNotACrash) {
  EXPECT_EQ(*dec({0x10, 0x83, 0x05, 0x02}).error,
            "byte 1 (0x83): special format needs 1 length byte(s) and 3 manufacturer byte(s), "
            "only 2 follow");
  EXPECT_EQ(dec({0x10, 0x83, 0x05, 0x02}).entries.size(), 1u);
  EXPECT_TRUE(dec({0xC0, 0x83}).error);
  EXPECT_TRUE(dec({0x0F}).error);
  EXPECT_FALSE(dec({}).error);
}

struct SlotCase {
  std::vector<std::uint8_t> cfg;
  const char* text;
  const char* problem;  // "" = accepted
};

TEST(GsdCfg, CanDp2Meaning) {
  const SlotCase cases[] = {
      // manual §7 example
      {{0x83, 0x05, 0x02, 0x03, 0x00}, "Tx 11-bit ID 0x203, 6 bytes, form 0x00", ""},
      // manual §5.2.1: 11-bit 0x0309; cycle 1000 ms = 03 E8 (manual §5.2.3)
      {{0x85, 0x07, 0x03, 0x09, 0xB8, 0x03, 0xE8},
       "Tx 11-bit ID 0x309, 8 bytes, form 0xB8, cycle 1000 ms",
       ""},
      // manual §5.2.1: 29-bit 0x123456 as 20,12,34,56
      {{0x87, 0x03, 0x20, 0x12, 0x34, 0x56, 0x00, 0x00, 0x64},
       "Tx 29-bit ID 0x00123456, 4 bytes, form 0x00, cycle 100 ms",
       ""},
      {{0x45, 0x03, 0x20, 0x12, 0x34, 0x56, 0x8E},
       "Rx 29-bit ID 0x00123456, 4 bytes, form 0x8E",
       ""},
      {{0x45, 0x08, 0x01, 0x81, 0x00, 0x00, 0x10},
       "Rx 11-bit ID 0x181, 9 bytes, form 0x00 (cycle bytes ignored on an input)",
       ""},
      {{0x83, 0x00, 0x07, 0xF8, 0x00}, "Tx without CAN identifier (0x07F8 dummy), 1 byte", ""},
      // manual §5.3.2: Communication Window FF EF, SYNC time in comment bytes 4-5
      {{0x85, 0x8F, 0xFF, 0xEF, 0x00, 0x00, 0x64},
       "Communication Window write (output), form 0x00, SYNC time 100 ms",
       ""},
      {{0x85, 0x0F, 0xFF, 0xEF, 0x00, 0x00, 0x00},
       "Communication Window write (output), form 0x00, no SYNC time",
       "Cfg fault code 8"},
      {{0x43, 0x87, 0xFF, 0xEF, 0x00},
       "Communication Window read (input), form 0x00",
       "Cfg fault code 3"},
      // manual table 6.4.1: Page-Mode segment
      {{0x40, 0x9F}, "Page-Mode input segment, 32 bytes (valid only with Page-Mode on)", ""},
      {{0x40, 0x1F}, "Rx", "Cfg fault code 4"},
      {{0x20}, "not a CAN-DP/2 slot", "Cfg fault code 1: general identifier format"},
      {{0xC3, 0x00, 0x00, 0x01, 0x02, 0x00},
       "not a CAN-DP/2 slot",
       "Cfg fault code 1: input+output slot"},
      {{0x43, 0x41, 0x01, 0x02, 0x00}, "input", "Cfg fault code 2"},
      {{0x43, 0x09, 0x01, 0x02, 0x00},
       "Rx 11-bit ID 0x102, 10 bytes, form 0x00",
       "Cfg fault code 3"},
      {{0x41, 0x00, 0x01}, "Rx", "Cfg fault code 4: only one identifier byte"},
      {{0x42, 0x00, 0x01, 0x02}, "Rx", "Cfg fault code 5"},
      {{0x44, 0x00, 0x20, 0x01, 0x02, 0x03}, "Rx", "Cfg fault code 5"},
      {{0x46, 0x00, 1, 2, 3, 4, 5, 6}, "Rx", "Cfg fault code 6: 6 comment bytes"},
      {{0x43, 0x00, 0x08, 0x00, 0x00},
       "Rx 11-bit ID 0x800, 1 byte, form 0x00",
       "Cfg fault code 6: 11-bit identifier 0x800 > 0x7FF"},
  };
  for (const auto& c : cases) {
    const CfgDecode d = decode_config(c.cfg);
    ASSERT_FALSE(d.error) << *d.error;
    ASSERT_EQ(d.entries.size(), 1u);
    const CanDp2Slot s = describe_candp2(d.entries[0]);
    EXPECT_EQ(s.text, c.text);
    if (*c.problem == 0) {
      EXPECT_FALSE(s.problem) << *s.problem;
    } else {
      EXPECT_NE(s.problem.value_or("").find(c.problem), std::string::npos)
          << c.text << ": " << s.problem.value_or("(none)");
    }
  }
  EXPECT_TRUE(is_universal_module(std::vector<std::uint8_t>{0x00}));
  EXPECT_FALSE(is_universal_module(std::vector<std::uint8_t>{0x00, 0x00}));
}

}  // namespace
}  // namespace candp2::gsd

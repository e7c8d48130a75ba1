// Configuration (Chk_Cfg identifier) bytes: general and special format decoding, and the
// CAN-DP/2 meaning of the comment bytes (manual §5.2, §5.3.2, §7; docs/slots.md "Chk_Cfg slots").
#include "gsd/cfg.hpp"

#include <gtest/gtest.h>

#include "common/hex.hpp"
#include "gateway/cfg_reading.hpp"

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
  // tests/gsd/data/CP2DPV1.GSD: 0xC0 -> output length byte, then input length byte, no manufacturer
  // bytes.
  CfgDecode d = dec({0xC0, 0x83, 0x89});
  ASSERT_FALSE(d.error);
  ASSERT_EQ(d.entries.size(), 1u);
  EXPECT_EQ(describe(d.entries[0]), "output 4 bytes consistent, input 10 bytes consistent");
  // 0x04 -> no data, 4 manufacturer bytes (an empty slot as vendor files write it).
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

TEST(GsdCfg, TruncatedIsAnErrorNotACrash) {
  // The message is dp::decode_chk_cfg's, prefixed with the truncated entry's first byte.
  EXPECT_EQ(*dec({0x10, 0x83, 0x05, 0x02}).error,
            "byte 1 (0x83): Chk_Cfg truncated: manufacturer bytes missing");
  EXPECT_EQ(dec({0x10, 0x83, 0x05, 0x02}).entries.size(), 1u);
  EXPECT_EQ(*dec({0x20, 0xC0, 0x83}).error,
            "byte 1 (0xC0): Chk_Cfg truncated: length byte missing");
  EXPECT_TRUE(dec({0x0F}).error);  // 15 manufacturer bytes announced, none follow
  EXPECT_FALSE(dec({}).error);
  EXPECT_TRUE(dec({}).entries.empty());
}

TEST(GsdCfg, EntriesKeepTheirBytes) {
  const CfgDecode d = dec({0x20, 0x83, 0x05, 0x02, 0x03, 0x00, 0x40, 0x9F});
  ASSERT_FALSE(d.error);
  ASSERT_EQ(d.entries.size(), 3u);
  EXPECT_EQ(hex_bytes(d.entries[0].bytes), "20");
  EXPECT_EQ(hex_bytes(d.entries[1].bytes), "83 05 02 03 00");
  EXPECT_EQ(d.entries[1].offset, 1u);
  EXPECT_EQ(hex_bytes(d.entries[2].bytes), "40 9F");
  EXPECT_EQ(d.entries[2].offset, 6u);
  EXPECT_EQ(d.input_len, 32u);
  EXPECT_EQ(d.output_len, 7u);
}

struct SlotCase {
  std::vector<std::uint8_t> cfg;
  const char* text;
  const char* problem;  // "" = accepted
};

// The meaning comes from gw::decode_slots (manual §5.2, §5.3.2, §7, table 6.4.1;
// docs/slots.md "Chk_Cfg slots" codes), so these cases also pin that the GSD view and the gateway
// agree.
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
      // docs/slots.md "Chk_Cfg slots": cycle bytes on an input are ignored; 9 bytes only with the
      // Rx-Counter
      {{0x45, 0x08, 0x01, 0x81, 0x00, 0x00, 0x10},
       "Rx 11-bit ID 0x181, 9 bytes (8 data + Rx-Counter), form 0x00, cycle 16 ms ignored on an "
       "input (valid only with Rx-Counter on)",
       ""},
      {{0x45, 0x07, 0x01, 0x81, 0x00, 0x00, 0x00}, "Rx 11-bit ID 0x181, 8 bytes, form 0x00", ""},
      {{0x83, 0x08, 0x03, 0x01, 0x00},
       "Tx 11-bit ID 0x301, 9 bytes (8 data + Tx-Counter), form 0x00 (valid only with Tx-Counter "
       "on)",
       ""},
      // manual §5.1.4: 0x07F8 on an 11-bit output = no CAN assignment
      {{0x83, 0x00, 0x07, 0xF8, 0x00}, "Tx without CAN identifier (0x07F8 dummy), 1 byte", ""},
      // manual §5.3.2: Communication Window FF EF, SYNC time in comment bytes 4-5
      {{0x85, 0x8F, 0xFF, 0xEF, 0x00, 0x00, 0x64},
       "Communication Window write (output), form 0x00, SYNC time 100 ms (valid only with "
       "Communication Window on)",
       ""},
      {{0x85, 0x0F, 0xFF, 0xEF, 0x00, 0x00, 0x00}, "", "Cfg fault code 8"},
      {{0x43, 0x87, 0xFF, 0xEF, 0x00}, "", "Cfg fault code 3"},
      // manual table 6.4.1: Page-Mode segment; a shorter one as the last of its direction
      {{0x40, 0x9F}, "Page-Mode input segment, 32 bytes (valid only with Page-Mode on)", ""},
      {{0x80, 0x87}, "Page-Mode output segment, 8 bytes (valid only with Page-Mode on)", ""},
      // Not consistent, so not a segment; as a normal slot the gateway checks the length (code
      // 3) before the identifier (code 4), in the order of docs/slots.md "Chk_Cfg slots".
      {{0x40, 0x1F}, "", "Cfg fault code 3: wrong length"},
      {{0x40, 0x07}, "", "Cfg fault code 4: identifier missing"},
      {{0x20}, "", "Cfg fault code 1: wrong I/O type"},  // general format
      {{0xC3, 0x00, 0x00, 0x01, 0x02, 0x00}, "", "Cfg fault code 1: wrong I/O type"},
      {{0x00}, "", "Cfg fault code 1"},  // empty slot
      {{0x43, 0x41, 0x01, 0x02, 0x00}, "", "Cfg fault code 2: wrong unit"},
      {{0x43, 0x09, 0x01, 0x02, 0x00}, "", "Cfg fault code 3: wrong length"},
      {{0x41, 0x00, 0x01}, "", "Cfg fault code 4"},
      {{0x42, 0x00, 0x01, 0x02}, "", "Cfg fault code 5: format byte missing"},
      {{0x44, 0x00, 0x20, 0x01, 0x02, 0x03}, "", "Cfg fault code 5"},
      {{0x46, 0x00, 1, 2, 3, 4, 5, 6}, "", "Cfg fault code 6: wrong identifier"},
      {{0x43, 0x00, 0x08, 0x00, 0x00}, "", "Cfg fault code 6"},  // 11-bit 0x800 > 0x7FF
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(hex_bytes(c.cfg));
    const CfgDecode d = decode_config(c.cfg);
    ASSERT_FALSE(d.error) << *d.error;
    ASSERT_EQ(d.entries.size(), 1u);
    const gw::EntryReading s = gw::read_cfg_entry(d.entries[0].bytes);
    EXPECT_EQ(s.text, c.text);
    if (*c.problem == 0) {
      EXPECT_FALSE(s.problem) << *s.problem;
      EXPECT_TRUE(s.slot.has_value());
    } else {
      EXPECT_FALSE(s.slot.has_value());
      EXPECT_NE(s.problem.value_or("").find(c.problem), std::string::npos)
          << s.problem.value_or("(none)");
    }
  }
  EXPECT_TRUE(is_universal_module(std::vector<std::uint8_t>{0x00}));
  EXPECT_FALSE(is_universal_module(std::vector<std::uint8_t>{0x00, 0x00}));
}

// docs/slots.md "Chk_Cfg slots": the cycle an input slot's comment carries is read as the gateway
// reads an output's; nothing for no cycle bytes, cycle 0 or outputs.
TEST(GsdCfg, IgnoredInputCycle) {
  gw::Slot rx;
  rx.kind = gw::SlotKind::Rx;
  rx.length = 2;
  rx.comment = {0x01, 0x81, 0x00, 0x01, 0xF4};
  EXPECT_EQ(gw::ignored_input_cycle(rx, {}), 500);
  rx.comment = {0x21, 0x00, 0x01, 0x81, 0x00, 0x00, 0x64};  // 29-bit, cycle 100 ms
  EXPECT_EQ(gw::ignored_input_cycle(rx, {}), 100);
  rx.comment = {0x01, 0x81, 0x00};
  EXPECT_FALSE(gw::ignored_input_cycle(rx, {}));
  rx.comment = {0x01, 0x81, 0x00, 0x00, 0x00};
  EXPECT_FALSE(gw::ignored_input_cycle(rx, {}));
  rx.comment = {0x20, 0x00, 0x01, 0x81, 0x00};  // 29-bit with m = 5: no cycle bytes
  EXPECT_FALSE(gw::ignored_input_cycle(rx, {}));
  gw::Slot tx = rx;
  tx.kind = gw::SlotKind::Tx;
  tx.comment = {0x01, 0x81, 0x00, 0x01, 0xF4};
  EXPECT_FALSE(gw::ignored_input_cycle(tx, {}));
}

}  // namespace
}  // namespace candp2::gsd

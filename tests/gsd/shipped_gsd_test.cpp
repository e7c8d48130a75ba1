// The shipped device description gsd/CDPS04A4.GSD (manual chapter 4 and 7,
// docs/dp-slave.md "User parameters", docs/slots.md "Chk_Cfg slots"): it parses without a single
// diagnostic, check() has no findings, its parameter defaults and named overrides encode to the
// Set_Prm user bytes of docs/dp-slave.md "User parameters", and its module catalogue matches the
// snapshot in snapshots/CDPS04A4.modules.txt.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/hex.hpp"
#include "gateway/cfg_reading.hpp"
#include "gsd/cfg.hpp"
#include "gsd/check.hpp"
#include "gsd/gsd.hpp"
#include "gsd/prm.hpp"
#include "gsd/summary.hpp"
#include "tools/candp2/gsd_reading.hpp"

namespace candp2::gsd {
namespace {

const char* const kGsdPath = CANDP2_SOURCE_DIR "/gsd/CDPS04A4.GSD";
const char* const kSnapshot = CANDP2_SOURCE_DIR "/tests/gsd/snapshots/CDPS04A4.modules.txt";

const ParseResult& shipped() {
  static const ParseResult r = parse_file(kGsdPath);
  return r;
}

std::string encode_hex(std::vector<PrmOverride> ov) {
  const EncodeResult r = encode_user_prm(shipped().model, ov);
  std::string out = hex_bytes(r.bytes);
  for (const auto& e : r.errors) out += " | " + e;
  return out;
}

TEST(ShippedGsd, ParsesWithoutAnyDiagnostic) {
  for (const auto& d : shipped().diagnostics) ADD_FAILURE() << format(d, kGsdPath);
  EXPECT_TRUE(shipped().model.has_header);
}

TEST(ShippedGsd, CheckHasNoFindings) {
  for (const auto& d : check(shipped().model, &cli::candp2_reader()))
    ADD_FAILURE() << format(d, kGsdPath);
}

TEST(ShippedGsd, KeywordsOfManualChapter4) {
  const Model& m = shipped().model;
  EXPECT_EQ(m.vendor_name(), "esd");
  EXPECT_EQ(m.model_name(), "CAN-DP/2");
  EXPECT_EQ(m.ident_number(), 0x04A4);  // manual §4 (printed as 1188 decimal)
  EXPECT_EQ(m.gsd_revision(), 1);
  const Limits l = m.limits();
  EXPECT_TRUE(l.modular_station);
  EXPECT_EQ(l.max_module, 48);
  EXPECT_EQ(l.max_input_len, 244);
  EXPECT_EQ(l.max_output_len, 244);
  EXPECT_EQ(l.max_data_len, 300);
  EXPECT_EQ(l.max_user_prm_data_len, 9);
  EXPECT_EQ(l.user_prm_data_len, 9);
  EXPECT_EQ(l.modul_offset, 0);  // docs/slots.md "Chk_Cfg slots": slot numbers are 0-based
  EXPECT_EQ(l.min_slave_intervall, 6);
  EXPECT_EQ(m.number("freeze_mode_supp"), 0);  // docs/dp-slave.md: FREEZE/SYNC not supported
  EXPECT_EQ(m.number("SYNC_MODE_SUPP"), 0);
  EXPECT_EQ(m.number("Set_Slave_Add_supp"), 0);
  ASSERT_EQ(m.prm_texts.size(), 3u);
  ASSERT_NE(m.prm_text(1), nullptr);
  EXPECT_EQ(m.prm_text(1)->texts.size(), 14u);  // manual table 5.1.1: 14 bit rates
  EXPECT_EQ(*m.prm_text(1)->text_for(6), "125 kbit/s");
  EXPECT_EQ(*m.prm_text(3)->text_for(0), "Yes");  // docs/dp-slave.md "User parameters": RTR bit 0 =
                                                  // send
  EXPECT_EQ(m.ext_user_prm_data.size(), 13u);
}

// docs/dp-slave.md "User parameters": offsets into the 9 user bytes (telegram bytes 7..15).
TEST(ShippedGsd, UserParameterLayoutOfEmulatorSpec11) {
  const Model& m = shipped().model;
  struct Expect {
    const char* name;
    std::int64_t offset;
    PrmType type;
    int bit;
  };
  const Expect table[] = {
      {"CAN-Bitrate", 1, PrmType::Unsigned8, 0},
      {"Communication Window", 2, PrmType::Bit, 7},
      {"RTR-Frames", 2, PrmType::Bit, 4},
      {"CANopen-Slave", 2, PrmType::Bit, 3},
      {"CANopen-Master", 2, PrmType::Bit, 2},
      {"Start-Frame", 2, PrmType::Bit, 1},
      {"Page-Mode", 2, PrmType::Bit, 0},
      {"ModuleID", 3, PrmType::Unsigned8, 0},
      {"CAN-Diagnosis", 4, PrmType::Bit, 0},
      {"Rx-Counter", 4, PrmType::Bit, 1},
      {"Tx-Counter", 4, PrmType::Bit, 2},  // docs/dp-slave.md "User parameters": added as Bit(2)
      {"WakeUp Time (0=Off, 255=Default)", 6, PrmType::Unsigned8, 0},
      {"Sync Time (0=Off, 65535=Default)", 7, PrmType::Unsigned16, 0},
  };
  ASSERT_EQ(m.user_prm.refs.size(), std::size(table));
  for (const auto& e : table) {
    SCOPED_TRACE(e.name);
    const PrmRef* found = nullptr;
    for (const auto& r : m.user_prm.refs) {
      const ExtUserPrmData* d = m.ext_user_prm(r.ref);
      ASSERT_NE(d, nullptr);
      if (d->name == e.name) found = &r;
    }
    ASSERT_NE(found, nullptr);
    EXPECT_EQ(found->offset, e.offset);
    const ExtUserPrmData* d = m.ext_user_prm(found->ref);
    EXPECT_EQ(d->type, e.type);
    if (e.type == PrmType::Bit) {
      EXPECT_EQ(d->first_bit, e.bit);
    }
  }
  // Nothing at the reserved bytes 0 and 5.
  for (const auto& r : m.user_prm.refs) EXPECT_TRUE(r.offset != 0 && r.offset != 5);
}

// manual §4 / §5.1.2 defaults (bit rate 125 kbit/s = index 6, ModuleID 1, wake-up 255, SYNC
// 65535 "keep") in the docs/dp-slave.md "User parameters" layout: reserved 0, bitrate 6, flags 0,
// ModuleID 1, diag 0, reserved 0, wake-up FF, SYNC FF FF (big-endian).
TEST(ShippedGsd, DefaultsEncodeToTheSpecifiedNineBytes) {
  EXPECT_EQ(encode_hex({}), "00 06 00 01 00 00 FF FF FF");
  // The legacy User_Prm_Data line says the same for masters without Ext_User_Prm_Data.
  const auto legacy = shipped().model.user_prm_data();
  ASSERT_TRUE(legacy.has_value());
  EXPECT_EQ(hex_bytes(*legacy), "00 06 00 01 00 00 FF FF FF");
}

TEST(ShippedGsd, NamedOverridesEncodeIntoTheirBytesAndBits) {
  struct Case {
    std::vector<PrmOverride> ov;
    const char* expect;
  };
  const Case cases[] = {
      {{{"CAN-Bitrate", 2}}, "00 02 00 01 00 00 FF FF FF"},  // table 5.1.1: 500 kbit/s
      {{{"can-bitrate", std::string("1000 kbit/s")}}, "00 00 00 01 00 00 FF FF FF"},
      {{{"Page-Mode", 1}}, "00 06 01 01 00 00 FF FF FF"},
      {{{"Communication Window", 1}}, "00 06 80 01 00 00 FF FF FF"},
      {{{"RTR-Frames", std::string("No")}}, "00 06 10 01 00 00 FF FF FF"},
      {{{"CANopen-Master", 1}, {"Start-Frame", std::string("Yes")}, {"Communication Window", 1}},
       "00 06 86 01 00 00 FF FF FF"},
      {{{"CANopen-Slave", 1}, {"ModuleID", 127}}, "00 06 08 7F 00 00 FF FF FF"},
      {{{"CAN-Diagnosis", 1}, {"Rx-Counter", 1}, {"Tx-Counter", 1}}, "00 06 00 01 07 00 FF FF FF"},
      {{{"Tx-Counter", 1}}, "00 06 00 01 04 00 FF FF FF"},
      {{{"WakeUp Time (0=Off, 255=Default)", 10}}, "00 06 00 01 00 00 0A FF FF"},
      // docs/dp-slave.md "User parameters": SYNC time big-endian, 1000 ms = 03 E8
      {{{"Sync Time (0=Off, 65535=Default)", 1000}}, "00 06 00 01 00 00 FF 03 E8"},
      {{{"Sync Time (0=Off, 65535=Default)", 0}}, "00 06 00 01 00 00 FF 00 00"},
      // The later override of the same name wins.
      {{{"CAN-Bitrate", 2}, {"CAN-Bitrate", 13}}, "00 0D 00 01 00 00 FF FF FF"},
  };
  for (const auto& c : cases) EXPECT_EQ(encode_hex(c.ov), c.expect);
}

TEST(ShippedGsd, InvalidOverridesAreReportedAndLeaveTheDefault) {
  struct Case {
    PrmOverride ov;
    const char* error_part;
  };
  const Case cases[] = {
      {{"ModuleID", 0}, "outside the range 1-127"},
      {{"ModuleID", 128}, "outside the range 1-127"},
      {{"CAN-Bitrate", 14}, "outside the range 0-13"},
      {{"CAN-Bitrate", -1}, "outside what Unsigned8 holds"},
      {{"Page-Mode", 2}, "outside what Bit holds"},
      {{"Sync Time (0=Off, 65535=Default)", 65536}, "outside what Unsigned16 holds"},
      {{"CAN-Bitrate", std::string("fast")}, "not a number nor one of"},
      {{"No-Such-Parameter", 1}, "no such parameter"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.ov.name);
    const EncodeResult r = encode_user_prm(shipped().model, {&c.ov, 1});
    ASSERT_EQ(r.errors.size(), 1u);
    EXPECT_NE(r.errors[0].find(c.error_part), std::string::npos) << r.errors[0];
    EXPECT_EQ(hex_bytes(r.bytes), "00 06 00 01 00 00 FF FF FF");
  }
}

TEST(ShippedGsd, LinesStayUnder80Characters) {
  std::ifstream in(kGsdPath, std::ios::binary);
  ASSERT_TRUE(in);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    EXPECT_LT(line.size(), 80u) << "line " << n;
    EXPECT_EQ(line.find('\r'), std::string::npos) << "line " << n;
    EXPECT_EQ(line.find('\t'), std::string::npos) << "line " << n;
  }
  EXPECT_GT(n, 100);
}

// manual §7 example: output, 3 comment bytes, 6 bytes, ID 0x0203, form 0x00.
TEST(ShippedGsd, CarriesTheManualChapter7Example) {
  const Module* m = shipped().model.module("Tx 11-bit 6 bytes ID 0x203");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(hex_bytes(m->config), "83 05 02 03 00");
  const CfgDecode dec = decode_config(m->config);
  ASSERT_EQ(dec.entries.size(), 1u);
  const gw::EntryReading s = gw::read_cfg_entry(dec.entries[0].bytes);
  EXPECT_FALSE(s.problem.has_value());
  EXPECT_EQ(s.text, "Tx 11-bit ID 0x203, 6 bytes, form 0x00");
}

std::string module_listing(const Model& m) {
  std::string out;
  for (const auto& mod : m.modules) {
    std::string name = "\"" + mod.name + "\"";
    if (name.size() < 36) name.append(36 - name.size(), ' ');
    out += name + " " + hex_bytes(mod.config) + "\n";
  }
  return out;
}

// Snapshot of the module catalogue (name -> config bytes). After a deliberate change of the
// GSD, regenerate with CANDP2_UPDATE_SNAPSHOTS=1 and review the diff.
TEST(ShippedGsd, ModuleCatalogueSnapshot) {
  const std::string actual = module_listing(shipped().model);
  if (const char* upd = std::getenv("CANDP2_UPDATE_SNAPSHOTS"); upd && *upd == '1') {
    std::ofstream(kSnapshot, std::ios::binary) << actual;
    GTEST_SKIP() << "snapshot written: " << kSnapshot;
  }
  std::ifstream in(kSnapshot, std::ios::binary);
  ASSERT_TRUE(in) << "missing " << kSnapshot << "; actual listing:\n" << actual;
  std::ostringstream expected;
  expected << in.rdbuf();
  EXPECT_EQ(actual, expected.str());
}

TEST(ShippedGsd, EveryModuleIsAValidCanDp2Slot) {
  for (const auto& mod : shipped().model.modules) {
    SCOPED_TRACE(mod.name);
    if (is_universal_module(mod.config)) continue;
    const CfgDecode dec = decode_config(mod.config);
    ASSERT_FALSE(dec.error.has_value()) << *dec.error;
    ASSERT_EQ(dec.entries.size(), 1u);
    const gw::EntryReading s = gw::read_cfg_entry(dec.entries[0].bytes);
    EXPECT_FALSE(s.problem.has_value()) << *s.problem;
  }
}

TEST(ShippedGsd, SummaryNamesTheEssentials) {
  const std::string s = summary(shipped().model, &cli::candp2_reader());
  for (const char* part :
       {"esd CAN-DP/2", "0x04A4", "Max_Module 48", "Max_Input_Len 244", "Max_Data_Len 300",
        "defaults 00 06 00 01 00 00 FF FF FF", "CAN-Bitrate", "\"125 kbit/s\"", "byte 7..8",
        "byte 4 bit 2", "Tx-Counter", "Communication Window read (input)",
        "Page-Mode output segment, 32 bytes", "Tx 11-bit ID 0x203, 6 bytes, form 0x00"})
    EXPECT_NE(s.find(part), std::string::npos) << part;
}

}  // namespace
}  // namespace candp2::gsd

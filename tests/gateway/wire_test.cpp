// Wire formats of the gateway core, built from the manual's own examples.
#include <gtest/gtest.h>

#include <cstring>

#include "fixture.hpp"
#include "gateway/form.hpp"
#include "gateway/slot_config.hpp"
#include "gateway/user_prm.hpp"

namespace candp2::gw::test {
namespace {

// ---------------------------------------------------------------- form (manual §5.2.2)

struct FormCase {
  const char* cite;
  std::uint8_t form;
  std::vector<std::uint8_t> plc;
  std::vector<std::uint8_t> can;
};

class FormSwap : public ::testing::TestWithParam<FormCase> {};

TEST_P(FormSwap, ConvertsAndIsItsOwnInverse) {
  const auto& c = GetParam();
  auto b = c.plc;
  form_swap(b, c.form);
  EXPECT_EQ(hex(b), hex(c.can)) << c.cite;
  form_swap(b, c.form);
  EXPECT_EQ(hex(b), hex(c.plc)) << c.cite << " (inverse)";
}

INSTANTIATE_TEST_SUITE_P(
    Manual, FormSwap,
    ::testing::Values(
        // manual §5.2.2: 0x8E swaps bytes 1-2 and 5-8, bytes 3-4 unchanged.
        FormCase{"§5.2.2 8E", 0x8E, {1, 2, 3, 4, 5, 6, 7, 8}, {2, 1, 3, 4, 8, 7, 6, 5}},
        // manual §5.2.2: FE swaps all 8 bytes.
        FormCase{"§5.2.2 FE", 0xFE, {1, 2, 3, 4, 5, 6, 7, 8}, {8, 7, 6, 5, 4, 3, 2, 1}},
        // docs/slots.md "Data exchange in normal mode": B8 on 6 bytes: a b c d e f -> b a f e d c.
        FormCase{"§4 B8/6", 0xB8, {0xA, 0xB, 0xC, 0xD, 0xE, 0xF}, {0xB, 0xA, 0xF, 0xE, 0xD, 0xC}},
        FormCase{"00 = none", 0x00, {1, 2, 3}, {1, 2, 3}},
        // docs/slots.md "Data exchange in normal mode": a group still open at the last data byte
        // ends there.
        FormCase{"open group", 0xE0, {1, 2}, {2, 1}},
        FormCase{"lone zero bits", 0x40, {1, 2, 3, 4}, {1, 3, 2, 4}}));

// ---------------------------------------------------- Set_Prm (docs/dp-slave.md "User parameters")

// Every bit rate as manual table 5.1.1 names it, in one place: logs, pages, reports.
TEST(Bitrates, TextAsTable511NamesThem) {
  const char* names[] = {"1000k", "666.6k", "500k", "333.3k", "250k", "166k",  "125k",
                         "100k",  "66.6k",  "50k",  "33.3k",  "20k",  "12.5k", "10k"};
  for (std::uint8_t i = 0; i < kBitrates.size(); ++i) {
    EXPECT_EQ(bitrate_name(i), names[i]);
    EXPECT_EQ(bitrate_text(i),
              std::string(names[i]).substr(0, std::strlen(names[i]) - 1) + " kbit/s");
    EXPECT_EQ(bitrate_text_bps(kBitrates[i]), bitrate_text(i));
  }
  EXPECT_EQ(bitrate_text(1), "666.6 kbit/s");  // not "666 kbit/s"
  EXPECT_EQ(bitrate_bps(0), 1000000u);         // the one checked look-up of the table
  EXPECT_EQ(bitrate_bps(13), 10000u);
  EXPECT_FALSE(bitrate_bps(14));
  EXPECT_EQ(bitrate_name(14), "?");
  EXPECT_EQ(bitrate_text(14), "?");
  EXPECT_EQ(bitrate_text_bps(800000), "800 kbit/s");    // an interface outside the table
  EXPECT_EQ(bitrate_text_bps(666666), "666666 bit/s");  // what an SJA1000 may really run
}

TEST(UserPrm, DefaultsRoundTrip) {
  UserPrm p;
  const auto t = make_set_prm(p);
  // GSD defaults: bitrate 6 (125 k), ModuleID 1, wake-up 255, SYNC 65535 (manual §4).
  EXPECT_EQ(hex(t), "00 01 01 00 04 A4 00 00 06 00 01 00 00 FF FF FF");
  auto d = decode_user_prm(t);
  ASSERT_TRUE(std::holds_alternative<UserPrm>(d));
  EXPECT_EQ(std::get<UserPrm>(d), p);
}

TEST(UserPrm, FlagsAndCountersDecode) {
  auto t = make_set_prm(UserPrm{});
  t[kPrmFlags] = kFlagCommWindow | kFlagNoRtr | kFlagCanopenMaster | kFlagStartFrame;
  t[kPrmDiagFlags] = kDiagCanDiagnosis | kDiagRxCounter | kDiagTxCounter;
  t[kPrmSyncHigh] = 0x02;
  t[kPrmSyncLow] = 0x00;
  auto p = std::get<UserPrm>(decode_user_prm(t));
  EXPECT_TRUE(p.comm_window);
  EXPECT_FALSE(p.send_rtr);  // bit 4 set = don't send RTR frames (GSD PrmText 3)
  EXPECT_EQ(p.role(), CanopenRole::Master);
  EXPECT_TRUE(p.start_frame);
  EXPECT_TRUE(p.can_diagnosis && p.rx_counter && p.tx_counter);
  EXPECT_EQ(p.sync_ms, 0x0200);
}

struct PrmFaultCase {
  const char* what;
  std::size_t byte;
  std::uint8_t value;
  std::uint8_t correct;
};

class PrmFaults : public GatewayFixture, public ::testing::WithParamInterface<PrmFaultCase> {};

// Every Prm fault of docs/dp-slave.md "User parameters" shows as diag 3D, faulty byte, correct
// value.
TEST_P(PrmFaults, ReportedInDiagnosisBytes8To10) {
  const auto& c = GetParam();
  make();
  auto t = make_set_prm(UserPrm{});
  t[c.byte] = c.value;
  EXPECT_FALSE(gw->dp().set_prm(kMaster, t, now));
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  const auto d = diag();
  EXPECT_EQ(d[0], dp::kDiag1StationNotReady | dp::kDiag1ExtDiag | dp::kDiag1PrmFault) << c.what;
  EXPECT_EQ(d[8], 0x3D) << c.what;
  EXPECT_EQ(d[9], c.byte) << c.what;
  EXPECT_EQ(d[10], c.correct) << c.what;
}

INSTANTIATE_TEST_SUITE_P(Spec11, PrmFaults,
                         ::testing::Values(PrmFaultCase{"Ident high", 4, 0x05, 0x04},
                                           PrmFaultCase{"Ident low", 5, 0xA5, 0xA4},
                                           PrmFaultCase{"reserved byte 7", 7, 0x01, 0x00},
                                           PrmFaultCase{"bitrate 14", 8, 14, 6},
                                           PrmFaultCase{"flags bits 6,5", 9, 0x61, 0x01},
                                           PrmFaultCase{"slave+master", 9, 0x8C, 0x80},
                                           PrmFaultCase{"page-mode with master", 9, 0x05, 0x04},
                                           PrmFaultCase{"page-mode with slave", 9, 0x09, 0x08},
                                           PrmFaultCase{"ModuleID 0", 10, 0, 1},
                                           PrmFaultCase{"ModuleID 128", 10, 128, 1},
                                           PrmFaultCase{"unknown diag bits", 11, 0x0B, 0x03},
                                           PrmFaultCase{"reserved byte 12", 12, 0x80, 0x00}));

TEST_F(GatewayFixture, PrmLengthFaultNamesFirstMissingOrExcessByte) {
  make();
  auto t = make_set_prm(UserPrm{});
  // docs/dp-slave.md "User parameters": byte 9 = first missing byte index, byte 10 = 0.
  gw->dp().set_prm(kMaster, std::span(t).first(12), now);
  auto d = diag();
  EXPECT_EQ(d[8], 0x3D);
  EXPECT_EQ(d[9], 12);
  EXPECT_EQ(d[10], 0);
  std::vector<std::uint8_t> longer(t.begin(), t.end());
  longer.push_back(0);
  gw->dp().set_prm(kMaster, longer, now);
  d = diag();
  EXPECT_EQ(d[9], 16);  // first excess byte
}

TEST_F(GatewayFixture, PrmChecksRunInTelegramByteOrder) {
  make();
  auto t = make_set_prm(UserPrm{});
  t[kPrmModuleId] = 0;  // byte 10 faulty
  t[kPrmBitrate] = 20;  // byte 8 faulty: reported first
  gw->dp().set_prm(kMaster, t, now);
  EXPECT_EQ(diag()[9], kPrmBitrate);
}

TEST_F(GatewayFixture, SyncOrFreezeRequestIsNotSupported) {
  make();
  auto t = make_set_prm(UserPrm{});
  t[0] |= dp::kPrmSyncReq;
  EXPECT_FALSE(gw->dp().set_prm(kMaster, t, now));
  const auto d = diag();
  // docs/dp-slave.md: Not_Supported, Station_Status_1 bit 4.
  EXPECT_EQ(d[0] & dp::kDiag1NotSupported, dp::kDiag1NotSupported);
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
}

// ---------------------------------------------------------------- Chk_Cfg (manual §5, §7)

SlotConfig slots_ok(const std::vector<std::uint8_t>& cfg, UserPrm p = {}) {
  auto r = decode_slots(cfg, p);
  if (auto* f = std::get_if<dp::CfgFault>(&r)) {
    ADD_FAILURE() << "Cfg fault slot " << int(f->slot) << " code " << int(f->code);
    return {};
  }
  return std::get<SlotConfig>(r);
}

TEST(ChkCfg, Manual514InputAndOutputExample) {
  // manual §5.1.4: input 0x0289 form B8 length 6 (comment 02,89,B8) and output 0x0309 form B8.
  std::string err;
  const auto in_comment = *parse_comment("02,89,B8,", &err);
  const auto out_comment = *parse_comment("03,09,B8,", &err);
  auto c = slots_ok(cfg_of({in_slot(6, in_comment), out_slot(6, out_comment)}));
  ASSERT_EQ(c.slots.size(), 2u);
  EXPECT_EQ(c.slots[0].kind, SlotKind::Rx);
  EXPECT_EQ(c.slots[0].id, (can::Ident{0x289, false}));
  EXPECT_EQ(c.slots[0].form, 0xB8);
  EXPECT_EQ(c.slots[0].length, 6u);
  EXPECT_EQ(c.slots[1].kind, SlotKind::Tx);
  EXPECT_EQ(c.slots[1].id, (can::Ident{0x309, false}));
  EXPECT_EQ(c.input_len, 6u);
  EXPECT_EQ(c.output_len, 6u);
}

TEST(ChkCfg, Manual521ExtendedIdentifier) {
  // manual §5.2.1: 20,12,34,56 -> 29-bit identifier 0x123456 (bit 29 flags the 29-bit kind).
  auto c = slots_ok(cfg_of({out_slot(8, {0x20, 0x12, 0x34, 0x56, 0xB8})}));
  EXPECT_EQ(c.slots[0].id, (can::Ident{0x123456, true}));
  EXPECT_EQ(c.slots[0].form, 0xB8);
  EXPECT_EQ(c.slots[0].cycle_ms, 0);
}

TEST(ChkCfg, Manual521ElevenBitIdentifier) {
  // manual §5.2.1: 03,09, is the 11-bit identifier 0x309.
  auto c = slots_ok(cfg_of({out_slot(2, {0x03, 0x09, 0x00})}));
  EXPECT_EQ(c.slots[0].id, (can::Ident{0x309, false}));
}

TEST(ChkCfg, Manual523CycleBytes) {
  // manual §5.2.3: 03,09,B8,03,E8 = every 1000 ms; 29-bit with cycle 20,12,34,56,B8,03,E8.
  auto c = slots_ok(cfg_of({out_slot(8, {0x03, 0x09, 0xB8, 0x03, 0xE8}),
                            out_slot(8, {0x20, 0x12, 0x34, 0x56, 0xB8, 0x03, 0xE8})}));
  EXPECT_EQ(c.slots[0].cycle_ms, 1000);
  EXPECT_EQ(c.slots[1].id, (can::Ident{0x123456, true}));
  EXPECT_EQ(c.slots[1].cycle_ms, 1000);
}

TEST(ChkCfg, Manual7SpecialIdentifierExample) {
  // manual §7: 0x83,0x05,0x02,0x03,0x00 = output, 6 bytes, identifier 0x203, no swap.
  const std::vector<std::uint8_t> cfg = {0x83, 0x05, 0x02, 0x03, 0x00};
  auto c = slots_ok(cfg);
  ASSERT_EQ(c.slots.size(), 1u);
  EXPECT_EQ(c.slots[0].kind, SlotKind::Tx);
  EXPECT_EQ(c.slots[0].length, 6u);
  EXPECT_EQ(c.slots[0].id, (can::Ident{0x203, false}));
  EXPECT_EQ(c.slots[0].form, 0x00);
  EXPECT_FALSE(c.slots[0].consistent);
}

TEST(ChkCfg, EncodeDecodeRoundTrip) {
  const std::vector<std::uint8_t> cfg = {0x83, 0x05, 0x02, 0x03, 0x00};
  auto decoded = dp::decode_chk_cfg(cfg);
  EXPECT_EQ(dp::encode_chk_cfg(decoded.entries), cfg);
}

TEST(ChkCfg, DummyOutputHasNoIdentifier) {
  auto c = slots_ok(cfg_of({dummy_out()}));
  EXPECT_FALSE(c.slots[0].id.has_value());  // manual §5.1.4: 0x07F8
}

TEST(ChkCfg, CountersAddOneByte) {
  UserPrm p;
  p.rx_counter = p.tx_counter = true;
  auto c = slots_ok(cfg_of({in_slot(9, {0x01, 0x81, 0x00}), out_slot(9, {0x02, 0x01, 0x00})}), p);
  EXPECT_EQ(c.slots[0].data_len, 8u);
  EXPECT_TRUE(c.slots[0].counter);
  EXPECT_EQ(c.slots[1].data_len, 8u);
}

TEST(ChkCfg, CounterSlotsNeedOneDataByte) {
  // docs/slots.md "Cfg fault codes" code 3: 1..8 data bytes plus the counter byte, so 2 is the
  // shortest slot with a counter; the counter of the other direction does not count.
  UserPrm p;
  p.rx_counter = true;
  auto c = slots_ok(cfg_of({in_slot(2, {0x01, 0x81, 0x00}), out_slot(1, {0x02, 0x01, 0x00})}), p);
  EXPECT_EQ(c.slots[0].data_len, 1u);
  EXPECT_EQ(c.slots[1].data_len, 1u);
  p.rx_counter = false;
  p.tx_counter = true;
  c = slots_ok(cfg_of({in_slot(1, {0x01, 0x81, 0x00}), out_slot(2, {0x02, 0x01, 0x00})}), p);
  EXPECT_EQ(c.slots[0].data_len, 1u);
  EXPECT_EQ(c.slots[1].data_len, 1u);
}

struct CfgCase {
  const char* what;
  std::vector<std::uint8_t> cfg;
  std::uint8_t slot;
  std::uint8_t code;
  UserPrm prm = {};
};

UserPrm with_cw() {
  UserPrm p;
  p.comm_window = true;
  return p;
}
UserPrm with_counters() {
  UserPrm p;
  p.rx_counter = p.tx_counter = true;
  return p;
}
UserPrm with_page() {
  UserPrm p;
  p.page_mode = true;
  return p;
}

std::vector<std::uint8_t> many_outputs(int n) {
  std::vector<std::uint8_t> cfg;
  for (int i = 0; i < n; ++i) {
    auto b = cfg_of({out_slot(1, {0x01, static_cast<std::uint8_t>(i), 0x00})});
    cfg.insert(cfg.end(), b.begin(), b.end());
  }
  return cfg;
}

std::vector<std::uint8_t> bytes_out(int slots, std::uint8_t len, std::uint8_t id_high) {
  std::vector<std::uint8_t> cfg;
  for (int i = 0; i < slots; ++i) {
    auto b = cfg_of({out_slot(len, {id_high, static_cast<std::uint8_t>(i), 0x00})});
    cfg.insert(cfg.end(), b.begin(), b.end());
  }
  return cfg;
}
std::vector<std::uint8_t> bytes_in(int slots, std::uint8_t len, std::uint8_t id_high) {
  std::vector<std::uint8_t> cfg;
  for (int i = 0; i < slots; ++i) {
    auto b = cfg_of({in_slot(len, {id_high, static_cast<std::uint8_t>(i), 0x00})});
    cfg.insert(cfg.end(), b.begin(), b.end());
  }
  return cfg;
}
std::vector<std::uint8_t> cat(std::vector<std::uint8_t> a, const std::vector<std::uint8_t>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

class CfgFaults : public GatewayFixture, public ::testing::WithParamInterface<CfgCase> {};

// docs/slots.md "Chk_Cfg slots": every Cfg code 1..10, with the slot number in diag byte 9.
TEST_P(CfgFaults, ReportedInDiagnosisBytes8To10) {
  const auto& c = GetParam();
  EXPECT_FALSE(configure(c.prm, c.cfg)) << c.what;
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm) << c.what;
  const auto d = diag();
  EXPECT_EQ(d[0], dp::kDiag1StationNotReady | dp::kDiag1CfgFault | dp::kDiag1ExtDiag) << c.what;
  EXPECT_EQ(d[1], dp::kDiag2PrmReq | dp::kDiag2AlwaysOne) << c.what;
  EXPECT_EQ(d[8], 0x3E) << c.what;
  EXPECT_EQ(d[9], c.slot) << c.what;
  EXPECT_EQ(d[10], c.code) << c.what;
}

const std::vector<std::uint8_t> kOut = cfg_of({out_slot(2, {0x01, 0x00, 0x00})});

INSTANTIATE_TEST_SUITE_P(
    Spec2, CfgFaults,
    ::
        testing::
            Values(
                CfgCase{"1 empty slot", cat(kOut, {0x00}), 1, 1},
                CfgCase{"1 input+output", cat(kOut, {0xC3, 0x81, 0x81, 0x01, 0x23, 0x00}), 1, 1},
                CfgCase{"1 general format", cat(kOut, {0x95}), 1, 1},
                CfgCase{"2 word unit", cat(kOut, {0x43, 0x41, 0x01, 0x23, 0x00}), 1, 2},
                CfgCase{"3 length 9 without counter",
                        cat(kOut, cfg_of({in_slot(9, {0x01, 0x23, 0x00})})), 1, 3},
                // docs/slots.md "Cfg fault codes" code 3: the counter byte alone carries no data.
                CfgCase{"3 Rx-Counter slot of length 1",
                        cat(kOut, cfg_of({in_slot(1, {0x01, 0x23, 0x00})})), 1, 3, with_counters()},
                CfgCase{"3 Tx-Counter slot of length 1",
                        cfg_of({out_slot(1, {0x01, 0x00, 0x00})}), 0, 3, with_counters()},
                CfgCase{"3 Tx-Counter dummy output of length 1", cfg_of({dummy_out()}), 0, 3,
                        with_counters()},
                CfgCase{"3 CW not 16", cfg_of({out_slot(8, {0xFF, 0xEF, 0x00, 0x00, 0x00})}), 0, 3,
                        with_cw()},
                CfgCase{"4 no identifier", cat(kOut, cfg_of({in_slot(2, {})})), 1, 4},
                CfgCase{"4 one byte", cat(kOut, cfg_of({in_slot(2, {0x01})})), 1, 4},
                CfgCase{"5 format missing", cat(kOut, cfg_of({in_slot(2, {0x01, 0x23})})), 1, 5},
                CfgCase{"5 29-bit without format",
                        cat(kOut, cfg_of({in_slot(2, {0x20, 0x01, 0x02, 0x03})})), 1, 5},
                CfgCase{"6 11-bit above 7FF", cat(kOut, cfg_of({in_slot(2, {0x08, 0x00, 0x00})})),
                        1, 6},
                CfgCase{"6 half cycle", cat(kOut, cfg_of({out_slot(2, {0x02, 0x00, 0x00, 0x03})})),
                        1, 6},
                CfgCase{"6 m=6", cat(kOut, cfg_of({out_slot(2, {0x20, 0, 0, 1, 0, 3})})), 1, 6},
                CfgCase{"6 Tx and Rx clash", cat(kOut, cfg_of({in_slot(2, {0x01, 0x00, 0x00})})), 1,
                        6},
                CfgCase{"6 truncated entry", cat(kOut, {0x83, 0x05, 0x02}), 1, 6},
                CfgCase{"7 49 slots", many_outputs(49), 48, 7},
                CfgCase{"7 245 output bytes", cat(bytes_out(30, 8, 0x01), bytes_out(1, 5, 0x02)),
                        30, 7},
                CfgCase{"7 301 bytes total",
                        cat(bytes_out(19, 8, 0x01),
                            cat(bytes_in(18, 8, 0x03), bytes_in(1, 5, 0x04))),
                        37, 7},
                CfgCase{"8 CW without Prm flag",
                        cfg_of({out_slot(16, {0xFF, 0xEF, 0x00}), in_slot(16, {0xFF, 0xEF, 0x00})}),
                        0, 8},
                CfgCase{"8 CW one direction", cfg_of({out_slot(16, {0xFF, 0xEF, 0x00})}), 0, 8,
                        with_cw()},
                CfgCase{"8 two CW outputs",
                        cfg_of({out_slot(16, {0xFF, 0xEF, 0x00}),
                                out_slot(16, {0xFF, 0xEF, 0x00})}),
                        1, 8,
                        with_cw()},
                CfgCase{"8 CW not consistent",
                        cfg_of({dp::special_output(16, false, {0xFF, 0xEF, 0x00}),
                                in_slot(16, {0xFF, 0xEF, 0x00})}),
                        0, 8,
                        with_cw()},
                CfgCase{"8 CW before a segment in Page-Mode",
                        cat(cfg_of({out_slot(16, {0xFF, 0xEF, 0x00}),
                                    in_slot(16, {0xFF, 0xEF, 0x00})}),
                            cfg_of({out_slot(32, {}), in_slot(32, {})})),
                        2, 8,
                        [] {
                          auto p = with_page();
                          p.comm_window = true;
                          return p;
                        }()},
                CfgCase{"9 segment with comment",
                        cfg_of({out_slot(32, {0x01, 0x00, 0x00}), in_slot(32, {})}), 0, 9,
                        with_page()},
                CfgCase{"9 segment not consistent",
                        cfg_of({dp::special_output(32, false, {}), in_slot(32, {})}), 0, 9,
                        with_page()},
                CfgCase{"9 short segment not last",
                        cfg_of({out_slot(16, {}), out_slot(32, {}), in_slot(32, {})}), 0, 9,
                        with_page()},
                CfgCase{"9 fewer than 32 input bytes", cfg_of({out_slot(32, {}), in_slot(16, {})}),
                        1, 9, with_page()},
                CfgCase{"10 no output", cfg_of({in_slot(2, {0x01, 0x23, 0x00})}), 0, 10}));

TEST(ChkCfg, SameTxIdentifierTwiceAndSameRxTwiceAreAccepted) {
  // docs/slots.md "Chk_Cfg slots": behaviour, not errors (the validator warns).
  auto c = slots_ok(cfg_of({out_slot(2, {0x01, 0x00, 0x00}), out_slot(2, {0x01, 0x00, 0x00}),
                            in_slot(2, {0x02, 0x00, 0x00}), in_slot(2, {0x02, 0x00, 0x00})}));
  EXPECT_EQ(c.slots.size(), 4u);
}

TEST(ChkCfg, FortyEightSlotsAnd244BytesFit) {
  auto c = slots_ok(cat(bytes_out(30, 8, 0x01), bytes_out(1, 4, 0x02)));
  EXPECT_EQ(c.output_len, 244u);
  auto c48 = slots_ok(many_outputs(48));
  EXPECT_EQ(c48.slots.size(), 48u);
}

TEST(Comment, ParsesSimaticNotation) {
  std::string err;
  EXPECT_EQ(hex(*parse_comment("02,89,B8", &err)), "02 89 B8");
  EXPECT_EQ(hex(*parse_comment("FF EF 00 00 00", &err)), "FF EF 00 00 00");
  EXPECT_EQ(hex(*parse_comment("03,09,B8,", &err)), "03 09 B8");
  EXPECT_FALSE(parse_comment("2,89", &err));
  EXPECT_NE(err.find("two hex digits"), std::string::npos) << err;
  EXPECT_FALSE(parse_comment("02,8G", &err));
  EXPECT_NE(err.find("not a hex digit"), std::string::npos) << err;
}

}  // namespace
}  // namespace candp2::gw::test

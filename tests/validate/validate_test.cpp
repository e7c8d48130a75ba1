// candp2_validate: the report is the answer of a real gw::Gateway (Set_Prm, Chk_Cfg, Slave_Diag),
// plus the warnings of manual §2.1, §5.2.1 and docs/slots.md "Chk_Cfg slots", docs/modbus.md.
#include "validate/validate.hpp"

#include <gtest/gtest.h>

#include "common/hex.hpp"
#include "gateway/gateway.hpp"
#include "validate/report.hpp"

namespace candp2::validate {
namespace {

struct Slot {
  bool input;
  std::uint8_t length;
  std::vector<std::uint8_t> comment;
  std::uint16_t address;
};

GatewayInput make(const std::vector<Slot>& slots, gw::UserPrm prm = {}, std::uint8_t address = 5,
                  std::uint16_t watchdog_ms = 0) {
  GatewayInput in;
  in.name = "gw";
  in.json_path = "$.gateways[0]";
  in.address = address;
  const auto t = gw::make_set_prm(prm, watchdog_ms);
  in.params.prm.assign(t.begin(), t.end());
  std::vector<dp::CfgEntry> entries;
  for (std::size_t i = 0; i < slots.size(); ++i) {
    const Slot& s = slots[i];
    entries.push_back(s.input ? dp::special_input(s.length, true, s.comment)
                              : dp::special_output(s.length, true, s.comment));
    dp::EntryAddress a;
    (s.input ? a.input : a.output) = s.address;
    in.params.addresses.push_back(a);
    in.entry_paths.push_back("$.gateways[0].slots[" + std::to_string(i) + "]");
  }
  in.params.cfg = dp::encode_chk_cfg(entries);
  return in;
}

// manual §5.1.4 example
const std::vector<Slot> kManual = {{true, 6, {0x02, 0x89, 0xB8}, 172},
                                   {false, 6, {0x03, 0x09, 0xB8}, 172}};

std::vector<WarningKind> kinds(const GatewayReport& r) {
  std::vector<WarningKind> out;
  for (const auto& w : r.warnings) out.push_back(w.kind);
  return out;
}

TEST(Validate, AcceptedConfigurationShowsTheGatewaysSlots) {
  const GatewayReport r = check_gateway(make(kManual, {}, 5, 200));
  EXPECT_TRUE(r.valid());
  EXPECT_EQ(r.state, dp::SlaveState::DataExch);
  // docs/dp-slave.md "Diagnosis": Station_Status_2 = always-1 | WD_On, master 1, ident 04 A4, 05
  // 04, 0 0 0.
  EXPECT_EQ(hex_bytes(r.diag), "00 0C 00 01 04 A4 05 04 00 00 00");
  ASSERT_EQ(r.slots.size(), 2u);
  ASSERT_TRUE(r.slots[0].slot && r.slots[1].slot);
  EXPECT_EQ(r.slots[0].slot->kind, gw::SlotKind::Rx);
  EXPECT_EQ(r.slots[0].slot->id, (can::Ident{0x289, false}));
  EXPECT_EQ(r.slots[0].slot->form, 0xB8);
  EXPECT_EQ(r.slots[0].plc_input, 172);
  EXPECT_FALSE(r.slots[0].plc_output);
  EXPECT_EQ(hex_bytes(r.slots[1].cfg_bytes), "83 85 03 09 B8");
  EXPECT_EQ(r.slots[1].plc_output, 172);
  EXPECT_TRUE(r.warnings.empty());
  EXPECT_EQ(explain_diagnosis(r),
            "Data_Exch: the gateway accepts the parameters and the configuration");
}

// The diagnosis is the gateway's own, not a re-derivation: compare with a gateway driven by hand.
TEST(Validate, CfgFaultIsTheGatewaysDiagnosis) {
  GatewayInput in = make({{true, 9, {0x02, 0x89, 0x00}, 0}, {false, 1, {0x07, 0xF8, 0x00}, 0}});
  struct Discard final : can::FrameSink {
    void send(const can::Frame&) override {}
  } discard;
  gw::Gateway g({.address = 5}, discard, Time{0});
  ASSERT_TRUE(g.dp().set_prm(1, in.params.prm, Time{0}));
  ASSERT_FALSE(g.dp().chk_cfg(1, in.params.cfg, Time{0}));
  const auto expected = g.dp().slave_diag(Time{0});

  const GatewayReport r = check_gateway(std::move(in));
  EXPECT_FALSE(r.valid());
  EXPECT_EQ(r.diag, expected);
  // docs/slots.md "Chk_Cfg slots" code 3: 9 bytes without the Rx-Counter; diagnosis 3E, slot 0,
  // code 3.
  EXPECT_EQ(hex_bytes(r.diag), "0E 05 00 01 04 A4 05 04 3E 00 03");
  EXPECT_EQ(r.cfg_fault, (dp::CfgFault{0, 3}));
  ASSERT_EQ(r.slots.size(), 2u);
  EXPECT_EQ(r.slots[0].fault_code, 3);
  EXPECT_FALSE(r.slots[1].fault_code);
  EXPECT_FALSE(r.slots[0].slot);  // nothing accepted, nothing decoded
  EXPECT_EQ(explain_diagnosis(r),
            "Wait_Prm: Chk_Cfg rejected, slot 0 ($.gateways[0].slots[0]): code 3 = " +
                std::string(gw::cfg_code_text(3)) + " (docs/slots.md)");
}

TEST(Validate, PrmFaultLeavesChkCfgUnevaluated) {
  GatewayInput in = make(kManual);
  in.params.prm[gw::kPrmModuleId] = 0;  // docs/dp-slave.md "User parameters": ModuleID 1..127,
                                        // correct value 1
  const GatewayReport r = check_gateway(std::move(in));
  EXPECT_FALSE(r.prm_accepted);
  EXPECT_FALSE(r.cfg_accepted);
  EXPECT_FALSE(r.cfg_fault);
  EXPECT_EQ(r.prm_fault, (dp::PrmFault{10, 1}));
  EXPECT_EQ(hex_bytes(r.diag), "4A 05 00 FF 04 A4 05 04 3D 0A 01");
  EXPECT_EQ(r.slots.size(), 2u);  // the rows are still listed, as sent
  EXPECT_EQ(explain_diagnosis(r),
            "Wait_Prm: Set_Prm rejected at ModuleID (byte 10) = 0x00, a correct value is 0x01 "
            "(docs/dp-slave.md)");
}

TEST(Validate, PrmLengthAndNotSupported) {
  GatewayInput in = make(kManual);
  in.params.prm.pop_back();
  GatewayReport r = check_gateway(std::move(in));
  EXPECT_EQ(r.prm_fault, (dp::PrmFault{15, 0}));
  EXPECT_NE(explain_diagnosis(r).find("the telegram has 15 bytes, the gateway expects 16"),
            std::string::npos);

  in = make(kManual);
  in.params.prm[0] = dp::kPrmFreezeReq;  // docs/dp-slave.md: FREEZE not supported
  r = check_gateway(std::move(in));
  EXPECT_TRUE(r.not_supported);
  EXPECT_FALSE(r.prm_fault);
  EXPECT_EQ(r.diag[0] & dp::kDiag1NotSupported, dp::kDiag1NotSupported);
  EXPECT_NE(explain_diagnosis(r).find("Not_Supported"), std::string::npos);
}

// manual §5.2.1: the later of two input slots with one identifier wins; every earlier one is
// reported and names the winner.
TEST(Validate, DuplicateRxNamesTheSlotThatNeverReceives) {
  const GatewayReport r = check_gateway(make({{true, 1, {0x01, 0x81, 0x00}, 0},
                                              {true, 1, {0x01, 0x81, 0x00}, 1},
                                              {true, 1, {0x21, 0x00, 0x01, 0x81, 0x00}, 2},
                                              {true, 1, {0x01, 0x81, 0x00}, 3},
                                              {false, 1, {0x07, 0xF8, 0x00}, 0}}));
  ASSERT_TRUE(r.valid());
  ASSERT_EQ(kinds(r), (std::vector{WarningKind::DuplicateRx, WarningKind::DuplicateRx}));
  EXPECT_EQ(r.warnings[0].json_path, "$.gateways[0].slots[0]");
  EXPECT_NE(r.warnings[0].message.find("slot 0 never receives"), std::string::npos);
  EXPECT_NE(r.warnings[0].message.find("slot 3 ($.gateways[0].slots[3])"), std::string::npos);
  EXPECT_EQ(r.warnings[1].json_path, "$.gateways[0].slots[1]");  // slot 2 is 29-bit: different
}

TEST(Validate, DuplicateTxButNotTheDummy) {
  const GatewayReport r = check_gateway(make({{false, 1, {0x02, 0x01, 0x00}, 0},
                                              {false, 1, {0x07, 0xF8, 0x00}, 1},
                                              {false, 1, {0x07, 0xF8, 0x00}, 2},
                                              {false, 1, {0x02, 0x01, 0x00}, 3}}));
  ASSERT_TRUE(r.valid());
  ASSERT_EQ(kinds(r), (std::vector{WarningKind::DuplicateTx}));
  EXPECT_EQ(r.warnings[0].json_path, "$.gateways[0].slots[3]");
  EXPECT_NE(r.warnings[0].message.find("Tx identifier 0x201 is also sent by slot 0"),
            std::string::npos);
}

// docs/slots.md "Chk_Cfg slots": cycle bytes on an input are ignored; cycle 0 means none and is not
// reported.
TEST(Validate, CycleOnAnInputSlot) {
  const GatewayReport r = check_gateway(make({{true, 2, {0x01, 0x81, 0x00, 0x03, 0xE8}, 0},
                                              {true, 2, {0x01, 0x82, 0x00, 0x00, 0x00}, 2},
                                              {false, 2, {0x02, 0x01, 0x00, 0x03, 0xE8}, 0}}));
  ASSERT_TRUE(r.valid());
  ASSERT_EQ(kinds(r), (std::vector{WarningKind::InputCycle}));
  EXPECT_EQ(r.warnings[0].json_path, "$.gateways[0].slots[0]");
  EXPECT_NE(r.warnings[0].message.find("cycle 1000 ms"), std::string::npos);
  EXPECT_EQ(r.slots[2].slot->cycle_ms, 1000);  // the output's cycle is real
}

TEST(Validate, DpAddressClamping) {
  for (const auto& [configured, used] : {std::pair{1, 3}, {125, 124}, {3, 3}, {124, 124}}) {
    const GatewayReport r = check_gateway(make(kManual, {}, static_cast<std::uint8_t>(configured)));
    EXPECT_EQ(r.dp_address, used);
    EXPECT_EQ(r.warnings.size(), configured == used ? 0u : 1u) << configured;
    if (configured != used) {
      EXPECT_EQ(r.warnings[0].json_path, "$.gateways[0].address");
    }
  }
}

// docs/modbus.md: one PLC image for all gateways; overlaps within a direction only.
TEST(Validate, OverlapsAcrossGateways) {
  std::vector<GatewayReport> reports;
  reports.push_back(
      check_gateway(make({{true, 4, {0x01, 0x81, 0x00}, 10}, {false, 4, {0x02, 0x01, 0x00}, 10}})));
  GatewayInput second = make({{true, 2, {0x01, 0x82, 0x00}, 13},   // I 13..14 overlaps I 10..13
                              {false, 2, {0x02, 0x02, 0x00}, 14},  // Q 14..15: no overlap
                              {true, 1, {0x01, 0x83, 0x00}, 14}},  // I 14 overlaps I 13..14
                             {}, 6);
  second.json_path = "$.gateways[1]";
  for (auto& p : second.entry_paths) p.replace(0, 13, "$.gateways[1]");
  reports.push_back(check_gateway(std::move(second)));
  check_overlaps(reports);
  EXPECT_TRUE(reports[0].warnings.empty());
  ASSERT_EQ(kinds(reports[1]), (std::vector{WarningKind::Overlap, WarningKind::Overlap}));
  EXPECT_EQ(reports[1].warnings[0].json_path, "$.gateways[1].slots[0]");
  EXPECT_NE(
      reports[1].warnings[0].message.find("I 13..14 overlap I 10..13 of $.gateways[0].slots[0]"),
      std::string::npos)
      << reports[1].warnings[0].message;
  EXPECT_NE(reports[1].warnings[1].message.find("I 14 overlap I 13..14 of $.gateways[1].slots[0]"),
            std::string::npos)
      << reports[1].warnings[1].message;
}

TEST(Validate, ExitCodes) {
  Report ok;
  ok.gateways.push_back(check_gateway(make(kManual)));
  EXPECT_EQ(exit_code(ok, false), 0);
  EXPECT_EQ(exit_code(ok, true), 0);
  ok.gateways[0].warnings.push_back({WarningKind::Overlap, "$", "x"});
  EXPECT_EQ(exit_code(ok, false), 0);
  EXPECT_EQ(exit_code(ok, true), 1);  // --strict
  Report bad = ok;
  bad.gateways.push_back(check_gateway(make({{true, 1, {0x01, 0x81, 0x00}, 0}})));  // code 10
  EXPECT_EQ(bad.gateways[1].cfg_fault, (dp::CfgFault{0, 10}));
  EXPECT_EQ(exit_code(bad, false), 1);
}

TEST(Validate, ReportsInTextAndJsonAgree) {
  Report r;
  r.file = "x.json";
  r.gateways.push_back(check_gateway(make(kManual)));
  r.gateways.push_back(check_gateway(make({{true, 9, {0x02, 0x89, 0x00}, 0}})));
  const std::string text = format_text(r);
  EXPECT_NE(text.find("43 88 02 89 00  <- Cfg fault code 3"), std::string::npos) << text;
  EXPECT_NE(text.find("result: invalid (rejected by 1 of 2 gateways, 0 warnings)"),
            std::string::npos)
      << text;
  const auto j = to_json(r, exit_code(r, false));
  EXPECT_EQ(j["valid"], false);
  EXPECT_EQ(j["exit_code"], 1);
  EXPECT_EQ(j["gateways"][0]["slots"][0]["gateway"]["can_id"], "0x289");
  EXPECT_EQ(j["gateways"][1]["diagnosis"]["cfg_fault"]["code"], 3);
  EXPECT_EQ(j["gateways"][1]["diagnosis"]["bytes"], hex_bytes(r.gateways[1].diag));
}

TEST(Validate, NamesOfSetPrmBytes) {
  EXPECT_EQ(prm_byte_name(5), "Ident_Number low (byte 5)");
  EXPECT_EQ(prm_byte_name(9), "flags (byte 9)");
  EXPECT_EQ(prm_byte_name(15), "SYNC time low (byte 15)");
  EXPECT_EQ(prm_byte_name(16), "byte 16");
}

}  // namespace
}  // namespace candp2::validate

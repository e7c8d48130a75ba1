// candp2_validate: the report is the answer of a real gw::Gateway (Set_Prm, Chk_Cfg, Slave_Diag),
// plus the warnings of manual §2.1, §5.2.1 and docs/slots.md "Chk_Cfg slots", docs/modbus.md.
#include "validate/validate.hpp"

#include <gtest/gtest.h>

#include <map>

#include "can/frame_bits.hpp"
#include "common/hex.hpp"
#include "gateway/gateway.hpp"
#include "validate/buses.hpp"
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

// docs/validate.md "CAN buses": the messages come from the gateway's own slot table, analysed by
// can/response_time (Davis et al. 2007). Times in us; at 500 kbit/s a bit is 2 us. Worst-case
// frame lengths (docs/can-bus.md): 11-bit DLC 8 135 bits, DLC 6 115, DLC 3 85, DLC 2 75, DLC 0 55.

BusReport bus_of(const std::vector<GatewayInput>& gateways, std::uint32_t bitrate,
                 const std::vector<DriveInput>& drives = {}) {
  std::vector<GatewayReport> reports;
  for (auto in : gateways) {
    in.bus = "can0";
    reports.push_back(check_gateway(std::move(in)));
  }
  return check_bus(
      {.name = "can0", .json_path = "$.buses.can0.bitrate", .bitrate = bitrate, .cycle_ms = 10},
      reports, drives);
}

gw::UserPrm at_500k() {
  gw::UserPrm p;
  p.bitrate_index = 2;  // manual table 5.1.1: 500 kbit/s
  return p;
}

using std::chrono::microseconds;

// A Tx slot sends on change (every master cycle at worst) and every `cycle`: two messages of one
// identifier, each counted as the other's higher priority. 0x201 DLC 8 with cycle 20 ms (270 us),
// 0x300 DLC 2 (150 us); the input slot sends nothing.
//   load, at the longest real frames (can::frame_bits_longest: 0x201 DLC 8 132 bits = 264 us,
//   0x300 DLC 2 72 bits = 144 us): 264/10000 + 264/20000 + 144/10000 = 5.4 %.
//   0x201 (either): B = 150, hp = the other 0x201: w = 150 -> 150 + 270 = 420 -> 420, R = 690.
//   0x300: B = 0, w = 0 -> 270 + 270 = 540 -> 540, R = 540 + 150 = 690.
TEST(Buses, TxSlotsAtTheMasterCycleAndTheirOwnCycle) {
  const BusReport b = bus_of({make({{false, 8, {0x02, 0x01, 0x00, 0x00, 0x14}, 0},
                                    {false, 2, {0x03, 0x00, 0x00}, 8},
                                    {true, 6, {0x01, 0x81, 0x00}, 0}},
                                   at_500k())},
                             500'000);
  ASSERT_EQ(b.messages.size(), 3u);
  EXPECT_EQ(b.messages[0].source, BusSource::Outputs);
  EXPECT_EQ(b.messages[0].message.period, microseconds(10000));
  EXPECT_EQ(b.messages[0].json_path, "$.gateways[0].slots[0]");
  EXPECT_EQ(b.messages[1].source, BusSource::Cycle);
  EXPECT_EQ(b.messages[1].message.period, microseconds(20000));
  EXPECT_EQ(b.messages[2].message.id, (can::Ident{0x300, false}));
  EXPECT_EQ(b.messages[2].message.dlc, 2);
  EXPECT_NEAR(b.load_pct, 5.4, 1e-9);
  for (const auto& a : b.analysis.messages) EXPECT_EQ(a.response, microseconds(690));
  EXPECT_TRUE(b.problems.empty());
}

// The prediction's rules against the gateway itself: a real gw::Gateway run for one second of
// virtual time, its outputs changed at every Data_Exchange (every 10 ms), sends per identifier
// as many frames as the predicted messages of that identifier make in a second (once-only frames
// once), within one frame per message for the edges of the second (it sends 199 SYNCs of the
// predicted 200, 149 frames 0x201 of 150).
TEST(Buses, TheGatewaysOwnTrafficMatchesThePrediction) {
  gw::UserPrm p = at_500k();
  p.canopen_master = true;
  p.start_frame = true;
  p.sync_ms = 5;
  const GatewayInput in = make({{false, 8, {0x02, 0x01, 0x00, 0x00, 0x14}, 0},
                                {false, 2, {0x03, 0x00, 0x00}, 8},
                                {true, 6, {0x01, 0x81, 0x00}, 0}},
                               p);
  const BusReport b = bus_of({in}, 500'000);
  std::map<std::uint32_t, double> predicted;  // arbitration key -> frames in 1 s
  std::map<std::uint32_t, int> messages;
  for (const auto& m : b.messages) {
    const auto key = can::arbitration_key(m.message.id, m.message.remote);
    predicted[key] += m.once ? 1.0 : 1e9 / static_cast<double>(m.message.period.count());
    ++messages[key];
  }
  ASSERT_EQ(predicted.size(), 5u);  // 0x000 start, 0x080 SYNC, 0x181 remote, 0x201, 0x300
  ASSERT_EQ(b.messages.size(), 6u);

  struct Count final : can::FrameSink {
    std::map<std::uint32_t, int> frames;
    void send(const can::Frame& f) override { ++frames[can::arbitration_key(f)]; }
  } sink;
  Time now{0};
  gw::Gateway g({.address = in.address}, sink, now);
  ASSERT_TRUE(g.dp().set_prm(in.master_address, in.params.prm, now));
  ASSERT_TRUE(g.dp().chk_cfg(in.master_address, in.params.cfg, now));
  std::vector<std::uint8_t> outputs(10);
  for (int ms = 0; ms < 1000; ++ms) {
    now = Time{0} + milliseconds(ms);
    g.advance(now);
    if (ms % 10 == 0) {
      std::fill(outputs.begin(), outputs.end(), static_cast<std::uint8_t>(ms / 10));
      ASSERT_TRUE(g.dp().data_exchange(in.master_address, outputs, now).has_value());
    }
  }
  for (const auto& [key, n] : predicted)
    EXPECT_NEAR(sink.frames[key], n, messages[key]) << "arbitration key " << key;
  EXPECT_EQ(sink.frames.size(), predicted.size());
}

// A gateway whose Set_Prm bit rate is not the bus's sends nothing the others can receive.
TEST(Buses, AGatewayAtAnotherBitRateIsNotCounted) {
  const BusReport b = bus_of({make({{false, 8, {0x02, 0x01, 0x00}, 0}}, at_500k())}, 250'000);
  EXPECT_TRUE(b.messages.empty());
  EXPECT_EQ(b.load_pct, 0);
  ASSERT_EQ(b.problems.size(), 1u);
  EXPECT_EQ(b.problems[0].json_path, "$.gateways[0].parameters.can_bitrate");
  EXPECT_NE(b.problems[0].message.find("500 kbit/s"), std::string::npos) << b.problems[0].message;
}

// A drive answers each command frame its decoder takes (DLC 3 here; DLC 2 is no command,
// docs/drive-simulator.md) with one reply of DLC 6, released when the command has been received:
// jitter = the command's R - C.
//   0x201 DLC 3 (170 us): B = 150 (0x202), hp = the reply 0x181 (230 us):
//     w = 150 -> 150 + 230 = 380 -> 380, R = 550; so the reply's J = 550 - 170 = 380 (stable).
//   0x181: B = 170, no hp: w = 170, R = 380 + 170 + 230 = 780.
TEST(Buses, DriveRepliesFollowTheirCommands) {
  const BusReport b = bus_of(
      {make({{false, 3, {0x02, 0x01, 0x00}, 0}, {false, 2, {0x02, 0x02, 0x00}, 3}}, at_500k())},
      500'000,
      {{"axis1", "$.drives[0]", "can0", 0x201, 0x181},
       {"axis2", "$.drives[1]", "can0", 0x202, 0x182}});
  ASSERT_EQ(b.messages.size(), 3u);
  const BusMessage& reply = b.messages[2];
  EXPECT_EQ(reply.source, BusSource::Reply);
  EXPECT_EQ(reply.sender, "drive axis1");
  EXPECT_EQ(reply.message.id, (can::Ident{0x181, false}));
  EXPECT_EQ(reply.message.dlc, 6);
  EXPECT_EQ(reply.reply_to, 0u);
  EXPECT_EQ(b.analysis.messages[0].response, microseconds(550));
  EXPECT_EQ(reply.message.jitter, microseconds(380));
  EXPECT_EQ(b.analysis.messages[2].response, microseconds(780));
}

// A CANopen master adds its SYNC (released up to one Data_Exchange burst late, manual §5.3.3) and,
// once at the release, the start frame and one remote frame per Rx identifier (docs/canopen.md).
//   burst: 0x201 DLC 3 = 85 bits = 170 us: the SYNC's jitter. Load at the longest real frames:
//   0x201 DLC 3 83 bits = 166 us every 10 ms, SYNC its exact 51 bits (no data) = 102 us every
//   5 ms: 1.66 + 2.04 = 3.7 %.
TEST(Buses, CanopenMasterSyncAndReleaseFrames) {
  gw::UserPrm p = at_500k();
  p.canopen_master = true;
  p.start_frame = true;
  p.sync_ms = 5;
  const BusReport b = bus_of(
      {make({{false, 3, {0x02, 0x01, 0x00}, 0}, {true, 6, {0x01, 0x81, 0x00}, 0}}, p)}, 500'000);
  ASSERT_EQ(b.messages.size(), 4u);
  EXPECT_EQ(b.messages[1].source, BusSource::Sync);
  EXPECT_EQ(b.messages[1].message.id, (can::Ident{0x080, false}));
  EXPECT_EQ(b.messages[1].message.period, microseconds(5000));
  EXPECT_EQ(b.messages[1].message.jitter, microseconds(170));
  EXPECT_EQ(b.messages[2].source, BusSource::Start);
  EXPECT_TRUE(b.messages[2].once);
  EXPECT_EQ(b.messages[3].source, BusSource::Rtr);
  EXPECT_TRUE(b.messages[3].message.remote);
  EXPECT_EQ(b.messages[3].message.dlc, 6);
  EXPECT_EQ(b.messages[3].json_path, "$.gateways[0].slots[1]");
  EXPECT_NEAR(b.load_pct, 3.7, 1e-9);
}

// Nine 8-byte outputs every 10 ms at 125 kbit/s (1080 us each in the analysis): every frame still
// in time (the last after 9 x 1080 = 9720 us; the gateway's one FIFO queue puts each at the queue's
// lowest priority, so the first too). Their load at the longest real frames (0x101..0x108 132
// bits but 0x104 133, 0x109..0x10B 131; 8 us a bit): 1188 bits = 9504 us in 10 ms, 95.04 %, above
// the design limit. Eleven: 1450 bits = 11600 us, 116.0 %, overloaded; the queue's frames load the
// bus beyond 100 % at its level, so none of the eleven has a bound.
TEST(Buses, LoadAboveTheLimitAndOverload) {
  auto outputs = [](int n) {
    std::vector<Slot> s;
    for (int i = 0; i < n; ++i)
      s.push_back({false,
                   8,
                   {0x01, static_cast<std::uint8_t>(i + 1), 0x00},
                   static_cast<std::uint16_t>(8 * i)});
    return s;
  };
  const BusReport nine = bus_of({make(outputs(9))}, 125'000);
  EXPECT_NEAR(nine.load_pct, 95.04, 1e-9);
  EXPECT_EQ(nine.analysis.messages[8].response, microseconds(9720));
  ASSERT_EQ(nine.problems.size(), 1u);
  EXPECT_EQ(nine.problems[0].json_path, "$.buses.can0.bitrate");
  EXPECT_NE(nine.problems[0].message.find("design limit of 80 %"), std::string::npos);

  EXPECT_EQ(nine.analysis.messages[0].response, microseconds(9720));

  const BusReport eleven = bus_of({make(outputs(11))}, 125'000);
  ASSERT_EQ(eleven.problems.size(), 12u);
  EXPECT_NE(eleven.problems[0].message.find("overloaded"), std::string::npos);
  EXPECT_EQ(eleven.problems[1].json_path, "$.gateways[0].slots[0]");
  EXPECT_NE(eleven.problems[1].message.find("no worst-case response"), std::string::npos)
      << eleven.problems[1].message;
  EXPECT_FALSE(eleven.analysis.messages[0].response);
  EXPECT_FALSE(eleven.analysis.messages[10].response);

  // Counted as warnings, in the text and --json reports.
  Report r;
  r.file = "x.json";
  r.buses.push_back(eleven);
  EXPECT_EQ(r.warning_count(), 12u);
  EXPECT_EQ(exit_code(r, true), 1);
  EXPECT_NE(format_text(r).find("bus can0: 125000 bit/s, predicted load 116.0 %"),
            std::string::npos);
  const auto j = to_json(r, 0);
  EXPECT_EQ(j["buses"]["can0"]["load_pct"], 116.0);
  EXPECT_EQ(j["buses"]["can0"]["identifiers"][8]["response_us"], nullptr);
  EXPECT_EQ(j["buses"]["can0"]["identifiers"][10]["response_us"], nullptr);
}

TEST(Validate, NamesOfSetPrmBytes) {
  EXPECT_EQ(prm_byte_name(5), "Ident_Number low (byte 5)");
  EXPECT_EQ(prm_byte_name(9), "flags (byte 9)");
  EXPECT_EQ(prm_byte_name(15), "SYNC time low (byte 15)");
  EXPECT_EQ(prm_byte_name(16), "byte 16");
}

}  // namespace
}  // namespace candp2::validate

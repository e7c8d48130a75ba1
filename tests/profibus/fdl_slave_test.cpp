// The FDL slave front end (docs/profibus.md) with real gw::Gateway objects as the DP slaves:
// the capture in docs/profibus.md "A real master's first telegrams", the manual §5.1.4 round trip
// through FDL bytes, FCB repetition, DH, min_TSDR, the master address filter, broadcasts and
// several stations on one line.
#include "profibus_sim/fdl/fdl_slave.hpp"

#include <gtest/gtest.h>

#include "fdl_capture.hpp"
#include "fixture.hpp"

namespace candp2::fdl::test {
namespace {

using gw::test::F;
using gw::test::Recorder;

constexpr std::uint8_t kMaster = 2;

// Requests as an FDL master (address 2, SSAP 62) builds them (the table in docs/profibus.md).
std::vector<std::uint8_t> srd(std::uint8_t da, std::optional<std::uint8_t> dsap, bool fcb, bool fcv,
                              std::vector<std::uint8_t> du, std::uint8_t sa = kMaster) {
  const std::optional<std::uint8_t> ssap =
      dsap ? std::optional<std::uint8_t>(kSapChkCfg) : std::nullopt;
  if (!dsap && du.empty())
    return encode(Telegram::no_data(da, sa, request_fc(kFcSrdHigh, fcb, fcv)));
  return encode(
      Telegram::with_data(da, sa, request_fc(kFcSrdHigh, fcb, fcv), dsap, ssap, std::move(du)));
}

struct FdlSlaveFixture : ::testing::Test {
  FdlSlaveFixture() { rec.now = &now; }

  gw::Gateway& add_gateway(std::uint8_t address) {
    gateways.push_back(
        std::make_unique<gw::Gateway>(gw::GatewayOptions{.address = address}, rec, now));
    EXPECT_TRUE(fe->add(gateways.back()->dp()));
    return *gateways.back();
  }
  void make(SlaveFrontEndOptions o = {}) { fe = std::make_unique<SlaveFrontEnd>(o, &log); }

  // Feeds the bytes as one chunk; returns the reply's hex ("" when there is none).
  std::string send(const std::vector<std::uint8_t>& bytes) {
    last = fe->on_bytes(bytes, now);
    return last ? H(last->bytes) : std::string();
  }
  std::string send(const char* hex) { return send(B(hex)); }

  // The capture's parameterization of station 3 up to Data_Exch.
  void parameterize() {
    EXPECT_EQ(send(kCapFdlStatus), "10 02 03 00 05 16");
    EXPECT_NE(send(kCapSlaveDiag1), "");
    EXPECT_EQ(send(kCapSetPrm), "E5");
    EXPECT_EQ(send(kCapChkCfg), "E5");
    EXPECT_NE(send(kCapSlaveDiag2), "");
  }

  Time now{0};
  Recorder rec;
  MemoryLog log;
  std::unique_ptr<SlaveFrontEnd> fe = std::make_unique<SlaveFrontEnd>(SlaveFrontEndOptions{}, &log);
  std::vector<std::unique_ptr<gw::Gateway>> gateways;
  std::optional<Reply> last;
};

TEST_F(FdlSlaveFixture, CaptureParameterizesTheGatewayWithExactResponses) {
  auto& gw = add_gateway(3);
  // docs/profibus.md: FDL_Status -> SD1 FC 0x00 (slave, OK); cf. profirust's 10 02 22 00 24 16.
  EXPECT_EQ(send(kCapFdlStatus), "10 02 03 00 05 16");
  // Slave_Diag -> SD2, DSAP 62 / SSAP 60 swapped, FC DL; docs/dp-slave.md "Diagnosis" bytes in
  // Wait_Prm: Station_Not_Ready, Prm_Req + always-1, master FF, ident 04 A4, 05 04, 00 00 00.
  EXPECT_EQ(send(kCapSlaveDiag1),
            "68 10 10 68 82 83 08 3E 3C 02 05 00 FF 04 A4 05 04 00 00 00 3E 16");
  EXPECT_EQ(send(kCapSetPrm), "E5");  // docs/profibus.md: Set_Prm -> SC
  EXPECT_EQ(gw.dp().state(), dp::SlaveState::WaitCfg);
  EXPECT_EQ(send(kCapChkCfg), "E5");  // Chk_Cfg -> SC
  EXPECT_EQ(gw.dp().state(), dp::SlaveState::DataExch);
  // In Data_Exch, parameterized by master 2, WD on: 00 0C 00 02 ...
  EXPECT_EQ(send(kCapSlaveDiag2),
            "68 10 10 68 82 83 08 3E 3C 00 0C 00 02 04 A4 05 04 00 00 00 46 16");
  // Data_Exchange: 6 input bytes (still zero), FC DL (the diagnosis was just read).
  EXPECT_EQ(send(kCapDataExch1), "68 09 09 68 02 03 08 00 00 00 00 00 00 0D 16");
  EXPECT_EQ(rec.take().back(), "309#221166554433");  // form B8 (manual §5.1.4)
  EXPECT_EQ(send(kCapDataExch2), "68 09 09 68 02 03 08 00 00 00 00 00 00 0D 16");
  const auto* s = fe->stats(3);
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->requests, 7u);
  EXPECT_EQ(s->responses, 7u);
  EXPECT_EQ(s->repetitions, 0u);
}

TEST_F(FdlSlaveFixture, Manual514RoundTripThroughFdlBytes) {
  auto& gw = add_gateway(3);
  parameterize();
  // manual §5.1.4: PLC writes 0A..0F to Q 172 -> frame 309 with form B8 applied.
  send(srd(3, std::nullopt, true, true, B("0A 0B 0C 0D 0E 0F")));
  EXPECT_EQ(rec.take().back(), "309#0B0A0F0E0D0C");
  gw.on_can_frame(F("289#0B0A0F0E0D0C"), now);
  const auto rsp = decode(B(send(srd(3, std::nullopt, false, true, B("0A 0B 0C 0D 0E 0F")))));
  ASSERT_TRUE(rsp.telegram);
  EXPECT_EQ(rsp.telegram->function(), kFcDl);
  EXPECT_EQ(H(rsp.telegram->du), "0A 0B 0C 0D 0E 0F");
  // Rd_Inp / Rd_Outp (SAP 56/57) read the same images.
  EXPECT_EQ(H(decode(B(send(srd(3, kSapRdInp, true, true, {})))).telegram->du),
            "0A 0B 0C 0D 0E 0F");
  EXPECT_EQ(H(decode(B(send(srd(3, kSapRdOutp, false, true, {})))).telegram->du),
            "0A 0B 0C 0D 0E 0F");
  // Get_Cfg (SAP 59) returns the accepted Chk_Cfg bytes, SAPs swapped.
  const auto cfg = decode(B(send(srd(3, kSapGetCfg, true, true, {}))));
  EXPECT_EQ(H(cfg.telegram->du), "43 85 02 89 B8 83 85 03 09 B8");
  EXPECT_EQ(cfg.telegram->dsap, kSapChkCfg);
  EXPECT_EQ(cfg.telegram->ssap, kSapGetCfg);
}

TEST_F(FdlSlaveFixture, FcbRepetitionResendsTheLastResponseWithoutExecuting) {
  add_gateway(3);
  parameterize();
  const std::string first = send(srd(3, std::nullopt, true, true, B("01 02 03 04 05 06")));
  rec.take();
  // Same FCB with FCV=1: the master lost our answer. Different data proves nothing executes.
  EXPECT_EQ(send(srd(3, std::nullopt, true, true, B("AA BB CC DD EE FF"))), first);
  EXPECT_TRUE(rec.take().empty());
  EXPECT_EQ(fe->stats(3)->repetitions, 1u);
  // Toggled FCB: executes.
  send(srd(3, std::nullopt, false, true, B("AA BB CC DD EE FF")));
  EXPECT_EQ(rec.take().back(), "309#BBAAFFEEDDCC");
  EXPECT_EQ(fe->stats(3)->repetitions, 1u);
}

TEST_F(FdlSlaveFixture, FdlStatusRestartsTheFcbSequence) {
  add_gateway(3);
  parameterize();
  send(srd(3, std::nullopt, true, true, B("01 02 03 04 05 06")));
  rec.take();
  // The master restarts: FDL_Status, then FCB=1 FCV=0 again — executed, not a repetition.
  send(kCapFdlStatus);
  send(srd(3, std::nullopt, true, false, B("11 12 13 14 15 16")));
  EXPECT_EQ(rec.take().back(), "309#121116151413");
  EXPECT_EQ(fe->stats(3)->repetitions, 0u);
}

TEST_F(FdlSlaveFixture, DataExchangeBeforeParameterizationIsRs) {
  add_gateway(3);
  send(kCapFdlStatus);
  // pyprofibus dp_master.py / profirust peripheral.rs: RS ("SAP not enabled") makes the master
  // parameterize again. SD1 DA 2 SA 3 FC 0x03.
  EXPECT_EQ(send(srd(3, std::nullopt, true, false, B("01 02 03 04 05 06"))), "10 02 03 03 08 16");
  EXPECT_TRUE(log.contains("Data_Exchange in Wait_Prm: RS"));
}

TEST_F(FdlSlaveFixture, LockedStationIgnoresAnotherMastersSetPrm) {
  // docs/dp-slave.md "Lock": master 5's Set_Prm (Lock_Req, min_TSDR 0x40) is acknowledged but not
  // taken; its Slave_Diag shows master 2 in byte 3.
  auto& gw = add_gateway(3);
  parameterize();
  const auto tsdr = fe->min_tsdr_bits(3);
  auto prm = decode(B(kCapSetPrm)).telegram->du;
  prm[3] = 0x40;
  EXPECT_EQ(send(srd(3, kSapSetPrm, true, false, prm, 5)), "E5");
  EXPECT_EQ(gw.dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(fe->min_tsdr_bits(3), tsdr);
  EXPECT_EQ(H(decode(B(send(srd(3, kSapSlaveDiag, false, true, {}, 5)))).telegram->du),
            "00 0C 00 02 04 A4 05 04 00 00 00");
  // Master 2 goes on; its Lock_Req = Unlock_Req = 0 takes min_TSDR only.
  EXPECT_NE(send(srd(3, std::nullopt, true, true, B("01 02 03 04 05 06"))), "10 02 03 03 08 16");
  prm[0] = 0x00;
  EXPECT_EQ(send(srd(3, kSapSetPrm, false, true, prm)), "E5");
  EXPECT_EQ(fe->min_tsdr_bits(3), 0x40);
  EXPECT_EQ(gw.dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(gw.dp().watchdog_ms(), 300u);
}

TEST_F(FdlSlaveFixture, WrongOutputLengthIsRsAndLeavesDataExch) {
  // docs/dp-slave.md "Wrong output length": 5 bytes for 6 -> RS, Wait_Prm.
  auto& gw = add_gateway(3);
  parameterize();
  EXPECT_EQ(send(srd(3, std::nullopt, true, true, B("01 02 03 04 05"))), "10 02 03 03 08 16");
  EXPECT_EQ(gw.dp().state(), dp::SlaveState::WaitPrm);
  EXPECT_EQ(send(srd(3, std::nullopt, false, true, B("01 02 03 04 05 06"))), "10 02 03 03 08 16");
}

TEST_F(FdlSlaveFixture, UnsupportedSapsAreRs) {
  add_gateway(3);
  send(kCapFdlStatus);
  // Set_Slave_Add (SAP 55) is not supported (docs/dp-slave.md); SAP 20 is not a DP SAP.
  EXPECT_EQ(send(srd(3, kSapSetSlaveAdd, true, false, B("05 04 A4 00"))), "10 02 03 03 08 16");
  EXPECT_EQ(send(srd(3, 20, false, true, B("00"))), "10 02 03 03 08 16");
}

TEST_F(FdlSlaveFixture, DhWhileNewDiagnosisIsPending) {
  add_gateway(3);
  send(kCapFdlStatus);
  send(kCapSlaveDiag1);
  send(kCapSetPrm);
  send(kCapChkCfg);
  // No Slave_Diag after Chk_Cfg (FCB 1): the diagnosis changed since the master read it -> DH.
  auto r = decode(B(send(srd(3, std::nullopt, false, true, B("01 02 03 04 05 06")))));
  ASSERT_TRUE(r.telegram);
  EXPECT_EQ(r.telegram->function(), kFcDh);
  EXPECT_EQ(r.telegram->du.size(), 6u);  // the inputs travel with DH
  send(srd(3, kSapSlaveDiag, true, true, {}));
  r = decode(B(send(srd(3, std::nullopt, false, true, B("01 02 03 04 05 06")))));
  EXPECT_EQ(r.telegram->function(), kFcDl);
}

TEST_F(FdlSlaveFixture, DhWhenTheCanBusStateChanges) {
  auto& gw = add_gateway(3);
  send(kCapFdlStatus);
  send(kCapSlaveDiag1);
  // User bytes with CAN-Diagnosis on (byte 11 bit 0, docs/dp-slave.md "User parameters").
  auto prm = decode(B(kCapSetPrm)).telegram.value();
  prm.du[gw::kPrmDiagFlags] = gw::kDiagCanDiagnosis;
  prm.fc = request_fc(kFcSrdHigh, false, true);
  send(encode(prm));
  send(kCapChkCfg);
  send(kCapSlaveDiag2);
  EXPECT_EQ(decode(B(send(kCapDataExch1))).telegram->function(), kFcDl);
  gw.set_controller_status(can::BusState::ErrorPassive, 0);
  EXPECT_EQ(decode(B(send(kCapDataExch2))).telegram->function(), kFcDh);
  const auto diag = decode(B(send(kCapSlaveDiag1))).telegram->du;  // FCB 1 FCV 0: executes
  EXPECT_EQ(diag[8], 0x80);                                        // ERROR_PASSIVE
  EXPECT_EQ(decode(B(send(kCapDataExch2))).telegram->function(), kFcDl);
}

TEST_F(FdlSlaveFixture, EightInputBytesGoAsSd3AndNoInputsAsSc) {
  add_gateway(3);
  add_gateway(4);
  send(kCapFdlStatus);
  // Station 3: one 8-byte input slot + the 0x07F8 dummy output.
  const auto cfg8 =
      gw::test::cfg_of({gw::test::in_slot(8, {0x01, 0x00, 0x00}), gw::test::dummy_out()});
  auto prm = decode(B(kCapSetPrm)).telegram.value();
  send(encode(prm));
  send(srd(3, kSapChkCfg, true, true, cfg8));
  send(srd(3, kSapSlaveDiag, false, true, {}));
  const std::string r3 = send(srd(3, std::nullopt, true, true, B("00")));
  EXPECT_EQ(r3.substr(0, 2), "A2");  // SD3
  EXPECT_EQ(decode(B(r3)).telegram->du.size(), 8u);
  // Station 4: outputs only -> SC (docs/profibus.md), SD1 FC DH while diagnosis is pending.
  prm.da = 4;
  send(encode(Telegram::no_data(4, kMaster, request_fc(kFcFdlStatus))));
  prm.fc = request_fc(kFcSrdHigh, true, false);
  send(encode(prm));
  send(srd(4, kSapChkCfg, false, true, gw::test::cfg_of({gw::test::dummy_out()})));
  EXPECT_EQ(send(srd(4, std::nullopt, true, true, B("00"))), "10 02 04 0A 10 16");
  send(srd(4, kSapSlaveDiag, false, true, {}));
  EXPECT_EQ(send(srd(4, std::nullopt, true, true, B("00"))), "E5");
}

TEST_F(FdlSlaveFixture, SeveralStationsAndForeignAddresses) {
  auto& a = add_gateway(3);
  auto& b = add_gateway(4);
  EXPECT_FALSE(fe->add(b.dp()));  // address 4 already served
  EXPECT_EQ(fe->addresses(), (std::vector<std::uint8_t>{3, 4}));
  EXPECT_EQ(send("10 04 02 49 4F 16"), "10 02 04 00 06 16");
  EXPECT_EQ(send(kCapFdlStatus), "10 02 03 00 05 16");
  EXPECT_EQ(send("10 05 02 49 50 16"), "");  // station 5 is not served: silence
  send(kCapSetPrm);
  EXPECT_EQ(a.dp().state(), dp::SlaveState::WaitCfg);
  EXPECT_EQ(b.dp().state(), dp::SlaveState::WaitPrm);
  EXPECT_EQ(fe->stats(4)->requests, 1u);
  EXPECT_EQ(fe->stats(5), nullptr);
  // A hand-built telegram with an address beyond 127 (decode never yields one): no answer.
  EXPECT_FALSE(fe->on_telegram(Telegram::no_data(200, kMaster, request_fc(kFcFdlStatus)), now));
  EXPECT_FALSE(fe->on_telegram(Telegram::no_data(3, 200, request_fc(kFcFdlStatus)), now));
}

TEST_F(FdlSlaveFixture, BroadcastIsNeverAnswered) {
  add_gateway(3);
  parameterize();
  // Global_Control (SDN, DSAP 58) to 127, and an SRD to 127: no answer.
  EXPECT_EQ(send(encode(Telegram::with_data(kBroadcast, kMaster, request_fc(kFcSdnHigh),
                                            kSapGlobalControl, kSapChkCfg, B("08 00")))),
            "");
  EXPECT_EQ(send(encode(Telegram::no_data(kBroadcast, kMaster, request_fc(kFcFdlStatus)))), "");
  // Global_Control to the station itself (SDN): no answer either (docs/profibus.md).
  EXPECT_EQ(send(encode(Telegram::with_data(3, kMaster, request_fc(kFcSdnHigh), kSapGlobalControl,
                                            kSapChkCfg, B("08 00")))),
            "");
  EXPECT_EQ(fe->stats(3)->ignored, 1u);
}

TEST_F(FdlSlaveFixture, MasterAddressFilter) {
  SlaveFrontEndOptions o;
  o.master_address = 1;
  make(o);
  add_gateway(3);
  EXPECT_EQ(send(kCapFdlStatus), "");  // from master 2: ignored
  EXPECT_EQ(fe->stats(3)->ignored, 1u);
  EXPECT_EQ(send("10 03 01 49 4D 16"), "10 01 03 00 04 16");
}

TEST_F(FdlSlaveFixture, MinTsdrDelaysTheResponse) {
  add_gateway(3);
  now = milliseconds(5);
  send(kCapFdlStatus);
  ASSERT_TRUE(last);
  // docs/profibus.md: default 11 bit times; at 19200 bit/s 11 / 19200 s = 572.9 µs -> 573 µs.
  EXPECT_EQ(last->not_before, now + microseconds(573));
  EXPECT_EQ(last->station, 3);
  // Set_Prm byte 3 = 0x40: 64 bit times = 3333.3 µs -> 3334 µs, from the Set_Prm's SC on.
  auto prm = decode(B(kCapSetPrm)).telegram.value();
  prm.du[3] = 0x40;
  send(encode(prm));
  EXPECT_EQ(last->not_before, now + microseconds(3334));
  EXPECT_EQ(fe->min_tsdr_bits(3), 0x40);
  // 1.5 Mbit/s: 11 bit times = 7.33 µs -> 8 µs.
  SlaveFrontEndOptions fo;
  fo.baud = 1500000;
  SlaveFrontEnd fast(fo);
  EXPECT_EQ(fast.bit_times(11), microseconds(8));
}

TEST_F(FdlSlaveFixture, NoisyLineStillAnswersAndCountsErrors) {
  add_gateway(3);
  auto bytes = B("00 FF 68 09 0A 68");  // noise and a broken SD2 header
  const auto req = B(kCapFdlStatus);
  bytes.insert(bytes.end(), req.begin(), req.end());
  EXPECT_EQ(send(bytes), "10 02 03 00 05 16");
  // A wrong FCS: no answer (docs/profibus.md: the master retries).
  EXPECT_EQ(send("10 03 02 49 4F 16"), "");
  EXPECT_EQ(fe->line_stats().fcs_errors, 1u);
  EXPECT_GT(fe->line_stats().garbage_bytes, 0u);
  // One byte at a time: the answer comes with the ED.
  const auto diag = B(kCapSlaveDiag1);
  for (std::size_t i = 0; i + 1 < diag.size(); ++i) EXPECT_EQ(send(std::vector{diag[i]}), "");
  EXPECT_NE(send(std::vector{diag.back()}), "");
}

TEST_F(FdlSlaveFixture, DebugLogHasHexDumps) {
  add_gateway(3);
  send(kCapFdlStatus);
  EXPECT_TRUE(log.contains("station 3 master 2 request 10 03 02 49 4E 16"));
  EXPECT_TRUE(log.contains("station 3 master 2 response 10 02 03 00 05 16"));
}

}  // namespace
}  // namespace candp2::fdl::test

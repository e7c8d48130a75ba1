// The DP slave state machine and its diagnosis (docs/dp-slave.md; manual §3.4).
#include <gtest/gtest.h>

#include "fixture.hpp"

namespace candp2::gw::test {
namespace {

const std::vector<std::uint8_t> kCfg =
    cfg_of({in_slot(6, {0x02, 0x89, 0xB8}), out_slot(6, {0x03, 0x09, 0xB8})});

TEST_F(GatewayFixture, DiagnosisBeforeParameterization) {
  make({.address = 17});
  // docs/dp-slave.md "Diagnosis": 11 bytes; Station_Not_Ready, Prm_Req, bit 2 always 1, master FF,
  // 04 A4 05 04.
  EXPECT_EQ(hex(diag()), "02 05 00 FF 04 A4 05 04 00 00 00");
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  EXPECT_FALSE(gw->dp().get_cfg(now).has_value());
}

TEST_F(GatewayFixture, DiagnosisInWaitCfgAndDataExch) {
  make();
  gw->dp().set_prm(kMaster, make_set_prm(UserPrm{}, 100), now);
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitCfg);
  // Wait_Cfg: not ready, Prm_Req, WD_On; the parameterizing master in byte 3.
  EXPECT_EQ(hex(diag()), "02 0D 00 01 04 A4 05 04 00 00 00");
  gw->dp().chk_cfg(kMaster, kCfg, now);
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(hex(diag()), "00 0C 00 01 04 A4 05 04 00 00 00");
  EXPECT_EQ(hex(*gw->dp().get_cfg(now)), hex(kCfg));
}

TEST_F(GatewayFixture, AddressClampedToManualRange) {
  make({.address = 1});
  EXPECT_EQ(gw->address(), 3);  // manual §2.1
  make({.address = 126});
  EXPECT_EQ(gw->address(), 124);
}

TEST_F(GatewayFixture, DataExchangeRefusedBeforeDataExch) {
  make();
  std::vector<std::uint8_t> out(6);
  EXPECT_FALSE(gw->dp().data_exchange(kMaster, out, now).has_value());
}

TEST_F(GatewayFixture, WrongOutputLengthLeavesDataExch) {
  // docs/dp-slave.md "Wrong output length" (IEC 61158-6-3): no data, Wait_Prm, Prm_Req.
  ASSERT_TRUE(configure(UserPrm{}, kCfg, 100));
  std::vector<std::uint8_t> out(5);
  EXPECT_FALSE(gw->dp().data_exchange(kMaster, out, now).has_value());
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  EXPECT_EQ(hex(diag()), "02 05 00 01 04 A4 05 04 00 00 00");
  out.resize(6);
  EXPECT_FALSE(gw->dp().data_exchange(kMaster, out, now).has_value());  // parameterize first
  EXPECT_TRUE(configure(UserPrm{}, kCfg, 100));
  EXPECT_TRUE(gw->dp().data_exchange(kMaster, out, now).has_value());
}

TEST_F(GatewayFixture, LockedToTheParameterizingMaster) {
  // docs/dp-slave.md "Lock": another master's Set_Prm, even with Lock_Req, is ignored.
  ASSERT_TRUE(configure(UserPrm{}, kCfg, 100));
  const auto other = dp::with_lock_req(make_set_prm(UserPrm{}, 300));
  EXPECT_FALSE(gw->dp().set_prm(5, other, now));
  EXPECT_FALSE(gw->dp().chk_cfg(5, kCfg, now));
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(gw->dp().watchdog_ms(), 100u);
  EXPECT_EQ(hex(diag()), "00 0C 00 01 04 A4 05 04 00 00 00");  // the lock holder in byte 3
  EXPECT_TRUE(gw->dp().data_exchange(kMaster, std::vector<std::uint8_t>(6), now).has_value());
  EXPECT_FALSE(gw->dp().data_exchange(5, std::vector<std::uint8_t>(6), now).has_value());
  // Unlock_Req from the lock holder: Wait_Prm, no master; then the other master may lock it.
  auto unlock = make_set_prm(UserPrm{});
  unlock[0] = dp::kPrmUnlockReq;
  gw->dp().set_prm(kMaster, unlock, now);
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  EXPECT_EQ(diag()[3], dp::kNoMaster);
  EXPECT_TRUE(gw->dp().set_prm(5, other, now));
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitCfg);
  EXPECT_EQ(diag()[3], 5);
}

TEST_F(GatewayFixture, SetPrmWithoutLockReqKeepsStateAndWatchdog) {
  // docs/dp-slave.md "Lock": Lock_Req = Unlock_Req = 0 from the lock holder changes min_TSDR only.
  UserPrm p;
  p.module_id = 7;
  ASSERT_TRUE(configure(p, kCfg, 100));
  EXPECT_TRUE(gw->dp().set_prm(kMaster, make_set_prm(UserPrm{}), now));  // 00: WD off, ModuleID 1
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(gw->dp().watchdog_ms(), 100u);
  EXPECT_EQ(gw->user_prm()->module_id, 7);
  EXPECT_EQ(hex(diag()), "00 0C 00 01 04 A4 05 04 00 00 00");
  run_for(milliseconds(101));  // the watchdog still runs
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
}

TEST_F(GatewayFixture, ChkCfgFromAnotherMasterIgnored) {
  make();
  gw->dp().set_prm(kMaster, make_set_prm(UserPrm{}), now);
  EXPECT_FALSE(gw->dp().chk_cfg(2, kCfg, now));
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitCfg);
}

TEST_F(GatewayFixture, NewSetPrmInDataExchRequiresNewChkCfg) {
  ASSERT_TRUE(configure(UserPrm{}, kCfg));
  gw->dp().set_prm(kMaster, dp::with_lock_req(make_set_prm(UserPrm{})), now);
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitCfg);  // docs/dp-slave.md
}

TEST_F(GatewayFixture, CfgFaultClearedByGoodParameterization) {
  EXPECT_FALSE(configure(UserPrm{}, cfg_of({in_slot(2, {0x01, 0x23, 0x00})})));
  EXPECT_EQ(diag()[8], 0x3E);
  EXPECT_TRUE(configure(UserPrm{}, kCfg));
  EXPECT_EQ(hex(diag()), "00 04 00 01 04 A4 05 04 00 00 00");
}

TEST_F(GatewayFixture, WatchdogExpiryDropsToWaitPrmAndStopsTx) {
  // docs/dp-slave.md: with WD_On a gap longer than 10 ms x f1 x f2 drops the slave to Wait_Prm.
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({out_slot(1, {0x01, 0x00, 0x00, 0x00, 0x64})}), 50));
  EXPECT_EQ(gw->dp().watchdog_ms(), 50u);
  exchange({0x11});
  EXPECT_EQ(rec.take(), V({"100#11"}));
  rx("200#00");
  run_for(milliseconds(50));
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::DataExch);  // exactly 50 ms is not longer
  run_for(milliseconds(1));
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  EXPECT_EQ(diag()[1] & dp::kDiag2PrmReq, dp::kDiag2PrmReq);
  rec.take();
  run_for(milliseconds(500));  // the 100 ms cycle does not send while not in Data_Exch
  EXPECT_TRUE(rec.take().empty());
}

TEST_F(GatewayFixture, WatchdogOffNeverExpires) {
  ASSERT_TRUE(configure(UserPrm{}, kCfg, 0));
  run_for(seconds(100));
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::DataExch);
}

TEST_F(GatewayFixture, InputImageKeptAfterWatchdog) {
  ASSERT_TRUE(configure(UserPrm{}, kCfg, 20));
  rx("289#0102030405060000");
  auto in = exchange(std::vector<std::uint8_t>(6));
  run_for(milliseconds(30));
  ASSERT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  gw->dp().set_prm(kMaster, make_set_prm(UserPrm{}), now);
  // Re-parameterized with the same configuration: the slot buffers were kept until then.
  EXPECT_TRUE(gw->dp().chk_cfg(kMaster, kCfg, now));
}

TEST_F(GatewayFixture, GlobalControlIgnored) {
  ASSERT_TRUE(configure(UserPrm{}, kCfg));
  gw->dp().global_control(kMaster, 0x08, now);  // manual §2.6: not implemented
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::DataExch);
}

TEST_F(GatewayFixture, PowerCycleKeepsStoredValues) {
  UserPrm p;
  p.canopen_master = true;
  p.wakeup_s = 2;
  p.sync_ms = 100;
  ASSERT_TRUE(configure(p, kCfg));
  gw->power_cycle(now);
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  EXPECT_EQ(diag()[3], dp::kNoMaster);
  EXPECT_EQ(gw->stored_wakeup_s(), 2);
  EXPECT_EQ(gw->stored_sync_ms(), 100);
}

TEST_F(GatewayFixture, CanDiagnosisReportsBusStateAndLostCounters) {
  UserPrm p;
  p.can_diagnosis = true;
  ASSERT_TRUE(configure(p, kCfg));
  EXPECT_EQ(hex(diag()), "00 04 00 01 04 A4 05 04 00 00 00");
  struct Case {
    can::BusState state;
    std::uint8_t code;
  };
  // manual table 3.4.5: 00 OK, 40 WARN, 80 ERROR_PASSIVE, C0 BUS_OFF; Ext_Diag when not OK.
  for (auto c : {Case{can::BusState::Warning, 0x40}, Case{can::BusState::ErrorPassive, 0x80},
                 Case{can::BusState::BusOff, 0xC0}}) {
    gw->set_controller_status(c.state, 3);
    const auto d = diag();
    EXPECT_EQ(d[0], dp::kDiag1ExtDiag);
    EXPECT_EQ(d[8], c.code);
    EXPECT_EQ(d[9], 3);
  }
  gw->set_controller_status(can::BusState::Ok, 300);
  const auto d = diag();
  EXPECT_EQ(d[0], 0);
  EXPECT_EQ(d[9], 255);  // docs/dp-slave.md "Diagnosis": saturates at 255
}

TEST_F(GatewayFixture, WithoutCanDiagnosisBusStateIsNotReported) {
  ASSERT_TRUE(configure(UserPrm{}, kCfg));
  gw->set_controller_status(can::BusState::BusOff, 9);
  EXPECT_EQ(hex(diag()), "00 04 00 01 04 A4 05 04 00 00 00");
}

}  // namespace
}  // namespace candp2::gw::test

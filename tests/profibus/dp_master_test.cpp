// The simulated DP master (docs/modbus.md) against emulated gateways.
#include "profibus_sim/master/dp_master.hpp"

#include <gtest/gtest.h>

#include "fixture.hpp"

namespace candp2::gw::test {
namespace {

struct MasterFixture : ::testing::Test {
  MasterFixture() { rec.now = &now; }
  Time now{0};
  Recorder rec;
  MemoryLog log;
  dp::DpMaster master{{.address = 2, .retry_delay = milliseconds(100)}, &log};

  void cycle(int n = 1) {
    for (int i = 0; i < n; ++i) {
      master.cycle(now);
      now += milliseconds(10);
    }
  }
};

TEST_F(MasterFixture, ParameterizesAndExchangesManual514Slots) {
  Gateway gw({.address = 5}, rec, now);
  // manual §5.1.4: input at PLC I 172 (0x289), output at PLC Q 172 (0x309), form B8.
  const auto cfg = cfg_of({in_slot(6, {0x02, 0x89, 0xB8}), out_slot(6, {0x03, 0x09, 0xB8})});
  const auto prm = make_set_prm(UserPrm{}, 100);
  master.add_slave(gw.dp(), {{prm.begin(), prm.end()}, cfg, {{172, {}}, {{}, 172}}, "gw"});
  cycle(4);  // Init, Set_Prm, Chk_Cfg, Check_Diag + first Data_Exchange
  ASSERT_EQ(master.slave(5)->state, dp::MasterSlaveState::DataExch);
  EXPECT_EQ(gw.dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(gw.dp().slave_diag(now)[3], 2);  // parameterized by master 2
  auto& q = master.image().outputs;
  for (int i = 0; i < 6; ++i) q[172 + i] = static_cast<std::uint8_t>(0x0A + i);
  cycle();
  EXPECT_EQ(rec.take().back(), "309#0B0A0F0E0D0C");
  gw.on_can_frame(F("289#0B0A0F0E0D0C"), now);
  cycle();
  EXPECT_EQ(hex(std::span(master.image().inputs).subspan(172, 6)), "0A 0B 0C 0D 0E 0F");
  EXPECT_TRUE(log.contains("Check_Diag -> Data_Exch"));
}

TEST_F(MasterFixture, ReparameterizesWithLockReqAndIsLockedAgainstOthers) {
  // docs/dp-slave.md "Lock": the configured Set_Prm has no Lock_Req; the master sends it with
  // Lock_Req, so a re-parameterization in Data_Exch takes the gateway back through Wait_Cfg, and
  // another master cannot take the station over.
  Gateway gw({.address = 5}, rec, now);
  const auto cfg = cfg_of({in_slot(6, {0x02, 0x89, 0xB8}), out_slot(6, {0x03, 0x09, 0xB8})});
  const auto prm = make_set_prm(UserPrm{}, 100);
  ASSERT_EQ(prm[0] & dp::kPrmLockReq, 0);
  master.add_slave(gw.dp(), {{prm.begin(), prm.end()}, cfg, {{172, {}}, {{}, 172}}, "gw"});
  cycle(4);
  ASSERT_EQ(gw.dp().state(), dp::SlaveState::DataExch);
  EXPECT_FALSE(gw.dp().set_prm(9, dp::with_lock_req(prm), now));
  EXPECT_EQ(gw.dp().slave_diag(now)[3], 2);
  master.reparameterize(5, now);
  cycle(2);  // Init (Slave_Diag), Set_Prm
  EXPECT_EQ(gw.dp().state(), dp::SlaveState::WaitCfg);
  cycle(2);
  EXPECT_EQ(gw.dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(hex(dp::with_lock_req(std::vector<std::uint8_t>{0x48, 1})), "88 01");
}

TEST_F(MasterFixture, RetriesWhileTheSlaveReportsAFaultAndLogsTheDiagnosis) {
  Gateway gw({.address = 6}, rec, now);
  const auto bad = cfg_of({in_slot(2, {0x01, 0x23})});  // code 5 in slot 0... and no output
  const auto prm = make_set_prm(UserPrm{});
  master.add_slave(gw.dp(), {{prm.begin(), prm.end()}, bad, {}, "gw"});
  cycle(4);
  EXPECT_EQ(master.slave(6)->state, dp::MasterSlaveState::Retry);
  EXPECT_TRUE(log.contains("Cfg fault: slot 0, code 5"));
  const auto attempts = master.slave(6)->parameterizations;
  cycle(20);  // 200 ms with a 100 ms retry delay: parameterized again
  EXPECT_GT(master.slave(6)->parameterizations, attempts);
}

TEST_F(MasterFixture, WatchdogDropIsNoticedAndRecovered) {
  Gateway gw({.address = 7}, rec, now);
  const auto cfg = cfg_of({dummy_out()});
  const auto prm = make_set_prm(UserPrm{}, 20);
  master.add_slave(gw.dp(), {{prm.begin(), prm.end()}, cfg, {{{}, 0}}, "gw"});
  cycle(5);
  ASSERT_EQ(master.slave(7)->state, dp::MasterSlaveState::DataExch);
  now += milliseconds(50);  // the master stalls longer than the watchdog
  cycle();
  EXPECT_EQ(master.slave(7)->state, dp::MasterSlaveState::Retry);
  cycle(20);
  EXPECT_EQ(master.slave(7)->state, dp::MasterSlaveState::DataExch);
}

TEST_F(MasterFixture, OneImageSharedByTwoGatewaysLaterInputWins) {
  Gateway a({.address = 10}, rec, now), b({.address = 11}, rec, now);
  const auto prm = make_set_prm(UserPrm{});
  master.add_slave(a.dp(), {{prm.begin(), prm.end()},
                            cfg_of({in_slot(1, {0x01, 0x81, 0x00}), dummy_out()}),
                            {{0, {}}, {{}, 100}},
                            "a"});
  master.add_slave(b.dp(), {{prm.begin(), prm.end()},
                            cfg_of({in_slot(1, {0x01, 0x82, 0x00}), dummy_out()}),
                            {{0, {}}, {{}, 100}},
                            "b"});
  cycle(4);
  a.on_can_frame(F("181#11"), now);
  b.on_can_frame(F("182#22"), now);
  cycle();
  EXPECT_EQ(master.image().inputs[0], 0x22);  // docs/modbus.md: later slot's bytes win
}

TEST_F(MasterFixture, ReparameterizeOnRequest) {
  Gateway gw({.address = 8}, rec, now);
  const auto prm = make_set_prm(UserPrm{});
  master.add_slave(gw.dp(), {{prm.begin(), prm.end()}, cfg_of({dummy_out()}), {}, "gw"});
  cycle(4);
  const auto n = master.slave(8)->parameterizations;
  master.reparameterize(8, now);
  cycle(4);
  EXPECT_EQ(master.slave(8)->parameterizations, n + 1);
  EXPECT_EQ(master.slave(8)->state, dp::MasterSlaveState::DataExch);
}

TEST(DescribeDiag, Words) {
  const dp::DpSlave::Diag d = {0x02, 0x05, 0x00, 0xFF, 0x04, 0xA4, 0x05, 0x04, 0x00, 0x00, 0x00};
  EXPECT_EQ(dp::describe_diag(d), "Station_Not_Ready Prm_Req master=none ident=04A4 ext=00 00 00");
}

}  // namespace
}  // namespace candp2::gw::test

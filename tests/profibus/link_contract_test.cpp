// One contract for the DP master/slave behaviour over every link: the
// in-process link and FDL on a byte pipe (docs/modbus.md, docs/profibus.md). Each test runs on both
// rigs.
#include <gtest/gtest.h>

#include "fixture.hpp"
#include "link_rigs.hpp"

namespace candp2::dp::test {
namespace {

using gw::Gateway;
using gw::test::cfg_of;
using gw::test::dummy_out;
using gw::test::F;
using gw::test::hex;
using gw::test::in_slot;
using gw::test::out_slot;
using gw::test::Recorder;

template <typename Rig>
struct LinkContract : ::testing::Test {
  LinkContract() { rec.now = &now; }
  static constexpr Duration kCycle = milliseconds(10);

  Time now{0};
  Recorder rec;
  MemoryLog log;
  DpMaster master{{.address = 2, .retry_delay = milliseconds(100)}, &log};
  Rig rig;
  std::vector<std::unique_ptr<Gateway>> gateways;
  Time next_cycle{0};
  bool cycling = true;

  Gateway& gateway(std::uint8_t address, std::vector<std::uint8_t> cfg,
                   std::vector<EntryAddress> addresses = {}, std::uint16_t watchdog_ms = 100) {
    gateways.push_back(std::make_unique<Gateway>(gw::GatewayOptions{.address = address}, rec, now));
    const auto prm = gw::make_set_prm(gw::UserPrm{}, watchdog_ms);
    rig.add(master, gateways.back()->dp(),
            {{prm.begin(), prm.end()}, std::move(cfg), std::move(addresses), "gw"});
    return *gateways.back();
  }

  // Virtual time: master cycles every 10 ms, the gateways' timers, the rig's line events.
  void run_for(Duration d) {
    const Time until = now + d;
    for (int guard = 0; guard < 1'000'000; ++guard) {
      Time t = next_cycle;
      for (auto& g : gateways)
        if (auto gd = g->next_deadline()) t = std::min(t, *gd);
      if (auto rd = rig.next_deadline()) t = std::min(t, *rd);
      if (t > until) break;
      now = std::max(now, t);
      for (auto& g : gateways) g->advance(now);
      rig.advance(now);
      if (now >= next_cycle) {
        if (cycling) master.cycle(now);
        next_cycle += kCycle;
      }
    }
    now = until;
    for (auto& g : gateways) g->advance(now);
    rig.advance(now);
  }
  DpMaster::SlaveView view(std::uint8_t a) { return *master.slave(a); }
};

using Rigs = ::testing::Types<InProcessRig, FdlRig>;
struct RigName {
  template <typename T>
  static std::string GetName(int) {
    return T::kName == std::string("fdl") ? "Fdl" : "InProcess";
  }
};
TYPED_TEST_SUITE(LinkContract, Rigs, RigName);

// manual §5.1.4: input slot at PLC I 172 (CAN 0x289), output slot at PLC Q 172 (CAN 0x309).
std::vector<std::uint8_t> manual_514_cfg() {
  return cfg_of({in_slot(6, {0x02, 0x89, 0xB8}), out_slot(6, {0x03, 0x09, 0xB8})});
}

TYPED_TEST(LinkContract, ParameterizationReachesDataExch) {
  auto& g = this->gateway(3, manual_514_cfg(), {{172, {}}, {{}, 172}});
  this->run_for(milliseconds(100));
  EXPECT_EQ(this->view(3).state, MasterSlaveState::DataExch);
  EXPECT_EQ(g.dp().state(), SlaveState::DataExch);
  EXPECT_EQ(g.dp().slave_diag(this->now)[3], 2);  // parameterized by master 2
  EXPECT_EQ(this->view(3).parameterizations, 1u);
  EXPECT_GT(this->view(3).data_exchanges, 3u);
  EXPECT_TRUE(this->log.contains("Check_Diag -> Data_Exch"));
}

TYPED_TEST(LinkContract, Manual514RoundTrip) {
  auto& g = this->gateway(3, manual_514_cfg(), {{172, {}}, {{}, 172}});
  this->run_for(milliseconds(100));
  ASSERT_EQ(this->view(3).state, MasterSlaveState::DataExch);
  this->rec.take();
  auto& q = this->master.image().outputs;
  for (int i = 0; i < 6; ++i) q[172 + i] = static_cast<std::uint8_t>(0x0A + i);
  this->run_for(milliseconds(30));
  const auto frames = this->rec.take();
  ASSERT_FALSE(frames.empty());
  EXPECT_EQ(frames.front(), "309#0B0A0F0E0D0C");  // manual §5.1.4: byte order of form B8
  g.on_can_frame(F("289#0B0A0F0E0D0C"), this->now);
  this->run_for(milliseconds(30));
  EXPECT_EQ(hex(std::span(this->master.image().inputs).subspan(172, 6)), "0A 0B 0C 0D 0E 0F");
}

TYPED_TEST(LinkContract, CfgFaultShowsInTheMastersDiagnosisAndIsRetried) {
  this->gateway(4, cfg_of({in_slot(2, {0x01, 0x23})}));  // 2 comment bytes: code 5, no output
  this->run_for(milliseconds(60));
  const auto v = this->view(4);
  EXPECT_EQ(v.state, MasterSlaveState::Retry);
  ASSERT_TRUE(v.last_diag);
  EXPECT_TRUE((*v.last_diag)[0] & kDiag1CfgFault);
  EXPECT_EQ((*v.last_diag)[8], kExtDiagCfgSap);  // manual table 3.4.5: 3E = Chk_Cfg faulty
  EXPECT_EQ((*v.last_diag)[10], gw::kCfgFormatMissing);
  EXPECT_TRUE(this->log.contains("Cfg fault: slot 0"));
  this->run_for(milliseconds(300));  // retry_delay 100 ms: parameterized again
  EXPECT_GT(this->view(4).parameterizations, v.parameterizations);
}

TYPED_TEST(LinkContract, Reparameterization) {
  this->gateway(5, cfg_of({dummy_out()}));
  this->run_for(milliseconds(100));
  ASSERT_EQ(this->view(5).state, MasterSlaveState::DataExch);
  const auto n = this->view(5).parameterizations;
  this->master.reparameterize(5, this->now);
  this->run_for(milliseconds(100));
  EXPECT_EQ(this->view(5).parameterizations, n + 1);
  EXPECT_EQ(this->view(5).state, MasterSlaveState::DataExch);
}

TYPED_TEST(LinkContract, WatchdogExpiresWhenTheMasterStopsAndRecovers) {
  auto& g = this->gateway(6, cfg_of({dummy_out()}), {}, 50);
  this->run_for(milliseconds(100));
  ASSERT_EQ(g.dp().state(), SlaveState::DataExch);
  this->cycling = false;
  this->run_for(milliseconds(100));  // > 50 ms watchdog (docs/dp-slave.md)
  EXPECT_EQ(g.dp().state(), SlaveState::WaitPrm);
  this->cycling = true;
  this->run_for(milliseconds(30));
  EXPECT_TRUE(this->log.contains("Data_Exchange not answered"));
  this->run_for(milliseconds(300));
  EXPECT_EQ(this->view(6).state, MasterSlaveState::DataExch);
  EXPECT_EQ(g.dp().state(), SlaveState::DataExch);
}

TYPED_TEST(LinkContract, StationLostShowsNonExistentAndIsParameterizedWhenBack) {
  auto& g = this->gateway(7, cfg_of({dummy_out()}), {}, 0);
  this->run_for(milliseconds(100));
  ASSERT_EQ(this->view(7).state, MasterSlaveState::DataExch);
  const auto n = this->view(7).parameterizations;
  this->rig.pull_cable(7, true);
  this->run_for(milliseconds(100));
  auto v = this->view(7);
  EXPECT_EQ(v.state, MasterSlaveState::Init);
  ASSERT_TRUE(v.last_diag);
  EXPECT_EQ((*v.last_diag)[0], kDiag1StationNonExistent);  // manual table 3.4.3 bit 0
  EXPECT_EQ(v.station_lost, 1u);
  EXPECT_TRUE(this->log.contains("station lost"));
  g.dp().reset(this->now);  // it comes back after a power cycle
  this->rig.pull_cable(7, false);
  this->run_for(milliseconds(100));
  v = this->view(7);
  EXPECT_EQ(v.state, MasterSlaveState::DataExch);
  EXPECT_EQ(v.parameterizations, n + 1);
  EXPECT_FALSE((*v.last_diag)[0] & kDiag1StationNonExistent);
}

}  // namespace
}  // namespace candp2::dp::test

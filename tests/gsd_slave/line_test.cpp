// The DP master (profibus_sim/master) drives generic slaves from the project's GSD files
// (tests/gsd/data) beside a CAN-DP/2, over the in-process link and over FDL on a byte pipe (the
// rigs of tests/profibus/link_rigs.hpp: one contract, every link). The PLC-like line of
// docs/slaves.md: one CAN-DP/2 and two generic slaves in Data_Exch; one slave leaves the bus and
// the others go on.
#include <gtest/gtest.h>

#include "fixture.hpp"
#include "link_rigs.hpp"
#include "support.hpp"

namespace candp2::gsd_slave::test {
namespace {

using dp::MasterSlaveState;
using dp::test::FdlRig;
using dp::test::InProcessRig;

template <typename Rig>
struct Line : ::testing::Test {
  Line() { rec.now = &now; }
  static constexpr Duration kCycle = milliseconds(10);

  Time now{0};
  gw::test::Recorder rec;
  MemoryLog log;
  dp::DpMaster master{{.address = kMaster, .retry_delay = milliseconds(100)}, &log};
  Rig rig;
  std::vector<std::unique_ptr<gw::Gateway>> gateways;
  std::vector<std::unique_ptr<GsdSlave>> slaves;
  Time next_cycle{0};

  std::shared_ptr<const gsd::Model> starter = load("CP2MOTOR.GSD");
  std::shared_ptr<const gsd::Model> coupler = load("CP2COUPL.GSD");
  const std::vector<std::string> starter_mods = {"Starter Standard"};
  const std::vector<std::string> coupler_mods = {"4 Bytes Output consistent", "2 Bytes Input",
                                                 "1 Byte Output"};

  GsdSlave& slave(std::shared_ptr<const gsd::Model> m, std::uint8_t address,
                  const std::vector<std::string>& mods, dp::SlaveParameters p) {
    slaves.push_back(make_slave(std::move(m), address, mods, &log));
    rig.add(master, slaves.back()->dp(), std::move(p));
    return *slaves.back();
  }
  GsdSlave& starter_at(std::uint8_t address, std::uint16_t in, std::uint16_t out) {
    return slave(starter, address, starter_mods,
                 params(*starter, starter_mods, in, out, {.watchdog_ms = 100}));
  }
  GsdSlave& coupler_at(std::uint8_t address, std::uint16_t in, std::uint16_t out) {
    return slave(coupler, address, coupler_mods,
                 params(*coupler, coupler_mods, in, out, {.watchdog_ms = 100}));
  }
  gw::Gateway& gateway_at(std::uint8_t address) {
    gateways.push_back(
        std::make_unique<gw::Gateway>(gw::GatewayOptions{.address = address}, rec, now));
    const auto prm = gw::make_set_prm(gw::UserPrm{}, 100);
    rig.add(master, gateways.back()->dp(),
            {{prm.begin(), prm.end()}, gw::test::cfg_of({gw::test::dummy_out()}), {}, "gw"});
    return *gateways.back();
  }

  void run_for(Duration d) {
    const Time until = now + d;
    for (int guard = 0; guard < 1'000'000; ++guard) {
      Time t = next_cycle;
      for (auto& g : gateways)
        if (auto gd = g->next_deadline()) t = std::min(t, *gd);
      for (auto& s : slaves)
        if (auto sd = s->next_deadline()) t = std::min(t, *sd);
      if (auto rd = rig.next_deadline()) t = std::min(t, *rd);
      if (t > until) break;
      now = std::max(now, t);
      for (auto& g : gateways) g->advance(now);
      for (auto& s : slaves) s->advance(now);
      rig.advance(now);
      if (now >= next_cycle) {
        master.cycle(now);
        next_cycle += kCycle;
      }
    }
    now = until;
    rig.advance(now);
  }
  dp::DpMaster::SlaveView view(std::uint8_t a) { return *master.slave(a); }
};

using Rigs = ::testing::Types<InProcessRig, FdlRig>;
struct RigName {
  template <typename T>
  static std::string GetName(int) {
    return T::kName == std::string("fdl") ? "Fdl" : "InProcess";
  }
};
TYPED_TEST_SUITE(Line, Rigs, RigName);

TYPED_TEST(Line, GenericSlavesReachDataExchangeAndCarryFieldData) {
  auto& a = this->starter_at(8, 100, 100);  // I 100..103, Q 100..103
  auto& b = this->coupler_at(9, 200, 200);  // Q 200..203 + 204, I 200..201
  this->run_for(milliseconds(100));
  ASSERT_EQ(this->view(8).state, MasterSlaveState::DataExch);
  ASSERT_EQ(this->view(9).state, MasterSlaveState::DataExch);
  EXPECT_EQ(hex(this->view(8).diag_bytes), "00 0C 00 02 0C 31");
  EXPECT_EQ(hex(this->view(9).diag_bytes), "00 0C 00 02 0C 70");
  auto& q = this->master.image().outputs;
  for (int i = 0; i < 4; ++i) q[100 + i] = static_cast<std::uint8_t>(0x10 + i);
  for (int i = 0; i < 5; ++i) q[200 + i] = static_cast<std::uint8_t>(0x20 + i);
  a.write_inputs(0, std::vector<std::uint8_t>{0xA0, 0xA1, 0xA2, 0xA3});
  b.write_inputs(0, std::vector<std::uint8_t>{0xB0, 0xB1});
  this->run_for(milliseconds(30));
  EXPECT_EQ(hex(a.field_outputs()), "10 11 12 13");
  EXPECT_EQ(hex(b.field_outputs()), "20 21 22 23 24");
  const auto& i = this->master.image().inputs;
  EXPECT_EQ(hex(std::span(i).subspan(100, 4)), "A0 A1 A2 A3");
  EXPECT_EQ(hex(std::span(i).subspan(200, 2)), "B0 B1");
}

TYPED_TEST(Line, PlcLikeLineOneSlaveLeavesTheOthersGoOn) {
  auto& g = this->gateway_at(3);
  auto& a = this->starter_at(8, 100, 100);
  auto& b = this->coupler_at(9, 200, 200);
  this->run_for(milliseconds(100));
  for (std::uint8_t addr : {3, 8, 9}) ASSERT_EQ(this->view(addr).state, MasterSlaveState::DataExch);
  a.set_online(false);  // the motor starter leaves the bus
  const auto gw_before = this->view(3).data_exchanges, b_before = this->view(9).data_exchanges;
  this->run_for(milliseconds(300));
  const auto v = this->view(8);
  EXPECT_NE(v.state, MasterSlaveState::DataExch);
  EXPECT_EQ(v.diag_bytes.at(0), dp::kDiag1StationNonExistent);
  EXPECT_EQ(v.station_lost, 1u);
  EXPECT_EQ(a.dp().state(), dp::SlaveState::WaitPrm);  // its watchdog (100 ms) expired
  EXPECT_EQ(this->view(3).state, MasterSlaveState::DataExch);
  EXPECT_EQ(this->view(9).state, MasterSlaveState::DataExch);
  EXPECT_GT(this->view(3).data_exchanges, gw_before + 20);
  EXPECT_GT(this->view(9).data_exchanges, b_before + 20);
  EXPECT_EQ(g.dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(b.dp().state(), dp::SlaveState::DataExch);
  a.set_online(true);  // back: the master parameterizes it again
  this->run_for(milliseconds(200));
  EXPECT_EQ(this->view(8).state, MasterSlaveState::DataExch);
  EXPECT_EQ(a.dp().state(), dp::SlaveState::DataExch);
}

TYPED_TEST(Line, ItsOwnModuleListDiffersCfgFaultAndRetry) {
  // The master configures the coupler with one module less than the slave has.
  auto p = params(*this->coupler, {"4 Bytes Output consistent", "2 Bytes Input"}, 200, 200);
  auto& s = this->slave(this->coupler, 9, this->coupler_mods, std::move(p));
  this->run_for(milliseconds(60));
  const auto v = this->view(9);
  EXPECT_EQ(v.state, MasterSlaveState::Retry);
  EXPECT_EQ(v.diag_bytes.at(0), dp::kDiag1CfgFault | dp::kDiag1StationNotReady);
  EXPECT_EQ(s.cfg_problem(), "Chk_Cfg entry 2: missing, the slave has 20 (output 1 byte)");
  this->run_for(milliseconds(300));
  EXPECT_GT(this->view(9).parameterizations, v.parameterizations);
}

TYPED_TEST(Line, ParameterOutOfRangePrmFault) {
  auto p = params(*this->starter, this->starter_mods, 100, 100);
  p.prm[16] = 40;  // "Class" 5-30
  auto& s = this->slave(this->starter, 8, this->starter_mods, std::move(p));
  this->run_for(milliseconds(60));
  EXPECT_EQ(this->view(8).state, MasterSlaveState::Retry);
  EXPECT_EQ(this->view(8).diag_bytes.at(0), dp::kDiag1PrmFault | dp::kDiag1StationNotReady);
  EXPECT_NE(s.prm_problem().find("\"Class\""), std::string::npos);
  EXPECT_TRUE(
      this->log.contains("slave not ready after parameterization: Station_Not_Ready "
                         "Prm_Fault Prm_Req master=none ident=0C31"));
}

TYPED_TEST(Line, ForcedFaultsTakeTheSlaveOutAndBack) {
  auto& s = this->starter_at(8, 100, 100);
  this->run_for(milliseconds(100));
  ASSERT_EQ(this->view(8).state, MasterSlaveState::DataExch);
  s.force_cfg_fault(true, this->now);
  this->run_for(milliseconds(50));
  EXPECT_NE(this->view(8).state, MasterSlaveState::DataExch);
  EXPECT_TRUE(this->view(8).diag_bytes.at(0) & dp::kDiag1CfgFault);
  s.force_cfg_fault(false, this->now);
  this->run_for(milliseconds(300));
  EXPECT_EQ(this->view(8).state, MasterSlaveState::DataExch);
}

// Over FDL a new diagnosis during Data_Exch is announced with DH and read by the master.
using LineFdl = Line<FdlRig>;
TEST_F(LineFdl, DiagnosisAlarmReachesTheMaster) {
  auto& s = starter_at(8, 100, 100);
  run_for(milliseconds(100));
  ASSERT_EQ(view(8).state, MasterSlaveState::DataExch);
  s.set_device_diag({0x42});
  run_for(milliseconds(50));
  EXPECT_EQ(hex(view(8).diag_bytes), "08 0C 00 02 0C 31 02 42");
  EXPECT_TRUE(log.contains("Ext_Diag WD_On master=2 ident=0C31 ext=02 42"));
  EXPECT_EQ(view(8).state, MasterSlaveState::DataExch);  // Ext_Diag is not "not ready"
}

}  // namespace
}  // namespace candp2::gsd_slave::test

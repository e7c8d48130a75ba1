// Generic slaves behind the FDL slave front end (profibus_sim/fdl/fdl_slave.hpp): Set_Slave_Add
// moves a station that supports it (CP2DPV1.GSD, the motor manager, Set_Slave_Add_supp = 1) to its
// new address, a station off the bus answers nothing, a diagnosis longer than 11 bytes goes out
// whole. docs/slaves.md.
#include <gtest/gtest.h>

#include "profibus_sim/fdl/fdl_slave.hpp"
#include "support.hpp"

namespace candp2::gsd_slave::test {
namespace {

using namespace fdl;

std::optional<Reply> srd(SlaveFrontEnd& fe, std::uint8_t da, std::optional<std::uint8_t> dsap,
                         std::vector<std::uint8_t> du, Time now) {
  const auto ssap = dsap ? std::optional<std::uint8_t>(kSapChkCfg) : std::nullopt;
  return fe.on_telegram(
      Telegram::with_data(da, kMaster, request_fc(kFcSrdHigh, true, false), dsap, ssap, du), now);
}

TEST(GenericSlaveFdl, SetSlaveAddMovesTheStation) {
  MemoryLog log;
  SlaveFrontEnd fe(SlaveFrontEndOptions{}, &log);
  auto manager = make_slave(load("CP2DPV1.GSD"), 126, {"Manager Standard"}, &log);
  auto starter = make_slave(load("CP2MOTOR.GSD"), 20, {"Starter Standard"}, &log);
  ASSERT_TRUE(fe.add(manager->dp()));
  ASSERT_TRUE(fe.add(starter->dp()));
  const Time now{0};
  // Address 20 is taken by the motor starter: RS, nothing moves.
  auto r = srd(fe, 126, kSapSetSlaveAdd, {20, 0x0C, 0xFD, 0}, now);
  ASSERT_TRUE(r);
  EXPECT_EQ(decode(r->bytes).telegram->function(), kFcRs);
  r = srd(fe, 126, kSapSetSlaveAdd, {21, 0x0C, 0xFD, 0}, now);
  ASSERT_TRUE(r);
  EXPECT_EQ(hex(r->bytes), "E5");  // SC
  EXPECT_EQ(fe.addresses(), (std::vector<std::uint8_t>{20, 21}));
  EXPECT_FALSE(srd(fe, 126, kSapSlaveDiag, {}, now));  // nobody at 126 any more
  r = srd(fe, 21, kSapSlaveDiag, {}, now);
  ASSERT_TRUE(r);
  EXPECT_EQ(hex(decode(r->bytes).telegram->du), "02 05 00 FF 0C FD");
  // The motor starter has Set_Slave_Add_supp = 0: RS, as the CAN-DP/2.
  r = srd(fe, 20, kSapSetSlaveAdd, {22, 0x0C, 0x31, 0}, now);
  ASSERT_TRUE(r);
  EXPECT_EQ(decode(r->bytes).telegram->function(), kFcRs);
  EXPECT_EQ(starter->address(), 20);
}

TEST(GenericSlaveFdl, OffTheBusNothingIsAnswered) {
  MemoryLog log;
  SlaveFrontEnd fe(SlaveFrontEndOptions{}, &log);
  auto s = make_slave(load("CP2MOTOR.GSD"), 8, {"Starter Standard"}, &log);
  ASSERT_TRUE(fe.add(s->dp()));
  EXPECT_TRUE(srd(fe, 8, kSapSlaveDiag, {}, Time{0}));
  s->set_online(false);
  EXPECT_FALSE(srd(fe, 8, kSapSlaveDiag, {}, Time{0}));
  EXPECT_EQ(fe.stats(8)->ignored, 1u);
  s->set_online(true);
  EXPECT_TRUE(srd(fe, 8, kSapSlaveDiag, {}, Time{0}));
}

TEST(GenericSlaveFdl, LongDiagnosisGoesOutWhole) {
  MemoryLog log;
  SlaveFrontEnd fe(SlaveFrontEndOptions{}, &log);
  auto s = make_slave(load("CP2MOTOR.GSD"), 8, {"Starter Standard"}, &log);
  ASSERT_TRUE(fe.add(s->dp()));
  s->set_device_diag({1, 2, 3, 4, 5, 6, 7, 8});
  const auto r = srd(fe, 8, kSapSlaveDiag, {}, Time{0});
  ASSERT_TRUE(r);
  EXPECT_EQ(hex(decode(r->bytes).telegram->du), "0A 05 00 FF 0C 31 09 01 02 03 04 05 06 07 08");
}

}  // namespace
}  // namespace candp2::gsd_slave::test

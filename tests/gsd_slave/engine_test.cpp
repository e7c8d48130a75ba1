// gsd_slave::GsdSlave driven directly through its DP services, with the project's own GSD files
// (tests/gsd/data/README.md): the motor starter (CP2MOTOR.GSD: user parameters with bit areas and
// ranges, no Sync/Freeze, Fail_Safe), the DP/DP coupler (CP2COUPL.GSD: modular, Sync/Freeze
// supported), the motor manager (CP2DPV1.GSD: DP-V1, DPV1_Status bytes, Set_Slave_Add) and the
// compact I/O station (CP2CIO8.GSD). docs/slaves.md.
#include <gtest/gtest.h>

#include "common/log.hpp"
#include "support.hpp"

namespace candp2::gsd_slave::test {
namespace {

using dp::SlaveState;

struct Engine : ::testing::Test {
  Time now{0};
  MemoryLog log;

  // Set_Prm + Chk_Cfg from kMaster; true when the slave reached Data_Exch.
  static bool parameterize(GsdSlave& s, const std::vector<std::uint8_t>& prm,
                           const std::vector<std::uint8_t>& cfg, Time t) {
    s.dp().set_prm(kMaster, prm, t);
    s.dp().chk_cfg(kMaster, cfg, t);
    return s.dp().state() == SlaveState::DataExch;
  }
  static std::vector<std::uint8_t> exchange(GsdSlave& s, std::vector<std::uint8_t> out, Time t) {
    auto in = s.dp().data_exchange(kMaster, out, t);
    EXPECT_TRUE(in) << "Data_Exchange refused";
    return in ? std::vector<std::uint8_t>(in->begin(), in->end()) : std::vector<std::uint8_t>{};
  }
};

// ------------------------------------------------------------- motor starter (CP2MOTOR)

struct Starter : Engine {
  std::shared_ptr<const gsd::Model> m = load("CP2MOTOR.GSD");
  const std::vector<std::string> standard = {"Starter Standard"};  // 4 input, 4 output bytes
  std::unique_ptr<GsdSlave> s = make_slave(m, 8, standard, &log);
  std::vector<std::uint8_t> prm = set_prm(*m, standard, {.watchdog_ms = 100});
  std::vector<std::uint8_t> cfg = chk_cfg(*m, standard);
};

TEST_F(Starter, ProfileFromTheGsd) {
  const Profile& p = s->profile();
  EXPECT_EQ(p.ident_number, 0x0C31);
  EXPECT_FALSE(p.sync);
  EXPECT_FALSE(p.freeze);
  EXPECT_TRUE(p.fail_safe);
  EXPECT_TRUE(p.modular);
  EXPECT_EQ(p.max_module, 1u);
  EXPECT_EQ(p.max_user_prm_len, 24u);
  EXPECT_EQ(p.max_diag_len, 20u);
  EXPECT_EQ(hex(s->configuration().bytes), "10 10 91 20 20 20 20");
  EXPECT_EQ(s->input_length(), 4u);
  EXPECT_EQ(s->output_length(), 4u);
  EXPECT_EQ(s->user_prm_layout().defaults.size(), 24u);
  EXPECT_EQ(prm.size(), 7u + 24u);
  EXPECT_EQ(hex(std::span(prm).first(7)), "88 0A 01 00 0C 31 00");  // Lock_Req + WD_On, 100 ms
}

TEST_F(Starter, DefaultsReachDataExchangeWithSixDiagnosisBytes) {
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "02 05 00 FF 0C 31");  // Not_Ready, Prm_Req, no master
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "00 0C 00 02 0C 31");  // WD_On, master 2
  EXPECT_EQ(s->dp().watchdog_ms(), 100u);
  ASSERT_TRUE(s->write_inputs(0, std::vector<std::uint8_t>{0xA1, 0xA2, 0xA3, 0xA4}));
  EXPECT_EQ(hex(exchange(*s, {1, 2, 3, 4}, now)), "A1 A2 A3 A4");
  EXPECT_EQ(hex(s->field_outputs()), "01 02 03 04");
  EXPECT_FALSE(s->write_inputs(3, std::vector<std::uint8_t>{1, 2}));  // beyond the 4 inputs
  // Wrong output length: no data (RS on the wire).
  EXPECT_FALSE(s->dp().data_exchange(kMaster, std::vector<std::uint8_t>{1, 2}, now));
}

TEST_F(Starter, BitAreaOutsideItsRangeIsPrmFault) {
  // "Thermistor Type" = BitArea(2-4) of user byte 3 (telegram byte 10), range 0-4.
  auto bad = prm;
  bad[10] = static_cast<std::uint8_t>((bad[10] & ~0x1C) | (5 << 2));
  EXPECT_FALSE(s->dp().set_prm(kMaster, bad, now));
  EXPECT_EQ(s->dp().state(), SlaveState::WaitPrm);
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "42 05 00 FF 0C 31");  // Prm_Fault, Not_Ready, Prm_Req
  EXPECT_NE(s->prm_problem().find("\"Thermistor Type\" (byte 10) = 5: outside the range 0-4"),
            std::string::npos)
      << s->prm_problem();
  // 4 is in range: the same bits, another value, accepted.
  bad[10] = static_cast<std::uint8_t>((bad[10] & ~0x1C) | (4 << 2));
  EXPECT_TRUE(s->dp().set_prm(kMaster, bad, now));
  EXPECT_EQ(s->dp().diagnosis(now)[0] & dp::kDiag1PrmFault, 0);
}

TEST_F(Starter, NamedOverridesThroughThePrmTexts) {
  const auto p =
      set_prm(*m, standard, {},
              {{"Thermistor Type", std::string("PTC Binary")}, {"Class", std::int64_t{20}}});
  EXPECT_EQ((p[10] >> 2) & 7, 1);  // PrmText 2: PTC Binary = 1
  EXPECT_EQ(p[16], 20);            // "Class" Unsigned8 at user byte 9
  EXPECT_TRUE(s->dp().set_prm(kMaster, p, now));
  const std::vector<gsd::PrmOverride> no_such = {{"No Such", std::int64_t{1}}};
  const auto unknown = encode_user_prm(*m, modules(*m, standard), no_such);
  ASSERT_EQ(unknown.errors.size(), 1u);
  EXPECT_EQ(unknown.errors[0], "\"No Such\": no such parameter (ExtUserPrmData name)");
}

TEST_F(Starter, UnsignedOutsideItsRangeAndWrongLengthsArePrmFaults) {
  auto bad = prm;
  bad[16] = 40;  // "Class" 5-30
  EXPECT_FALSE(s->dp().set_prm(kMaster, bad, now));
  EXPECT_NE(s->prm_problem().find("\"Class\" (byte 16) = 40: outside the range 5-30"),
            std::string::npos)
      << s->prm_problem();
  EXPECT_EQ(s->dp().prm_fault()->byte, 16);
  EXPECT_EQ(s->dp().prm_fault()->correct, 10);  // the GSD default

  auto longer = prm;
  longer.push_back(0);
  EXPECT_FALSE(s->dp().set_prm(kMaster, longer, now));
  EXPECT_EQ(s->prm_problem(), "25 user parameter bytes, Max_User_Prm_Data_Len is 24");
  auto shorter = prm;
  shorter.pop_back();
  EXPECT_FALSE(s->dp().set_prm(kMaster, shorter, now));
  EXPECT_EQ(s->prm_problem(), "23 user parameter bytes, the GSD defines 24");
  EXPECT_FALSE(s->dp().set_prm(kMaster, std::vector<std::uint8_t>{0x80, 1, 1}, now));
}

TEST_F(Starter, WrongIdentAndZeroWatchdogFactorArePrmFaults) {
  auto bad = prm;
  bad[5] = 0x32;
  EXPECT_FALSE(s->dp().set_prm(kMaster, bad, now));
  EXPECT_EQ(s->dp().prm_fault(), (dp::PrmFault{5, 0x31}));
  bad = prm;
  bad[1] = 0;  // WD_On with WD_Fact_1 = 0
  EXPECT_FALSE(s->dp().set_prm(kMaster, bad, now));
  EXPECT_EQ(s->dp().prm_fault(), (dp::PrmFault{1, 1}));
}

TEST_F(Starter, SyncAndFreezeRequestsAreNotSupported) {
  for (const StdPrmRequest r : {StdPrmRequest{.sync = true}, StdPrmRequest{.freeze = true}}) {
    EXPECT_FALSE(s->dp().set_prm(kMaster, set_prm(*m, standard, r), now));
    // Station_Not_Ready + Not_Supported, no Prm_Fault (docs/dp-slave.md's rule, docs/slaves.md).
    EXPECT_EQ(hex(s->dp().diagnosis(now)), "12 05 00 FF 0C 31");
  }
}

TEST_F(Starter, AnotherModuleIsCfgFaultAndGetCfgAnswersTheSlavesOwn) {
  EXPECT_EQ(hex(*s->dp().get_cfg(now)), "10 10 91 20 20 20 20");  // before any parameterization
  EXPECT_FALSE(parameterize(*s, prm, chk_cfg(*m, {"Starter Basic"}), now));
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "06 05 00 02 0C 31");  // Cfg_Fault, back to Wait_Prm
  EXPECT_EQ(s->cfg_problem(),
            "Chk_Cfg entry 3: 92 (input 3 bytes consistent), the slave has 20 (output 1 byte)");
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));  // a new Set_Prm forgets the fault
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "00 0C 00 02 0C 31");
}

TEST_F(Starter, FailSafeTelegramWithoutOutputsGoesToTheSafeState) {
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  exchange(*s, {9, 8, 7, 6}, now);
  EXPECT_EQ(hex(s->field_outputs()), "09 08 07 06");
  ASSERT_TRUE(s->dp().data_exchange(kMaster, {}, now));  // Fail_Safe = 1: accepted
  EXPECT_EQ(hex(s->field_outputs()), "00 00 00 00");
  EXPECT_EQ(hex(s->received_outputs()), "09 08 07 06");  // Rd_Outp: the last real outputs
  exchange(*s, {1, 1, 1, 1}, now);
  EXPECT_EQ(hex(s->field_outputs()), "01 01 01 01");

  auto hold = make_slave(m, 9, standard, &log, SafeState::Hold);
  ASSERT_TRUE(parameterize(*hold, prm, cfg, now));
  exchange(*hold, {5, 5, 5, 5}, now);
  ASSERT_TRUE(hold->dp().data_exchange(kMaster, {}, now));
  EXPECT_EQ(hex(hold->field_outputs()), "05 05 05 05");
}

TEST_F(Starter, WatchdogExpiryReleasesTheLockAndClearsTheOutputs) {
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  exchange(*s, {1, 2, 3, 4}, now);
  EXPECT_EQ(s->next_deadline(), now + milliseconds(100) + microseconds(1));
  now += milliseconds(101);
  s->advance(now);
  EXPECT_EQ(s->dp().state(), SlaveState::WaitPrm);
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "02 05 00 FF 0C 31");  // lock released: master FF
  EXPECT_EQ(hex(s->field_outputs()), "00 00 00 00");
}

TEST_F(Starter, LockedToOneMasterUntilItUnlocks) {
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  EXPECT_FALSE(s->dp().set_prm(3, prm, now));  // another master: ignored
  EXPECT_EQ(s->dp().state(), SlaveState::DataExch);
  EXPECT_EQ(s->dp().diagnosis(now)[3], kMaster);
  EXPECT_TRUE(log.contains("Set_Prm from master 3 ignored: locked by master 2"));
  auto unlock = prm;
  unlock[0] = dp::kPrmUnlockReq;
  s->dp().set_prm(kMaster, unlock, now);
  EXPECT_EQ(s->dp().state(), SlaveState::WaitPrm);
  EXPECT_EQ(s->dp().diagnosis(now)[3], dp::kNoMaster);
  auto no_lock = prm;
  no_lock[0] = 0x08;  // WD_On, Lock_Req = Unlock_Req = 0: only min_TSDR
  EXPECT_TRUE(s->dp().set_prm(3, no_lock, now));
  EXPECT_EQ(s->dp().state(), SlaveState::WaitPrm);
  EXPECT_TRUE(log.contains("without Lock_Req: only min_TSDR is taken"));
  EXPECT_TRUE(parameterize(*s, prm, cfg, now));  // unlocked: master 2 locks it again
}

TEST_F(Starter, SetPrmWithoutLockReqKeepsStateAndWatchdog) {
  // docs/slaves.md "Set_Prm": 0 0 from the lock holder takes the user parameters only.
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  auto no_lock = set_prm(*m, standard, {});  // watchdog off
  no_lock[0] = 0x00;
  EXPECT_TRUE(s->dp().set_prm(kMaster, no_lock, now));
  EXPECT_EQ(s->dp().state(), SlaveState::DataExch);
  EXPECT_EQ(s->dp().watchdog_ms(), 100u);
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "00 0C 00 02 0C 31");
  now += milliseconds(101);
  s->advance(now);
  EXPECT_EQ(s->dp().state(), SlaveState::WaitPrm);  // the watchdog still runs
}

TEST_F(Starter, WrongOutputLengthLeavesDataExch) {
  // docs/dp-slave.md "Wrong output length" (IEC 61158-6-3): no data, Wait_Prm, Prm_Req.
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  exchange(*s, {1, 2, 3, 4}, now);
  EXPECT_FALSE(s->dp().data_exchange(kMaster, std::vector<std::uint8_t>{1, 2, 3}, now));
  EXPECT_EQ(s->dp().state(), SlaveState::WaitPrm);
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "02 05 00 02 0C 31");
  EXPECT_EQ(hex(s->field_outputs()), "00 00 00 00");  // outputs in the safe state
  EXPECT_FALSE(s->dp().data_exchange(kMaster, std::vector<std::uint8_t>{1, 2, 3, 4}, now));
  EXPECT_TRUE(parameterize(*s, prm, cfg, now));
}

TEST_F(Starter, DeviceDiagnosisAlarmIsExtDiagData) {
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  ASSERT_TRUE(s->set_device_diag({0x01, 0x80}));
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "08 0C 00 02 0C 31 03 01 80");  // Ext_Diag, header 03
  ASSERT_TRUE(s->set_device_diag({0x01, 0x80}, false));                  // status only
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "00 0C 00 02 0C 31 03 01 80");
  // Max_Diag_Data_Len 20: 14 bytes of Ext_Diag_Data fit, the rest is cut (Ext_Diag_Overflow).
  ASSERT_TRUE(s->set_device_diag(std::vector<std::uint8_t>(20, 0xEE)));
  const auto d = s->dp().diagnosis(now);
  EXPECT_EQ(d.size(), 20u);
  EXPECT_EQ(d[2], dp::kDiag3ExtDiagOverflow);
  EXPECT_EQ(d[6], 21);  // the header still says what the device had
  s->clear_device_diag();
  EXPECT_EQ(hex(s->dp().diagnosis(now)), "00 0C 00 02 0C 31");
  EXPECT_FALSE(s->set_device_diag({}));
  EXPECT_FALSE(s->set_device_diag(std::vector<std::uint8_t>(63, 0)));
}

TEST_F(Starter, ForcedPrmAndCfgFaults) {
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  s->force_prm_fault(true, now);
  EXPECT_EQ(s->dp().state(), SlaveState::WaitPrm);
  EXPECT_EQ(s->dp().diagnosis(now)[0], dp::kDiag1PrmFault | dp::kDiag1StationNotReady);
  EXPECT_FALSE(parameterize(*s, prm, cfg, now));  // every Set_Prm rejected while forced
  s->force_prm_fault(false, now);
  ASSERT_TRUE(parameterize(*s, prm, cfg, now));
  s->force_cfg_fault(true, now);
  EXPECT_EQ(s->dp().diagnosis(now)[0], dp::kDiag1CfgFault | dp::kDiag1StationNotReady);
  EXPECT_FALSE(parameterize(*s, prm, cfg, now));
  EXPECT_EQ(s->cfg_problem(), "forced Cfg fault");
  s->force_cfg_fault(false, now);
  EXPECT_TRUE(parameterize(*s, prm, cfg, now));
}

// ------------------------------------------------------------- DP/DP coupler (CP2COUPL)

struct Coupler : Engine {
  std::shared_ptr<const gsd::Model> m = load("CP2COUPL.GSD");
  const std::vector<std::string> mods = {"2 Bytes Output", "2 Bytes Input"};
  std::unique_ptr<GsdSlave> s = make_slave(m, 9, mods, &log);
  std::vector<std::uint8_t> cfg = chk_cfg(*m, mods);

  void start(StdPrmRequest r) { ASSERT_TRUE(parameterize(*s, set_prm(*m, mods, r), cfg, now)); }
  void gc(std::uint8_t control, std::uint8_t group = 0) {
    s->dp().global_control(kMaster, control, now, group);
  }
};

TEST_F(Coupler, SyncHoldsTheOutputsUntilTheNextSync) {
  start({.sync = true, .freeze = true});
  exchange(*s, {0x11, 0x22}, now);
  EXPECT_EQ(hex(s->field_outputs()), "11 22");
  gc(dp::kGcSync);
  EXPECT_TRUE(s->dp().diagnosis(now)[1] & dp::kDiag2SyncMode);
  exchange(*s, {0x33, 0x44}, now);
  EXPECT_EQ(hex(s->field_outputs()), "11 22");  // held
  gc(dp::kGcSync);
  EXPECT_EQ(hex(s->field_outputs()), "33 44");
  exchange(*s, {0x55, 0x66}, now);
  gc(dp::kGcSync | dp::kGcUnsync);  // Unsync wins
  EXPECT_EQ(hex(s->field_outputs()), "55 66");
  EXPECT_FALSE(s->dp().diagnosis(now)[1] & dp::kDiag2SyncMode);
}

TEST_F(Coupler, FreezeHoldsTheInputsUntilTheNextFreeze) {
  start({.sync = true, .freeze = true});
  s->write_inputs(0, std::vector<std::uint8_t>{0xAA, 0xBB});
  gc(dp::kGcFreeze);
  EXPECT_TRUE(s->dp().diagnosis(now)[1] & dp::kDiag2FreezeMode);
  s->write_inputs(0, std::vector<std::uint8_t>{0xCC, 0xDD});
  EXPECT_EQ(hex(exchange(*s, {0, 0}, now)), "AA BB");
  gc(dp::kGcFreeze);
  EXPECT_EQ(hex(exchange(*s, {0, 0}, now)), "CC DD");
  s->write_inputs(0, std::vector<std::uint8_t>{0xEE, 0xFF});
  gc(dp::kGcUnfreeze);
  EXPECT_EQ(hex(exchange(*s, {0, 0}, now)), "EE FF");
}

TEST_F(Coupler, SyncWithoutSyncReqIsIgnored) {
  start({});
  exchange(*s, {1, 2}, now);
  gc(dp::kGcSync);
  exchange(*s, {3, 4}, now);
  EXPECT_EQ(hex(s->field_outputs()), "03 04");
  EXPECT_TRUE(log.contains("Sync/Unsync ignored (Sync_Req was not set in Set_Prm)"));
}

TEST_F(Coupler, ClearDataAndGroups) {
  start({.sync = true, .group = 0x02});
  exchange(*s, {7, 7}, now);
  gc(dp::kGcClearData, 0x01);  // another group
  EXPECT_EQ(hex(s->field_outputs()), "07 07");
  gc(dp::kGcClearData, 0x02);
  EXPECT_EQ(hex(s->field_outputs()), "00 00");
  exchange(*s, {8, 8}, now);
  EXPECT_EQ(hex(s->field_outputs()), "00 00");  // still cleared
  gc(0x00);
  EXPECT_EQ(hex(s->field_outputs()), "08 08");
  s->dp().global_control(3, dp::kGcClearData, now);  // not the lock holder
  EXPECT_EQ(hex(s->field_outputs()), "08 08");
}

TEST_F(Coupler, ModularLimitsAndTheUserParameterBit) {
  EXPECT_EQ(s->profile().max_module, 16u);
  EXPECT_TRUE(s->profile().sync);
  EXPECT_TRUE(s->profile().freeze);
  // "Diagnose" Bit(7) of user byte 3 (default 0, PrmText "standard diagnosis" = 0).
  const auto p = set_prm(*m, mods, {}, {{"Diagnose", std::int64_t{1}}});
  EXPECT_EQ(hex(std::span(p).subspan(7)), "00 00 00 80");
  // 17 modules: more than Max_Module 16, the slave's own configuration is refused.
  auto many = make_slave(m, 10, std::vector<std::string>(17, "1 Byte Input"), &log);
  EXPECT_FALSE(parameterize(*many, set_prm(*m, {}),
                            chk_cfg(*m, std::vector<std::string>(17, "1 Byte Input")), now));
  EXPECT_EQ(many->cfg_problem(), "17 modules, Max_Module is 16");
}

// ------------------------------------------------------- motor manager (CP2DPV1), DP-V1

struct Manager : Engine {
  std::shared_ptr<const gsd::Model> m = load("CP2DPV1.GSD");
  const std::vector<std::string> mods = {"Manager Standard"};
  std::unique_ptr<GsdSlave> s = make_slave(m, 126, mods, &log);
  std::vector<std::uint8_t> prm = set_prm(*m, mods, {.watchdog_ms = 50});
};

TEST_F(Manager, Dpv1StatusBytesAreCheckedAgainstTheGsd) {
  EXPECT_TRUE(s->profile().dpv1);
  EXPECT_EQ(hex(std::span(prm).subspan(7)), "80 00 08");  // DPV1_Enable, Prm_Structure
  EXPECT_TRUE(s->dp().set_prm(kMaster, prm, now));
  auto p = prm;
  p[8] = 0x20;  // Enable_Diagnostic_Alarm: Diagnostic_Alarm_supp = 1
  EXPECT_TRUE(s->dp().set_prm(kMaster, p, now));
  p[8] = 0x80;  // Enable_Pull_Plug_Alarm: Pull_Plug_Alarm_supp = 0
  EXPECT_FALSE(s->dp().set_prm(kMaster, p, now));
  EXPECT_EQ(s->prm_problem(),
            "DPV1_Status_2 (byte 8) = 0x80: Enable_Pull_Plug_Alarm (Pull_Plug_Alarm_supp) is set, "
            "the GSD does not support it");
  p = prm;
  p[7] |= 0x01;  // reserved
  EXPECT_FALSE(s->dp().set_prm(kMaster, p, now));
  EXPECT_EQ(s->dp().prm_fault(), (dp::PrmFault{7, 0x80}));
}

TEST_F(Manager, WatchdogBase1ms) {
  auto p = prm;  // 50 ms: WD_Fact_1 5, WD_Fact_2 1
  p[7] |= 0x04;  // WD_Base_1ms (WD_Base_1ms_supp = 1): 5 ms
  ASSERT_TRUE(s->dp().set_prm(kMaster, p, now));
  EXPECT_EQ(s->dp().watchdog_ms(), 5u);
  ASSERT_TRUE(s->dp().set_prm(kMaster, prm, now));
  EXPECT_EQ(s->dp().watchdog_ms(), 50u);
}

TEST_F(Manager, SetSlaveAddIsTakenOnceWithNoAddChg) {
  EXPECT_TRUE(s->dp().set_slave_add(kMaster, std::vector<std::uint8_t>{20, 0x0C, 0xFD, 1}, now));
  EXPECT_EQ(s->address(), 20);
  EXPECT_FALSE(s->dp().set_slave_add(kMaster, std::vector<std::uint8_t>{21, 0x0C, 0xFD, 0}, now));
  EXPECT_TRUE(log.contains("locked by an earlier No_Add_Chg"));
  auto starter = make_slave(load("CP2MOTOR.GSD"), 5, {"Starter Standard"}, &log);  // _supp = 0
  EXPECT_FALSE(
      starter->dp().set_slave_add(kMaster, std::vector<std::uint8_t>{6, 0x0C, 0x31, 0}, now));
  EXPECT_EQ(starter->address(), 5);
}

// ------------------------------------------------------------------ a compact station

TEST_F(Engine, CompactIoStation) {
  auto m = load("CP2CIO8.GSD");
  const std::vector<std::string> mods = {"8 DA", "8 DE"};
  auto s = make_slave(m, 7, mods, &log);
  EXPECT_FALSE(s->profile().modular);
  const auto prm = set_prm(*m, mods, {}, {{"Hold Outputs", std::string("enabled")}});
  EXPECT_EQ(hex(std::span(prm).subspan(7)), "00 00 00 4A");
  ASSERT_TRUE(parameterize(*s, prm, chk_cfg(*m, mods), now));
  s->write_inputs(0, std::vector<std::uint8_t>{0x5A});
  EXPECT_EQ(hex(exchange(*s, {0xA5}, now)), "5A");
  EXPECT_EQ(hex(s->field_outputs()), "A5");
  // The module list in another order is another configuration.
  EXPECT_FALSE(parameterize(*s, prm, chk_cfg(*m, {"8 DE", "8 DA"}), now));
}

// The CAN-DP/2 profile is untouched by the standard one: Global_Control is still ignored.
TEST(Profiles, OptionsOnlyInTheStandardProfile) {
  const Profile p = std::get<Profile>(read_profile(*load("CP2COUPL.GSD")));
  const dp::SlaveOptions o = p.options();
  EXPECT_EQ(o.profile, dp::DpProfile::Standard);
  EXPECT_TRUE(o.sync && o.freeze);
  EXPECT_FALSE(o.fail_safe);
  EXPECT_EQ(o.max_diag_len, 11u);
  EXPECT_EQ(p.name(), "candp2 test devices DP/DP coupler DC-16, Ident_Number 0x0C70");
  gsd::Model no_ident;
  EXPECT_EQ(std::get<std::string>(read_profile(no_ident)), "the GSD has no Ident_Number");
}

}  // namespace
}  // namespace candp2::gsd_slave::test

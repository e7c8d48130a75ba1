// CAN release rules, CANopen master and slave functions, SYNC, CAN diagnosis (manual §5.1.2,
// §5.3.3 command 20, §9, table 3.4.5; docs/dp-slave.md, docs/canopen.md).
#include <gtest/gtest.h>

#include "can/virtual_bus.hpp"
#include "fixture.hpp"
#include "gateway/comm_window.hpp"

namespace candp2::gw::test {
namespace {

// A Tx slot 0x201 (2 bytes), Rx slots 0x181 (8 bytes) and 29-bit 0x12345 (3 bytes).
const std::vector<std::uint8_t> kCfg =
    cfg_of({out_slot(2, {0x02, 0x01, 0x00}), in_slot(8, {0x01, 0x81, 0x00}),
            in_slot(3, {0x20, 0x01, 0x23, 0x45, 0x00})});

UserPrm master(std::uint8_t wakeup_s = 0, std::uint16_t sync_ms = 0) {
  UserPrm p;
  p.canopen_master = true;
  p.wakeup_s = wakeup_s;
  p.sync_ms = sync_ms;
  return p;
}

UserPrm slave(std::uint8_t module_id, std::uint8_t wakeup_s = 0) {
  UserPrm p;
  p.canopen_slave = true;
  p.module_id = module_id;
  p.wakeup_s = wakeup_s;
  return p;
}

std::vector<Time> times(const Recorder& r) {
  std::vector<Time> t;
  for (const auto& s : r.sent) t.push_back(s.time);
  return t;
}

using CanopenTest = GatewayFixture;

// ---------------------------------------------------------------- layer-2 mode

TEST_F(CanopenTest, LayerTwoModeIgnoresCanopenSettings) {
  // manual table 5.1.2 last row: without CANopen-Slave/Master, wake-up time, RTR, Start-Frame and
  // SYNC time are ignored; transmission is released when Data_Exch is entered (docs/canopen.md).
  UserPrm p;
  p.wakeup_s = 5;
  p.sync_ms = 100;
  p.start_frame = true;
  ASSERT_TRUE(configure(p, kCfg));
  EXPECT_TRUE(gw->status().released);
  EXPECT_TRUE(rec.take().empty());  // no start frame, no RTR frames
  exchange({0x01, 0x02});
  EXPECT_EQ(rec.take(), V({"201#0102"}));
  run_for(seconds(2));
  EXPECT_TRUE(rec.take().empty());  // no SYNC
  EXPECT_EQ(gw->status().sync_ms, 0);
  EXPECT_EQ(gw->stored_wakeup_s(), 0);  // not stored either
  EXPECT_EQ(gw->stored_sync_ms(), 0);
}

// ---------------------------------------------------------------- CANopen master

TEST_F(CanopenTest, MasterWaitsForTheWakeUpTime) {
  UserPrm p = master(2, 0);
  p.start_frame = true;
  make();  // power-on at t = 0
  now = milliseconds(500);
  ASSERT_TRUE(configure(p, kCfg));
  now = seconds(1);
  exchange({0xAA, 0xBB});  // held until release (docs/canopen.md)
  EXPECT_TRUE(rec.take().empty());
  EXPECT_FALSE(gw->status().released);
  // The wake-up time counts from power-on (t = 0), not from parameterization.
  EXPECT_EQ(gw->next_deadline(), seconds(2));
  run_until(seconds(2) - microseconds(1));
  EXPECT_TRUE(rec.sent.empty());
  run_until(seconds(3));
  // At release: NMT start-all, every Tx slot once (latest data), one RTR per Rx identifier.
  EXPECT_EQ(times(rec), std::vector<Time>(4, seconds(2)));
  EXPECT_EQ(rec.take(), V({"000#0100", "201#AABB", "181#R8", "00012345#R3"}));
  EXPECT_TRUE(gw->status().released);
}

TEST_F(CanopenTest, MasterReleasedAtDataExchWhenTheWakeUpTimeIsOver) {
  UserPrm p = master(1, 0);
  p.start_frame = true;
  p.send_rtr = false;  // GSD RTR-Frames "No" (flag bit 4 set)
  make();              // power-on at t = 0
  now = seconds(3);
  ASSERT_TRUE(configure(p, kCfg));
  EXPECT_EQ(rec.take(), V({"000#0100"}));  // no slot data yet, no RTR frames
  exchange({0x01, 0x02});
  EXPECT_EQ(rec.take(), V({"201#0102"}));
}

TEST_F(CanopenTest, WakeUpKeepUsesTheStoredValue) {
  make({.stored_wakeup_s = 3});
  ASSERT_TRUE(configure(master(kWakeupKeep, 0), kCfg));  // manual table 5.1.3: 255 = stored
  EXPECT_EQ(gw->stored_wakeup_s(), 3);
  exchange({0x01, 0x02});
  run_until(seconds(3) - microseconds(1));
  EXPECT_TRUE(rec.sent.empty());
  run_until(seconds(3));
  EXPECT_EQ(rec.take(), V({"201#0102", "181#R8", "00012345#R3"}));
}

TEST_F(CanopenTest, WakeUpTimeRestartsWithPowerCycle) {
  ASSERT_TRUE(configure(master(2, 0), kCfg));
  run_until(seconds(10));
  rec.take();
  gw->power_cycle(now);  // manual §5.1.2: "nach einem RESET oder Power-On"
  ASSERT_TRUE(configure(master(kWakeupKeep, 0), kCfg));
  exchange({0x01, 0x02});
  run_until(seconds(12) - microseconds(1));
  EXPECT_TRUE(rec.sent.empty());
  EXPECT_FALSE(gw->status().released);
  run_until(seconds(12));
  EXPECT_EQ(rec.take(), V({"201#0102", "181#R8", "00012345#R3"}));
}

TEST_F(CanopenTest, RtrFramesOnePerRxIdentifier) {
  // manual table 5.1.2 "RTR-Frames auf RxId senden": one remote frame per Rx identifier, in slot
  // order, DLC = the slot's data length (without the Rx-Counter byte); the same identifier on two
  // slots is requested once, with the later slot's length (manual §5.2.1: the later slot wins).
  UserPrm p = master();
  p.rx_counter = true;
  const auto cfg = cfg_of({in_slot(9, {0x01, 0x81, 0x00}), in_slot(5, {0x03, 0x81, 0x00}),
                           in_slot(3, {0x01, 0x81, 0x00}), out_slot(1, {0x07, 0xF8, 0x00})});
  ASSERT_TRUE(configure(p, cfg));
  EXPECT_EQ(rec.take(), V({"181#R2", "381#R4"}));
}

TEST_F(CanopenTest, MasterWithoutWakeUpTimeSendsTxSlotsBeforeRemoteFrames) {
  // docs/canopen.md "CANopen master": at the release NMT start-all, then every Tx slot once, then
  // one remote frame per Rx identifier (manual table 5.1.2 "nach Wake-Up-Time Start-Frame, TxID
  // ausgeben, RTR-Frames auf RxId senden"). With wake-up time 0 the release comes at Chk_Cfg,
  // before the PLC's first outputs: the remote frames wait for the Tx slot's first frame.
  UserPrm p = master(0, 0);
  p.start_frame = true;
  ASSERT_TRUE(configure(p, kCfg));
  EXPECT_TRUE(gw->status().released);
  EXPECT_EQ(rec.take(), V({"000#0100"}));
  now = milliseconds(5);
  exchange({0xAA, 0xBB});
  EXPECT_EQ(times(rec), std::vector<Time>(3, milliseconds(5)));
  EXPECT_EQ(rec.take(), V({"201#AABB", "181#R8", "00012345#R3"}));
  now = milliseconds(10);
  exchange({0xAA, 0xBB});  // once only
  EXPECT_TRUE(rec.take().empty());
}

TEST_F(CanopenTest, NoRtrFramesWhenDisabled) {
  UserPrm p = master();
  p.send_rtr = false;
  ASSERT_TRUE(configure(p, kCfg));
  exchange({0, 0});
  EXPECT_EQ(rec.take(), V({"201#0000"}));
}

TEST_F(CanopenTest, ReleaseActionsOnceStartFrameNotRepeatedAfterWatchdog) {
  UserPrm p = master();
  p.start_frame = true;
  ASSERT_TRUE(configure(p, kCfg, 50));
  EXPECT_EQ(rec.take(), V({"000#0100"}));  // the Tx slot waits for its data, the RTR frames too
  exchange({0x01, 0x02});
  EXPECT_EQ(rec.take(), V({"201#0102", "181#R8", "00012345#R3"}));
  run_for(milliseconds(60));
  ASSERT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  ASSERT_TRUE(configure(p, kCfg, 50));
  // Transmission resumes: every Tx slot once; the start frame and RTR frames belong to the
  // release after the wake-up time, which happened once.
  EXPECT_EQ(rec.take(), V({"201#0102"}));
}

// ---------------------------------------------------------------- SYNC

TEST_F(CanopenTest, SyncEverySyncTime) {
  ASSERT_TRUE(configure(master(0, 100), kCfg));
  rec.take();
  run_until(milliseconds(350));
  // docs/canopen.md: ID 0x080, DLC 0, every SYNC time ms from release.
  EXPECT_EQ(times(rec),
            (std::vector<Time>{milliseconds(100), milliseconds(200), milliseconds(300)}));
  EXPECT_EQ(rec.take(), V({"080#", "080#", "080#"}));
  EXPECT_EQ(gw->next_deadline(), milliseconds(400));
}

TEST_F(CanopenTest, SyncNeedsDataExch) {
  // docs/dp-slave.md: after a watchdog drop Tx on CAN stops, cyclic sends (SYNC) too.
  ASSERT_TRUE(configure(master(0, 100), kCfg, 150));
  rec.take();
  run_until(milliseconds(100));
  EXPECT_EQ(rec.take(), V({"080#"}));
  run_until(milliseconds(1000));
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  EXPECT_TRUE(rec.take().empty());  // the slave dropped out at 150 ms: no SYNC at 200 ms
  ASSERT_TRUE(configure(master(kWakeupKeep, kSyncKeep), kCfg, 150));
  rec.take();
  run_until(milliseconds(1100));
  // Set_Prm wrote the (kept) SYNC time again: its period restarts at 1000 ms.
  EXPECT_EQ(times(rec), (std::vector<Time>{milliseconds(1100)}));
}

TEST_F(CanopenTest, SyncWaitsForTheFramesOfADataExchange) {
  // manual §5.3.3 command 20 note: the SYNC cannot interrupt the sending of a DP telegram's
  // frames; it is delayed until they are out. 8 slots x 8 bytes at 125 kbit/s:
  // 8 x (47 + 64) bits = 888 bits = 7104 us.
  std::vector<dp::CfgEntry> slots;
  for (std::uint8_t i = 0; i < 8; ++i) slots.push_back(out_slot(8, {0x02, i, 0x00}));
  const auto cfg = dp::encode_chk_cfg(slots);
  ASSERT_TRUE(configure(master(0, 10), cfg));
  std::vector<std::uint8_t> out(64, 0);
  exchange(out);
  rec.take();
  now = milliseconds(9);
  out[0] = 1;
  for (std::size_t i = 0; i < 64; i += 8) out[i] = 1;
  exchange(out);
  EXPECT_EQ(gw->next_deadline(), microseconds(9000 + 7104));
  run_until(milliseconds(25));
  ASSERT_EQ(rec.sent.size(), 10u);
  EXPECT_EQ(rec.sent[7].time, milliseconds(9));
  EXPECT_EQ(can::format_candump(rec.sent[8].frame), "080#");
  EXPECT_EQ(rec.sent[8].time, microseconds(16104));
  // The grid keeps its phase: the next SYNC is due at 20 ms as planned.
  EXPECT_EQ(can::format_candump(rec.sent[9].frame), "080#");
  EXPECT_EQ(rec.sent[9].time, milliseconds(20));
}

TEST_F(CanopenTest, SyncWaitsBehindBurstsQueuedBackToBack) {
  std::vector<dp::CfgEntry> slots;
  for (std::uint8_t i = 0; i < 8; ++i) slots.push_back(out_slot(8, {0x02, i, 0x00}));
  ASSERT_TRUE(configure(master(0, 10), dp::encode_chk_cfg(slots)));
  std::vector<std::uint8_t> out(64, 0);
  exchange(out);
  rec.take();
  now = milliseconds(9);
  for (std::size_t i = 0; i < 64; i += 8) out[i] = 1;
  exchange(out);
  now = milliseconds(12);  // the first burst is still on the wire: the second queues behind it
  for (std::size_t i = 0; i < 64; i += 8) out[i] = 2;
  exchange(out);
  run_until(milliseconds(29));
  ASSERT_EQ(rec.sent.size(), 17u);
  EXPECT_EQ(can::format_candump(rec.sent[16].frame), "080#");
  EXPECT_EQ(rec.sent[16].time, microseconds(9000 + 2 * 7104));
}

TEST_F(CanopenTest, SyncAlreadyDueGoesBeforeTheExchangesFrames) {
  ASSERT_TRUE(configure(master(0, 10), kCfg));
  exchange({0, 0});
  rec.take();
  now = microseconds(10500);  // the SYNC due at 10 ms has not been fired yet
  exchange({1, 1});
  EXPECT_EQ(rec.take(), V({"080#", "201#0101"}));
  run_until(milliseconds(20));
  EXPECT_EQ(times(rec), (std::vector<Time>{milliseconds(20)}));
}

TEST_F(CanopenTest, SyncOnlyAsCanopenMaster) {
  UserPrm p = slave(3);
  p.sync_ms = 100;
  ASSERT_TRUE(configure(p, kCfg));
  rx("000#0100");
  rec.take();
  run_for(seconds(1));
  EXPECT_TRUE(rec.take().empty());
  EXPECT_EQ(gw->status().sync_ms, 0);
}

// The three SYNC sources are equal; the one written last wins (manual §5.1.2 note, §5.3.3).
class SyncSourceTest : public GatewayFixture {
 protected:
  static std::vector<std::uint8_t> cfg(std::uint16_t cw_sync_ms) {
    const auto hi = static_cast<std::uint8_t>(cw_sync_ms >> 8);
    const auto lo = static_cast<std::uint8_t>(cw_sync_ms & 0xFF);
    return cfg_of(
        {in_slot(16, {0xFF, 0xEF, 0x00, hi, lo}), out_slot(16, {0xFF, 0xEF, 0x00, hi, lo})});
  }
  static UserPrm prm(std::uint16_t sync_ms) {
    UserPrm p = master(0, sync_ms);
    p.comm_window = true;
    return p;
  }
  void set_prm(std::uint16_t sync_ms) {
    gw->dp().set_prm(kMaster, dp::with_lock_req(make_set_prm(prm(sync_ms))), now);
  }
  void chk_cfg(std::uint16_t cw_sync_ms) { gw->dp().chk_cfg(kMaster, cfg(cw_sync_ms), now); }
  std::uint8_t command20(std::uint16_t ms) {
    CwRequest r;
    r.command = kCwSyncTime;
    r.counter = ++counter_;
    r.data[0] = static_cast<std::uint8_t>(ms >> 8);
    r.data[1] = static_cast<std::uint8_t>(ms & 0xFF);
    const auto w = encode_cw_request(r);
    const auto in = exchange({w.begin(), w.end()});
    return in.at(kCwError);
  }
  // The SYNC period measured on the bus.
  Duration measured_period() {
    rec.take();
    const Time start = now;
    run_until(start + seconds(2));
    EXPECT_GE(rec.sent.size(), 2u);
    if (rec.sent.size() < 2) return Duration{0};
    const Duration d = rec.sent[1].time - rec.sent[0].time;
    rec.take();
    return d;
  }
  std::uint8_t counter_ = 0;
};

TEST_F(SyncSourceTest, EachSourceOverridesTheOthers) {
  make();
  set_prm(100);
  EXPECT_EQ(gw->status().sync_ms, 100);  // Prm bytes 14-15
  chk_cfg(200);
  EXPECT_EQ(gw->status().sync_ms, 200);  // CW comment bytes 4-5, written after Set_Prm
  ASSERT_EQ(gw->dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(measured_period(), milliseconds(200));
  EXPECT_EQ(command20(300), kCwOk);  // command 20 overrides both
  EXPECT_EQ(gw->status().sync_ms, 300);
  EXPECT_EQ(measured_period(), milliseconds(300));
  set_prm(400);  // a new Set_Prm overrides command 20
  EXPECT_EQ(gw->status().sync_ms, 400);
  chk_cfg(0);  // 00 00 = not given (docs/communication-window.md)
  EXPECT_EQ(gw->status().sync_ms, 400);
  EXPECT_EQ(measured_period(), milliseconds(400));
  EXPECT_EQ(command20(250), kCwOk);
  set_prm(kSyncKeep);  // 65535 keeps the stored value, which command 20 wrote
  chk_cfg(0);
  EXPECT_EQ(gw->status().sync_ms, 250);
  EXPECT_EQ(gw->stored_sync_ms(), 250);
  EXPECT_EQ(measured_period(), milliseconds(250));
  set_prm(kSyncKeep);
  chk_cfg(150);  // the CW comment again, on a re-configuration
  EXPECT_EQ(gw->status().sync_ms, 150);
  EXPECT_EQ(measured_period(), milliseconds(150));
}

TEST_F(SyncSourceTest, CommandTwentyZeroStopsAndFfffKeeps) {
  make();
  set_prm(100);
  chk_cfg(0);
  EXPECT_EQ(measured_period(), milliseconds(100));
  EXPECT_EQ(command20(0xFFFF), kCwOk);  // outside 0..FFFE: read like Prm 65535, kept
  EXPECT_EQ(gw->status().sync_ms, 100);
  EXPECT_EQ(command20(0), kCwOk);  // 0 = off
  rec.take();
  run_for(seconds(1));
  EXPECT_TRUE(rec.take().empty());
  EXPECT_EQ(gw->stored_sync_ms(), 0);
  EXPECT_FALSE(gw->next_deadline().has_value());
}

TEST_F(SyncSourceTest, StoredSyncTimeSurvivesAPowerCycle) {
  make();
  set_prm(100);
  chk_cfg(0);
  EXPECT_EQ(command20(700), kCwOk);
  gw->power_cycle(now);
  set_prm(kSyncKeep);
  chk_cfg(0);
  EXPECT_EQ(gw->status().sync_ms, 700);
}

// ---------------------------------------------------------------- CANopen slave

TEST_F(CanopenTest, SlaveBootFrameAfterTheWakeUpTime) {
  make();
  gw->dp().set_prm(kMaster, make_set_prm(slave(5, 1)), now);
  EXPECT_EQ(gw->status().nmt, NmtState::Initialising);
  EXPECT_EQ(gw->next_deadline(), seconds(1));
  rx("000#0100");  // NMT during the wake-up time: ignored
  run_until(seconds(1));
  // manual table 5.1.2: "128 dez + Module-No.", DLC 0 (docs/canopen.md).
  EXPECT_EQ(rec.take(), V({"085#"}));
  EXPECT_EQ(gw->status().nmt, NmtState::PreOperational);
  gw->dp().chk_cfg(kMaster, kCfg, now);
  exchange({1, 2});
  EXPECT_TRUE(rec.take().empty());  // pre-operational: nothing else is sent
  EXPECT_FALSE(gw->status().released);
}

TEST_F(CanopenTest, SlaveCia301BootUpOption) {
  make({.cia301_bootup = true});
  ASSERT_TRUE(configure(slave(0x7F), kCfg));
  EXPECT_EQ(rec.take(), V({"77F#00"}));  // CiA 301 boot-up: 0x700 + ID, DLC 1, 00
}

TEST_F(CanopenTest, SlaveNmtTransitions) {
  ASSERT_TRUE(configure(slave(5), kCfg));
  EXPECT_EQ(rec.take(), V({"085#"}));
  exchange({1, 1});
  EXPECT_TRUE(rec.take().empty());
  rx("000#0106");  // NMT start for node 6: not us
  EXPECT_EQ(gw->status().nmt, NmtState::PreOperational);
  rx("000#01");  // DLC 1: not an NMT frame (manual §9: DLC 2)
  EXPECT_EQ(gw->status().nmt, NmtState::PreOperational);
  EXPECT_TRUE(rec.take().empty());
  // NMT start for node 5 releases as for the master: Tx slots, RTR frames (docs/canopen.md).
  rx("000#0105");
  EXPECT_EQ(gw->status().nmt, NmtState::Operational);
  EXPECT_EQ(rec.take(), V({"201#0101", "181#R8", "00012345#R3"}));
  exchange({2, 2});
  EXPECT_EQ(rec.take(), V({"201#0202"}));
  // Stop: transmission halts.
  rx("000#0205");
  EXPECT_EQ(gw->status().nmt, NmtState::Stopped);
  exchange({3, 3});
  EXPECT_TRUE(rec.take().empty());
  // Start for all nodes: released again with the latest data and the RTR frames.
  rx("000#0100");
  EXPECT_EQ(rec.take(), V({"201#0303", "181#R8", "00012345#R3"}));
  // Enter pre-operational: halts.
  rx("000#8000");
  EXPECT_EQ(gw->status().nmt, NmtState::PreOperational);
  exchange({4, 4});
  EXPECT_TRUE(rec.take().empty());
  // Reset node / reset communication: the boot frame again, pre-operational.
  rx("000#0105");
  rec.take();
  rx("000#8105");
  EXPECT_EQ(rec.take(), V({"085#"}));
  EXPECT_EQ(gw->status().nmt, NmtState::PreOperational);
  EXPECT_FALSE(gw->status().released);
  rx("000#8200");
  EXPECT_EQ(rec.take(), V({"085#"}));
  rx("000#7705");  // unknown NMT command: ignored
  EXPECT_EQ(gw->status().nmt, NmtState::PreOperational);
  EXPECT_TRUE(rec.take().empty());
}

// docs/architecture.md "The plant": a gateway's deadline is asked again after a frame only when
// on_can_frame() says the frame may have moved it. Frames into slots, remote frames and other
// identifiers leave it as it was and say so; the NMT start that releases the slave arms its
// cyclic Tx slot (manual §5.2.3: 03,E8 = every 1000 ms) and says it may have moved.
TEST_F(CanopenTest, OnlyAnNmtCommandMayMoveWhatTheGatewayWaitsFor) {
  const auto cfg =
      cfg_of({out_slot(2, {0x02, 0x01, 0x00, 0x03, 0xE8}), in_slot(8, {0x01, 0x81, 0x00}),
              in_slot(3, {0x20, 0x01, 0x23, 0x45, 0x00})});
  ASSERT_TRUE(configure(slave(5), cfg));
  exchange({1, 1});
  const auto before = gw->next_deadline();
  EXPECT_FALSE(before);  // no watchdog, not released: nothing to wait for
  for (const char* f : {"181#0102030405060708", "00012345#AABBCC", "181#R", "7FF#00", "201#0101"}) {
    EXPECT_FALSE(gw->on_can_frame(F(f), now)) << f;
    EXPECT_EQ(gw->next_deadline(), before) << f;
  }
  EXPECT_FALSE(gw->status().released);
  // NMT start for node 5: released, the Tx slot's cycle is due 1000 ms from now.
  EXPECT_TRUE(gw->on_can_frame(F("000#0105"), now));
  EXPECT_TRUE(gw->status().released);
  EXPECT_EQ(gw->next_deadline(), now + milliseconds(1000));
}

TEST_F(CanopenTest, SlaveStartedBeforeDataExchReleasesAtDataExch) {
  make();
  gw->dp().set_prm(kMaster, make_set_prm(slave(9)), now);
  EXPECT_EQ(rec.take(), V({"089#"}));
  rx("000#0109");
  EXPECT_EQ(gw->status().nmt, NmtState::Operational);
  EXPECT_TRUE(rec.take().empty());  // no configuration yet: nothing to send
  gw->dp().chk_cfg(kMaster, kCfg, now);
  EXPECT_TRUE(rec.take().empty());  // the RTR frames follow the Tx slot's first frame
  exchange({5, 6});
  EXPECT_EQ(rec.take(), V({"201#0506", "181#R8", "00012345#R3"}));
}

TEST_F(CanopenTest, RoleChangeRestartsTheReleaseRules) {
  ASSERT_TRUE(configure(master(0, 100), kCfg));
  EXPECT_TRUE(gw->status().released);
  ASSERT_TRUE(configure(slave(4), kCfg));
  EXPECT_FALSE(gw->status().released);
  // The master's RTR frames waited for the first Data_Exchange, which never came: not sent.
  EXPECT_EQ(rec.take(), V({"084#"}));
  run_for(seconds(1));
  EXPECT_TRUE(rec.take().empty());  // no SYNC as slave, nothing before NMT start
}

TEST_F(CanopenTest, NewRoleReleasesOnlyAfterTheNewChkCfg) {
  ASSERT_TRUE(configure(UserPrm{}, kCfg));  // layer-2 mode
  exchange({1, 2});
  EXPECT_EQ(rec.take(), V({"201#0102"}));
  UserPrm p = master();
  p.start_frame = true;
  // Set_Prm arrives while the slave is still in Data_Exch: nothing may go out with the old slots.
  gw->dp().set_prm(kMaster, dp::with_lock_req(make_set_prm(p)), now);
  EXPECT_TRUE(rec.take().empty());
  gw->dp().chk_cfg(kMaster, kCfg, now);
  EXPECT_EQ(rec.take(), V({"000#0100"}));
  exchange({1, 2});
  EXPECT_EQ(rec.take(), V({"201#0102", "181#R8", "00012345#R3"}));
}

TEST_F(CanopenTest, SlaveReleasedAtDataExchSendsEachSlotOnce) {
  ASSERT_TRUE(configure(slave(5), kCfg, 50));
  rx("000#0105");
  exchange({7, 7});
  EXPECT_EQ(rec.take(), V({"085#", "201#0707", "181#R8", "00012345#R3"}));
  rx("000#0205");  // stopped
  run_for(milliseconds(60));
  ASSERT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  rx("000#0105");  // started while the DP master is away: released when Data_Exch returns
  EXPECT_TRUE(rec.take().empty());
  ASSERT_TRUE(configure(slave(5), kCfg, 50));
  EXPECT_EQ(rec.take(), V({"201#0707", "181#R8", "00012345#R3"}));
}

// ---------------------------------------------------------------- CAN diagnosis via a bus

TEST(CanDiagnosisOnVirtualBus, BusStateIrqLostAndMsgLost) {
  // The daemon wires the channel's bus_state()/rx_lost() into set_controller_status; here the
  // virtual bus's fault injection drives it (manual table 3.4.5, docs/dp-slave.md "Diagnosis").
  can::VirtualBus bus(can::VirtualBus::Options{.rx_queue_limit = 300});
  auto gw_ep = bus.endpoint("gateway");
  auto node = bus.endpoint("node");
  Time now{0};
  Gateway gw(GatewayOptions{.address = 5}, *gw_ep, now);
  auto pump = [&] {
    while (auto f = gw_ep->receive()) gw.on_can_frame(*f, now);
    gw.set_controller_status(gw_ep->bus_state(), gw_ep->rx_lost());
  };
  UserPrm p;
  p.comm_window = true;
  p.can_diagnosis = true;
  ASSERT_TRUE(gw.dp().set_prm(kMaster, make_set_prm(p), now));
  ASSERT_TRUE(gw.dp().chk_cfg(
      kMaster, cfg_of({in_slot(16, {0xFF, 0xEF, 0x00}), out_slot(16, {0xFF, 0xEF, 0x00})}), now));
  auto diag = [&] { return hex(gw.dp().slave_diag(now)); };
  pump();
  EXPECT_EQ(diag(), "00 04 00 01 04 A4 05 04 00 00 00");

  // IRQ_LOST: 310 frames into a 300-frame receive queue lose 10 before the gateway sees them.
  for (int i = 0; i < 310; ++i) node->send(F("555#01"));
  EXPECT_EQ(gw_ep->rx_lost(), 10u);
  pump();
  EXPECT_EQ(diag(), "00 04 00 01 04 A4 05 04 00 0A 00");
  gw_ep->inject_rx_lost(1000);  // saturates at 255
  pump();
  EXPECT_EQ(diag(), "00 04 00 01 04 A4 05 04 00 FF 00");

  // MSG_LOST: enable 0x181 in the window, then overflow its 255-frame FIFO by 3.
  CwRequest r;
  r.command = kCwEnable;
  r.counter = 1;
  r.set_identifier({0x181, false});
  const auto w = encode_cw_request(r);
  ASSERT_TRUE(gw.dp().data_exchange(kMaster, w, now).has_value());
  for (int i = 0; i < 258; ++i) node->send(F("181#02"));
  pump();
  EXPECT_EQ(diag(), "00 04 00 01 04 A4 05 04 00 FF 03");

  // Bus states: 40 WARN, 80 ERROR_PASSIVE, C0 BUS_OFF with Ext_Diag; 00 OK without.
  struct Case {
    can::BusState state;
    const char* head;
    const char* code;
  };
  for (const Case& c :
       {Case{can::BusState::Warning, "08", "40"}, Case{can::BusState::ErrorPassive, "08", "80"},
        Case{can::BusState::BusOff, "08", "C0"}, Case{can::BusState::Ok, "00", "00"}}) {
    bus.set_bus_state(c.state);
    pump();
    EXPECT_EQ(diag(), std::string(c.head) + " 04 00 01 04 A4 05 04 " + c.code + " FF 03");
  }
  // One controller's own state (override) drives its diagnosis too.
  gw_ep->set_bus_state_override(can::BusState::ErrorPassive);
  pump();
  EXPECT_EQ(diag(), "08 04 00 01 04 A4 05 04 80 FF 03");
}

}  // namespace
}  // namespace candp2::gw::test

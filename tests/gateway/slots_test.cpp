// Normal-mode slot traffic (manual §2.2, §3.2.3, §5.2;
// docs/slots.md "Data exchange in normal mode").
#include <gtest/gtest.h>

#include "fixture.hpp"

namespace candp2::gw::test {
namespace {

TEST_F(GatewayFixture, Manual514RoundTripWithFormB8) {
  // manual §5.1.4: input 0x0289 / output 0x0309, 6 bytes, form B8
  // (docs/slots.md "Data exchange in normal mode": a b c d e f -> b a f e d c).
  ASSERT_TRUE(configure(UserPrm{},
                        cfg_of({in_slot(6, {0x02, 0x89, 0xB8}), out_slot(6, {0x03, 0x09, 0xB8})})));
  exchange({0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F});
  EXPECT_EQ(rec.take(), V({"309#0B0A0F0E0D0C"}));
  rx("289#0B0A0F0E0D0C");
  auto in = exchange({0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F});
  EXPECT_EQ(hex(in), "0A 0B 0C 0D 0E 0F");
  EXPECT_TRUE(rec.take().empty());  // unchanged data: no frame
}

TEST_F(GatewayFixture, TxOnChangeOnly) {
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({out_slot(2, {0x01, 0x00, 0x00})})));
  exchange({0, 0});
  EXPECT_EQ(rec.take(), V({"100#0000"}));  // first Data_Exchange after release: sent once
  exchange({0, 0});
  EXPECT_TRUE(rec.take().empty());
  exchange({0, 1});
  EXPECT_EQ(rec.take(), V({"100#0001"}));
  exchange({0, 1});
  exchange({0, 1});
  EXPECT_TRUE(rec.take().empty());
}

TEST_F(GatewayFixture, TxSlotsInSlotOrderWithinOneExchange) {
  ASSERT_TRUE(
      configure(UserPrm{}, cfg_of({out_slot(1, {0x03, 0x00, 0x00}), out_slot(1, {0x01, 0x00, 0x00}),
                                   out_slot(2, {0x20, 0x12, 0x34, 0x56, 0x00})})));
  exchange({1, 2, 3, 4});
  EXPECT_EQ(rec.take(), V({"300#01", "100#02", "00123456#0304"}));
}

TEST_F(GatewayFixture, CyclicSendEveryCycleNotRestartedByChange) {
  // manual §5.2.3: 03,E8 = every 1000 ms; docs/slots.md "Data exchange in normal mode": the timer
  // runs freely from release.
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({out_slot(1, {0x03, 0x09, 0x00, 0x03, 0xE8})})));
  const Time release = now;
  exchange({0x01});
  ASSERT_EQ(rec.take(), V({"309#01"}));
  run_until(release + milliseconds(400));
  exchange({0x02});  // change at 400 ms: sent now, the cycle keeps its phase
  run_until(release + milliseconds(3500));
  ASSERT_EQ(rec.sent.size(), 4u);
  EXPECT_EQ(rec.sent[0].time, release + milliseconds(400));
  EXPECT_EQ(rec.sent[1].time, release + milliseconds(1000));
  EXPECT_EQ(rec.sent[2].time, release + milliseconds(2000));
  EXPECT_EQ(rec.sent[3].time, release + milliseconds(3000));
  EXPECT_EQ(rec.take(), V({"309#02", "309#02", "309#02", "309#02"}));
}

TEST_F(GatewayFixture, CyclicAnd29BitIdentifier) {
  ASSERT_TRUE(
      configure(UserPrm{}, cfg_of({out_slot(2, {0x20, 0x12, 0x34, 0x56, 0xB8, 0x00, 0x0A})})));
  exchange({0x12, 0x34});
  run_for(milliseconds(25));
  EXPECT_EQ(rec.take(), V({"00123456#3412", "00123456#3412", "00123456#3412"}));
}

TEST_F(GatewayFixture, RxZeroFillsShortFrames) {
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({in_slot(4, {0x01, 0x81, 0x00}), dummy_out()})));
  rx("181#11223344");
  EXPECT_EQ(hex(exchange({0})), "11 22 33 44");
  rx("181#55");
  EXPECT_EQ(hex(exchange({0})), "55 00 00 00");  // docs/slots.md "Data exchange in normal mode":
                                                 // the rest is zero
  rx("181#0102030405060708");
  EXPECT_EQ(hex(exchange({0})), "01 02 03 04");  // min(DLC, n) bytes taken
}

TEST_F(GatewayFixture, RxAppliesForm) {
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({in_slot(8, {0x01, 0x81, 0x8E}), dummy_out()})));
  rx("181#0201030408070605");
  EXPECT_EQ(hex(exchange({0})), "01 02 03 04 05 06 07 08");  // manual §5.2.2: 8E
}

TEST_F(GatewayFixture, RxCounterWrapsAt256) {
  UserPrm p;
  p.rx_counter = true;
  ASSERT_TRUE(configure(p, cfg_of({in_slot(3, {0x01, 0x81, 0x00}), dummy_out()})));
  for (int i = 1; i <= 255; ++i) rx("181#AABB");
  EXPECT_EQ(hex(exchange({0})), "AA BB FF");
  rx("181#AABB");
  EXPECT_EQ(hex(exchange({0})), "AA BB 00");  // manual §5.1.2: 8-bit counter, modulo 256
  rx("181#CC");
  EXPECT_EQ(hex(exchange({0})), "CC 00 01");
}

TEST_F(GatewayFixture, TxCounterChangeSendsWithoutTheCounterByte) {
  UserPrm p;
  p.tx_counter = true;
  ASSERT_TRUE(configure(p, cfg_of({out_slot(3, {0x02, 0x01, 0x00})})));
  exchange({0x11, 0x22, 0x00});
  exchange({0x11, 0x22, 0x01});  // manual §5.1.2: a changed counter byte sends the frame again
  exchange({0x11, 0x22, 0x01});
  EXPECT_EQ(rec.take(), V({"201#1122", "201#1122"}));
}

TEST_F(GatewayFixture, LaterRxSlotWins) {
  // manual §5.2.1: the earlier slot with the same Rx identifier never updates.
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({in_slot(1, {0x01, 0x81, 0x00}),
                                           in_slot(1, {0x01, 0x81, 0x00}), dummy_out()})));
  rx("181#77");
  EXPECT_EQ(hex(exchange({0})), "00 77");
}

TEST_F(GatewayFixture, RemoteFramesAndOtherKindsIgnored) {
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({in_slot(1, {0x01, 0x81, 0x00}), dummy_out()})));
  rx("181#R1");
  rx("00000181#99");  // a 29-bit frame with the same number is another identifier
  EXPECT_EQ(hex(exchange({0})), "00");
}

TEST_F(GatewayFixture, DummyOutputSendsNothing) {
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({dummy_out()})));
  exchange({0x42});
  exchange({0x43});
  EXPECT_TRUE(rec.take().empty());  // manual §5.1.4: 0x07F8 assigns no CAN identifier
}

TEST_F(GatewayFixture, FramesBeforeDataExchUpdateSlotBuffers) {
  // docs/slots.md "Data exchange in normal mode": frames that arrive before Data_Exch still update
  // the slot buffers.
  const auto cfg = cfg_of({in_slot(1, {0x01, 0x81, 0x00}), dummy_out()});
  ASSERT_TRUE(configure(UserPrm{}, cfg));
  gw->dp().set_prm(kMaster, dp::with_lock_req(make_set_prm(UserPrm{})), now);  // to Wait_Cfg
  ASSERT_EQ(gw->dp().state(), dp::SlaveState::WaitCfg);
  rx("181#5A");
  ASSERT_TRUE(gw->dp().chk_cfg(kMaster, cfg, now));  // the same configuration keeps the buffers
  EXPECT_EQ(hex(exchange({0})), "5A");
  // A different configuration starts from a zeroed image.
  const auto other = cfg_of({in_slot(2, {0x01, 0x81, 0x00}), dummy_out()});
  gw->dp().set_prm(kMaster, dp::with_lock_req(make_set_prm(UserPrm{})), now);
  ASSERT_TRUE(gw->dp().chk_cfg(kMaster, other, now));
  EXPECT_EQ(hex(exchange({0})), "00 00");
}

TEST_F(GatewayFixture, RxWhileNotInDataExchStillUpdates) {
  ASSERT_TRUE(configure(UserPrm{}, cfg_of({in_slot(1, {0x01, 0x81, 0x00}), dummy_out()}), 20));
  run_for(milliseconds(30));  // watchdog: Wait_Prm, configuration kept
  ASSERT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  rx("181#5A");
  EXPECT_EQ(gw->status().rx_frames, 1u);
}

TEST_F(GatewayFixture, LayerTwoReleaseAfterWatchdogResendsEverySlot) {
  const auto cfg = cfg_of({out_slot(1, {0x01, 0x00, 0x00})});
  ASSERT_TRUE(configure(UserPrm{}, cfg, 20));
  exchange({0x07});
  EXPECT_EQ(rec.take(), V({"100#07"}));
  run_for(milliseconds(30));
  ASSERT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  ASSERT_TRUE(configure(UserPrm{}, cfg, 20));
  exchange({0x07});  // same data, but transmission restarted: sent once again
  EXPECT_EQ(rec.take(), V({"100#07"}));
}

TEST_F(GatewayFixture, FullImage48SlotsAnd244Bytes) {
  std::vector<std::uint8_t> cfg;
  for (int i = 0; i < 30; ++i) {
    auto b = cfg_of({out_slot(8, {0x02, static_cast<std::uint8_t>(i), 0x00})});
    cfg.insert(cfg.end(), b.begin(), b.end());
  }
  for (int i = 0; i < 18; ++i) {
    auto b = cfg_of({in_slot(1, {0x03, static_cast<std::uint8_t>(i), 0x00})});
    cfg.insert(cfg.end(), b.begin(), b.end());
  }
  auto b = cfg_of({});
  ASSERT_TRUE(configure(UserPrm{}, cfg));
  std::vector<std::uint8_t> out(240);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<std::uint8_t>(i);
  exchange(out);
  EXPECT_EQ(rec.sent.size(), 30u);
  rx("311#AB");
  EXPECT_EQ(exchange(out)[17], 0xAB);
}

TEST_F(GatewayFixture, StatusCountsFrames) {
  ASSERT_TRUE(configure(UserPrm{},
                        cfg_of({in_slot(1, {0x01, 0x81, 0x00}), out_slot(1, {0x02, 0x01, 0x00})})));
  exchange({1});
  exchange({2});
  rx("181#01");
  const auto s = gw->status();
  EXPECT_EQ(s.tx_frames, 2u);
  EXPECT_EQ(s.rx_frames, 1u);
  EXPECT_EQ(s.data_exchanges, 2u);
  EXPECT_TRUE(s.released);
}

}  // namespace
}  // namespace candp2::gw::test

// The FDL master station (docs/profibus.md): exact bytes against the capture in
// docs/profibus.md "A real master's first telegrams", FCB per station, slot time, retries,
// corrupted and foreign answers.
#include "profibus_sim/fdl/fdl_master.hpp"

#include <gtest/gtest.h>

#include "fdl_capture.hpp"
#include "fixture.hpp"
#include "link_rigs.hpp"

namespace candp2::fdl::test {
namespace {

using dp::Response;

// A lone FDL master whose line is recorded; answers are fed by hand.
struct LoneMaster : ::testing::Test {
  Time now{0};
  MemoryLog log;
  std::vector<std::string> sent;
  Time sent_at{0};  // when the last telegram went out
  FdlMaster line{{.address = 2, .baud = 19200, .slot_time_bits = 100, .retries = 1},
                 [this](std::span<const std::uint8_t> b, Time t) {
                   sent.push_back(hex_bytes(b));
                   sent_at = t;
                 },
                 &log};
  std::vector<Response> done;

  void request(dp::Service s, std::vector<std::uint8_t> data = {}) {
    line.station(3).request({s, 2, std::move(data)}, now,
                            [this](const Response& r, Time) { done.push_back(r); });
  }
  void answer(const char* bytes) { line.on_bytes(B(bytes), now); }
  void run_to(Time t) {
    while (auto d = line.next_deadline()) {
      if (*d > t) break;
      now = std::max(now, *d);
      line.advance(now);
    }
    now = t;
    line.advance(now);
  }
  // FDL_Status request and its answer (SD1, FC 0x00 slave OK; FCS 02+03+00).
  void status_ok() {
    ASSERT_EQ(sent.back(), kCapFdlStatus);
    now += milliseconds(4);
    answer("10 02 03 00 05 16");
    run_to(now + milliseconds(2));  // TSYN, then the DP request goes out
  }
};

TEST_F(LoneMaster, FdlStatusFirstThenFcbOneFcvZeroThenToggled) {
  request(dp::Service::SlaveDiag);
  status_ok();
  EXPECT_EQ(sent.back(), kCapSlaveDiag1);  // docs/profibus.md: FCB=1 FCV=0
  answer("68 10 10 68 82 83 08 3E 3C 02 05 00 FF 04 A4 00 00 00 00 00 35 16");
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].status, Response::Status::Ok);
  EXPECT_EQ(hex_bytes(done[0].data), "02 05 00 FF 04 A4 00 00 00 00 00");
  run_to(now + milliseconds(2));
  request(dp::Service::SlaveDiag);
  run_to(now + milliseconds(2));
  EXPECT_EQ(sent.back(), kCapSlaveDiag2);  // FCB=0 FCV=1
  EXPECT_EQ(line.stats(3)->fdl_status, 1u);
}

TEST_F(LoneMaster, SlotTimeRunsFromTheRequestsLastCharacterAndARetryRepeatsTheFcb) {
  request(dp::Service::SlaveDiag);
  status_ok();
  const Time t0 = sent_at;
  ASSERT_EQ(sent.back(), kCapSlaveDiag1);
  // 11 characters × 11 bits at 19200 baud = 6302.1 µs, slot time 100 bits = 5208.3 µs (each rounded
  // up to the microsecond).
  const Time deadline = t0 + microseconds(6303) + microseconds(5209);
  EXPECT_EQ(line.next_deadline(), deadline);
  run_to(deadline - microseconds(1));
  EXPECT_EQ(sent.size(), 2u);
  run_to(deadline);
  ASSERT_EQ(sent.size(), 3u);
  EXPECT_EQ(sent.back(), kCapSlaveDiag1);  // the same FCB (docs/profibus.md)
  EXPECT_TRUE(line.repeating());           // the repeat is on the line
  EXPECT_EQ(line.stats(3)->timeouts, 1u);
  run_to(now + milliseconds(20));  // max_retry_limit 1: the station is lost
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].status, Response::Status::NoResponse);
  EXPECT_EQ(line.stats(3)->lost, 1u);
  EXPECT_TRUE(log.contains("station lost"));
  request(dp::Service::SlaveDiag);  // FDL_Status again first
  EXPECT_EQ(sent.back(), kCapFdlStatus);
}

TEST_F(LoneMaster, CorruptedOrForeignAnswerIsNoAnswerAndTheRequestIsRepeated) {
  request(dp::Service::SetPrm, B("88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF"));
  status_ok();
  ASSERT_EQ(sent.size(), 2u);
  answer("10 02 04 00 06 16");  // from station 4: not taken
  answer("10 02 03 00 FF 16");  // bad FCS
  EXPECT_TRUE(done.empty());
  EXPECT_EQ(line.line_stats().fcs_errors, 1u);
  EXPECT_EQ(line.stats(3)->invalid, 1u);
  // A character arrived: the master waits for a whole telegram (255 characters) before the retry.
  run_to(now + milliseconds(155));  // 146.1 ms; the retry's slot ends ~20 ms later
  ASSERT_EQ(sent.size(), 3u);
  EXPECT_EQ(sent[2], sent[1]);  // repeated, same FCB
  answer("E5");
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].status, Response::Status::Ok);
}

TEST_F(LoneMaster, NegativeAnswersAreRefusals) {
  request(dp::Service::DataExchange, {1, 2});
  status_ok();
  answer("10 02 03 03 08 16");  // RS: not in Data_Exch
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].status, Response::Status::Refused);
}

// The simulated master over FDL against a real gateway behind the slave front end produces the
// telegrams of the capture in docs/profibus.md "A real master's first telegrams" byte for byte
// (master 2, slave 3, 19200 baud).
TEST(FdlMasterCapture, FirstTelegramsMatchTheCapture) {
  Time now{0};
  gw::test::Recorder rec;
  rec.now = &now;
  dp::test::FdlRig rig(19200);
  dp::DpMaster master({.address = 2, .retry_delay = milliseconds(100)});
  gw::Gateway g({.address = 3}, rec, now);
  const auto prm = B("88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF");
  const auto cfg = B("43 85 02 89 B8 83 85 03 09 B8");
  rig.add(master, g.dp(), {prm, cfg, {{0, {}}, {{}, 0}}, "gw"});
  for (int i = 0; i < 6; ++i) master.image().outputs[i] = static_cast<std::uint8_t>(0x11 * (i + 1));
  Time next_cycle{0};
  while (now < milliseconds(400)) {
    Time t = next_cycle;
    if (auto d = rig.next_deadline()) t = std::min(t, *d);
    if (auto d = g.next_deadline()) t = std::min(t, *d);
    now = std::max(now, t);
    g.advance(now);
    rig.advance(now);
    if (now >= next_cycle) {
      master.cycle(now);
      next_cycle += milliseconds(10);
    }
  }
  ASSERT_GE(rig.sent.size(), 7u);
  EXPECT_EQ(H(rig.sent[0]), kCapFdlStatus);
  EXPECT_EQ(H(rig.sent[1]), kCapSlaveDiag1);
  EXPECT_EQ(H(rig.sent[2]), kCapSetPrm);
  EXPECT_EQ(H(rig.sent[3]), kCapChkCfg);
  EXPECT_EQ(H(rig.sent[4]), kCapSlaveDiag2);
  EXPECT_EQ(H(rig.sent[5]), kCapDataExch1);
  EXPECT_EQ(H(rig.sent[6]), kCapDataExch2);
  EXPECT_EQ(master.slave(3)->state, dp::MasterSlaveState::DataExch);
  EXPECT_EQ(rig.line.stats(3)->timeouts, 0u);  // nothing repeated
  EXPECT_FALSE(rig.line.repeating());
}

// A lossy line: every 5th telegram is corrupted; retries keep the station in Data_Exch.
TEST(FdlMasterCapture, CorruptedTelegramsAreRetriedAndTheCycleGoesOn) {
  Time now{0};
  gw::test::Recorder rec;
  rec.now = &now;
  dp::test::FdlRig rig;
  rig.pipe.corrupt_every = 5;
  dp::DpMaster master({.address = 2, .retry_delay = milliseconds(100)});
  gw::Gateway g({.address = 3}, rec, now);
  const auto prm = gw::make_set_prm(gw::UserPrm{}, 0);
  rig.add(master, g.dp(),
          {{prm.begin(), prm.end()}, gw::test::cfg_of({gw::test::dummy_out()}), {}, "gw"});
  Time next_cycle{0};
  while (now < milliseconds(500)) {
    Time t = next_cycle;
    if (auto d = rig.next_deadline()) t = std::min(t, *d);
    if (auto d = g.next_deadline()) t = std::min(t, *d);
    now = std::max(now, t);
    g.advance(now);
    rig.advance(now);
    if (now >= next_cycle) {
      master.cycle(now);
      next_cycle += milliseconds(10);
    }
  }
  EXPECT_EQ(master.slave(3)->state, dp::MasterSlaveState::DataExch);
  EXPECT_GT(rig.line.stats(3)->timeouts, 5u);  // each repeated: the station was never lost
  EXPECT_EQ(rig.line.stats(3)->lost, 0u);
  EXPECT_EQ(master.slave(3)->station_lost, 0u);
  EXPECT_GT(rig.line.line_stats().fcs_errors + rig.front.line_stats().fcs_errors, 0u);
}

}  // namespace
}  // namespace candp2::fdl::test

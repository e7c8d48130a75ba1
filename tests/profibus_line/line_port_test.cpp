// The role-master line on a real pseudo-terminal: the plant's PROFIBUS master line behind its
// serial port (profibus_line/line_port.hpp) in an event loop; the test holds the pty's terminal
// end and plays the remote station by hand, byte for byte.
#include "profibus_line/line_port.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <termios.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "modbus/plant_faces.hpp"
#include "plant/plant.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"
#include "profibus_sim/fdl/fdl.hpp"
#include "profibus_sim/fdl/line_stats.hpp"

namespace candp2::profibus_line {
namespace {

namespace fs = std::filesystem;

struct MasterLineFixture : ::testing::Test {
  void SetUp() override {
    char tmpl[] = "/tmp/candp2-mline-XXXXXX";
    dir = ::mkdtemp(tmpl);
    // manual §5.1.4 slots, as candp2d's configuration encodes them; master 2 cycles every 5 ms.
    const auto text = R"({"master": {"address": 2, "cycle_ms": 5, "retry_ms": 100},
        "profibus": {"port": "pty:)" +
                      dir + R"(/pb", "baud": 19200, "role": "master",
                     "slot_time_bits": 100, "retries": 1},
        "gateways": [{"address": 3, "slots": [
          {"io": "input", "address": 172, "length": 6, "comment": "02,89,B8"},
          {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"}]}]})";
    auto c = config::parse_daemon(text, "test.json");
    ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(c))
        << std::get<config::ConfigError>(c).to_string();
    cfg = std::get<config::DaemonConfig>(c);  // the plant refers to it
    std::string error;
    plant = plant::Plant::build(cfg, {}, loop.now(), &error);
    ASSERT_TRUE(plant) << error;
    ASSERT_NE(plant->master_line(), nullptr);
    port = MasterLinePort::open(*cfg.profibus, *plant->master_line(), loop, nullptr, &error);
    ASSERT_TRUE(port) << error;
    // The remote station's end: the terminal end of the pty, raw.
    peer = ::open((dir + "/pb").c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    ASSERT_GE(peer, 0);
    termios t{};
    ASSERT_EQ(::tcgetattr(peer, &t), 0);
    ::cfmakeraw(&t);
    ASSERT_EQ(::tcsetattr(peer, TCSANOW, &t), 0);
    // The plant's timer, as candp2d arms it: at next_deadline(), re-armed after every event.
    deferred = loop.add_deferred([this] {
      rearm();
      return false;
    });
    rearm();
  }
  void rearm() {
    const auto next = plant->next_deadline();
    if (timer && next == armed) return;
    if (timer) loop.cancel_timer(timer);
    timer = 0;
    armed = next;
    if (!next) return;
    timer = loop.add_timer(std::max(Duration(0), *next - loop.now()), [this] {
      timer = 0;
      plant->advance(loop.now());
    });
  }
  void TearDown() override {
    if (deferred) loop.remove_deferred(deferred);
    if (timer) loop.cancel_timer(timer);
    if (peer >= 0) ::close(peer);
    port.reset();
    plant.reset();
    fs::remove_all(dir);
  }
  // Runs the loop until the peer has read `n` bytes (or 2 s passed).
  std::vector<std::uint8_t> read_peer(std::size_t n) {
    std::vector<std::uint8_t> got;
    loop.run_until(
        [&] {
          std::uint8_t buf[256];
          const ssize_t r = ::read(peer, buf, sizeof buf);
          if (r > 0) got.insert(got.end(), buf, buf + r);
          return got.size() >= n;
        },
        milliseconds(2000));
    return got;
  }
  bool lost() const {
    const auto v = plant->master().slave(3);
    return v && v->last_diag && ((*v->last_diag)[0] & dp::kDiag1StationNonExistent);
  }
  station::LineStatus status() { return plant->master_line()->status(3, plant->master()); }
  const fdl::StationCounters& stats3() const {
    return plant->master_line()->statistics().station(3);
  }
  // The next telegram the master puts on the line (nullopt after 2 s without one).
  std::optional<fdl::Telegram> next_request() {
    std::optional<fdl::Telegram> got;
    loop.run_until(
        [&] {
          std::uint8_t buf[256];
          const ssize_t r = ::read(peer, buf, sizeof buf);
          if (r > 0) peer_rx.feed(std::span<const std::uint8_t>(buf, static_cast<std::size_t>(r)));
          while (!got)
            if (auto ev = peer_rx.next(); !ev)
              break;
            else if (ev->error == fdl::Error::None)
              got = ev->telegram;
          return got.has_value();
        },
        milliseconds(2000));
    return got;
  }
  void answer(const fdl::Telegram& t) {
    const auto bytes = fdl::encode(t);
    ASSERT_EQ(::write(peer, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  }
  // Plays station 3 as a DP slave: FDL_Status, Slave_Diag (Prm_Req), Set_Prm, Chk_Cfg, Slave_Diag
  // (ready), then answers `exchanges` Data_Exchange requests (6 input bytes); the next one is
  // read and stays unanswered.
  void parameterize(int exchanges = 0) {
    bool prm_done = false;
    for (int i = 0; i < 10 + exchanges; ++i) {
      const auto t = next_request();
      ASSERT_TRUE(t);
      ASSERT_EQ(t->da, 3);
      if (t->function() == fdl::kFcFdlStatus) {
        answer(fdl::Telegram::no_data(2, 3, fdl::response_fc(fdl::kFcOk)));
      } else if (t->dsap == fdl::kSapSlaveDiag) {
        // The standard diagnosis (docs/dp-slave.md "Diagnosis"): Prm_Req, no master before Set_Prm.
        const std::vector<std::uint8_t> diag = {
            0,
            static_cast<std::uint8_t>(dp::kDiag2AlwaysOne | (prm_done ? 0 : dp::kDiag2PrmReq)),
            0,
            prm_done ? std::uint8_t{2} : dp::kNoMaster,
            0x04,
            0xA4};
        answer(fdl::Telegram::with_data(2, 3, fdl::response_fc(fdl::kFcDl), fdl::kSapChkCfg,
                                        fdl::kSapSlaveDiag, diag));
      } else if (t->dsap == fdl::kSapSetPrm || t->dsap == fdl::kSapChkCfg) {
        prm_done = prm_done || t->dsap == fdl::kSapChkCfg;
        answer(fdl::Telegram::sc());
      } else {
        ASSERT_FALSE(t->dsap) << "unexpected DP service";  // Data_Exchange: default SAP
        if (exchanges-- == 0) return;
        answer(fdl::Telegram::with_data(2, 3, fdl::response_fc(fdl::kFcDl), std::nullopt,
                                        std::nullopt, std::vector<std::uint8_t>(6, 0)));
      }
    }
    FAIL() << "no unanswered Data_Exchange after " << 10 + exchanges << " telegrams";
  }

  EventLoop loop;
  std::string dir;
  config::DaemonConfig cfg;
  std::unique_ptr<plant::Plant> plant;
  std::unique_ptr<MasterLinePort> port;
  EventLoop::TimerId timer = 0;
  EventLoop::DeferredId deferred = 0;
  std::optional<Time> armed;
  int peer = -1;
  fdl::StreamParser peer_rx;  // the remote station's receiver
};

TEST(MasterLatencyAllowance, PtyAndSlowAdaptersGetMoreThanALowLatencyPort) {
  // docs/profibus.md "Timing in role master".
  EXPECT_EQ(master_latency_allowance(true, false), milliseconds(20));
  EXPECT_EQ(master_latency_allowance(false, false), milliseconds(20));
  EXPECT_EQ(master_latency_allowance(false, true), milliseconds(3));
}

TEST_F(MasterLineFixture, SilentStationIsAskedTwiceThenShowsStationNonExistent) {
  // the capture in docs/profibus.md "A real master's first telegrams": the master's first telegram
  // is FDL_Status 10 03 02 49 4E 16.
  const std::vector<std::uint8_t> fdl_status = {0x10, 0x03, 0x02, 0x49, 0x4E, 0x16};
  const Time t0 = loop.now();
  auto got = read_peer(6);
  ASSERT_EQ(got, fdl_status);
  const Time first = loop.now();
  // No answer: one retry (retries = 1) of the same telegram after slot time + allowance.
  got = read_peer(6);
  ASSERT_EQ(got, fdl_status);
  const Time second = loop.now();
  // 100 bit times at 19200 baud (5.2 ms) + the pty allowance (20 ms) at least.
  EXPECT_GE(second - first, milliseconds(20));
  ASSERT_TRUE(loop.run_until([&] { return lost(); }, milliseconds(2000)));
  EXPECT_GE(loop.now() - t0, milliseconds(40));
  const auto st = status();
  EXPECT_EQ(st.role, 2);
  EXPECT_GE(st.requests, 2u);
  EXPECT_GE(st.retries, 1u);
  EXPECT_FALSE(st.present);
  EXPECT_EQ(st.response_us, 0u);
  // The line statistics (docs/profibus.md "Line statistics in role master"): station 3 is
  // configured but never answered, so it is missing, never lost; its requests were repeated.
  EXPECT_EQ(plant->master_line()->statistics().live(3), fdl::Live::Missing);
  EXPECT_EQ(stats3().lost, 0u);
  EXPECT_GE(stats3().repeats, 1u);
  EXPECT_EQ(st.retries, stats3().repeats);  // one count: station_retries shows the repeats
  EXPECT_EQ(stats3().syncs, 0u);
  // The Modbus face shows the master's Station_Non_Existent (diag byte 0 bit 0), DP state 0.
  modbus::RemoteStationFace face(*plant, 3, "gw3");
  const auto block = face.status(loop.now());
  EXPECT_EQ(block[modbus::status::kDpState], 0);
  EXPECT_EQ(block[modbus::status::kDiag] & 0x01, 1);
  EXPECT_EQ(block[modbus::status::kDiag + 3], dp::kNoMaster);
  EXPECT_EQ(block[modbus::status::kLineRole], 2);
  EXPECT_EQ(block[modbus::status::kRxFrames + 1], 0);
  EXPECT_EQ(block[modbus::status::kDpAddress], 3);
  // Control: a power cycle is refused, re-parameterization is accepted.
  EXPECT_TRUE(face.refuses(modbus::Control::PowerCycle));
  EXPECT_FALSE(face.refuses(modbus::Control::Reparameterize));
}

TEST_F(MasterLineFixture, AnsweredFdlStatusIsFollowedBySlaveDiagAndTimed) {
  const std::vector<std::uint8_t> fdl_status = {0x10, 0x03, 0x02, 0x49, 0x4E, 0x16};
  ASSERT_EQ(read_peer(6), fdl_status);
  // docs/profibus.md: FDL_Status answer SD1, FC 0x00 (slave, OK), DA 2 SA 3, FCS 05.
  const std::uint8_t answer[] = {0x10, 0x02, 0x03, 0x00, 0x05, 0x16};
  ASSERT_EQ(::write(peer, answer, sizeof answer), static_cast<ssize_t>(sizeof answer));
  // Then Slave_Diag with FCB=1 FCV=0, byte for byte as in the capture.
  const std::vector<std::uint8_t> slave_diag = {0x68, 0x05, 0x05, 0x68, 0x83, 0x82,
                                                0x6D, 0x3C, 0x3E, 0xEC, 0x16};
  EXPECT_EQ(read_peer(11), slave_diag);
  const auto st = status();
  EXPECT_GE(st.telegrams, 1u);  // our FDL_Status answer
  EXPECT_GT(st.response_max_us, 0u);
  EXPECT_LT(st.response_max_us, 2000000u);
  EXPECT_EQ(st.response_us, st.response_max_us);
}

TEST_F(MasterLineFixture, CorruptedAnswerIsNoAnswerAndIsRepeated) {
  ASSERT_EQ(read_peer(6).size(), 6u);
  // A corrupted answer (wrong FCS): counted on the line, not taken; the master repeats.
  const std::uint8_t bad[] = {0x10, 0x02, 0x03, 0x00, 0x06, 0x16};
  ASSERT_EQ(::write(peer, bad, sizeof bad), static_cast<ssize_t>(sizeof bad));
  const std::vector<std::uint8_t> fdl_status = {0x10, 0x03, 0x02, 0x49, 0x4E, 0x16};
  EXPECT_EQ(read_peer(6), fdl_status);
  EXPECT_GE(status().fcs_errors, 1u);
  EXPECT_EQ(status().response_max_us, 0u);
  // The dropped answer is the station's illegal telegram, the second FDL_Status its repeat.
  EXPECT_EQ(stats3().illegals, 1u);
  EXPECT_EQ(stats3().repeats, 1u);
  EXPECT_EQ(status().retries, 1u);  // the same repeat, counted once
  EXPECT_EQ(plant->master_line()->statistics().illegals_unattributed(), 0u);
}

TEST_F(MasterLineFixture, ParameterizationCountsOneSyncAndTwoDiagnostics) {
  parameterize();
  const auto& line = plant->master_line()->statistics();
  EXPECT_EQ(line.live(3), fdl::Live::Ok);
  EXPECT_EQ(stats3().syncs, 1u);        // one Set_Prm
  EXPECT_EQ(stats3().diagnostics, 2u);  // before Set_Prm and after Chk_Cfg
  EXPECT_EQ(stats3().repeats, 0u);
  EXPECT_EQ(stats3().illegals, 0u);
  EXPECT_EQ(stats3().lost, 0u);
  // Only the configured station is listed: the master itself is no station of the live list.
  EXPECT_EQ(line.stations(), std::vector<std::uint8_t>{3});
}

TEST_F(MasterLineFixture, StationThatStopsAnsweringIsRepeatedPerRetryLimitThenLost) {
  parameterize(2);  // in data exchange; then a Data_Exchange goes unanswered, and its repeat
  const auto& line = plant->master_line()->statistics();
  EXPECT_EQ(stats3().lost, 0u);
  // Lost (it dropped out of data exchange) is counted when the master gives up: its next
  // telegram to the station is another one.
  ASSERT_TRUE(loop.run_until([&] { return stats3().lost > 0; }, milliseconds(2000)));
  EXPECT_EQ(stats3().lost, 1u);
  EXPECT_EQ(stats3().repeats, cfg.profibus->bus.retry_limit);
  EXPECT_EQ(stats3().repeats_max, cfg.profibus->bus.retry_limit);
  EXPECT_EQ(line.live(3), fdl::Live::Missing);
  EXPECT_EQ(stats3().illegals, 0u);
  // While it stays missing its FDL_Status is repeated too: repeats grow, it is not lost again,
  // and without a token on the line repeats_max is the most repeats of one request.
  const std::uint64_t later = cfg.profibus->bus.retry_limit + 2;
  ASSERT_TRUE(loop.run_until([&] { return stats3().repeats >= later; }, milliseconds(3000)));
  EXPECT_EQ(stats3().lost, 1u);
  EXPECT_EQ(stats3().repeats_max, cfg.profibus->bus.retry_limit);
}

}  // namespace
}  // namespace candp2::profibus_line

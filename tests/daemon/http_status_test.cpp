// The HTTP face's pure parts: the cycle lateness statistic, the bus monitor (bits with stuff bits,
// the trace ring) and the slot engine's per-slot counters the slot table shows.
#include "http/http_status.hpp"

#include <gtest/gtest.h>

#include <variant>

#include "config/config.hpp"
#include "gateway/slot_engine.hpp"
#include "plant/cycle_stats.hpp"

namespace candp2 {
namespace {

TEST(CycleStats, LatenessAgainstTheGrid) {
  plant::CycleStats s;
  s.start(milliseconds(10));
  // Cycles +0, +150, +30 µs after their grid points, then one 2 ms late, then one whose grid point
  // lies 25 ms back: it runs 25 ms late (the overrun counts) and the two grid points it overran
  // are missed.
  s.record(Time{10'000}, Time{10'000}, 0);
  s.record(Time{20'000}, Time{20'150}, 0);
  s.record(Time{30'000}, Time{30'030}, 0);
  s.record(Time{40'000}, Time{42'000}, 0);
  s.record(Time{50'000}, Time{75'000}, 2);
  const auto sum = s.summary();
  EXPECT_EQ(sum.cycles, 5u);
  EXPECT_EQ(sum.missed, 2u);
  EXPECT_EQ(sum.samples, 5u);
  EXPECT_EQ(sum.max_us, 25'000u);
  EXPECT_EQ(sum.max_ever_us, 25'000u);
  EXPECT_EQ(sum.p50_us, 150u);   // 0 30 150 2000 25000
  EXPECT_EQ(sum.p99_us, 2000u);  // index floor(0.99 * 4) = 3
}

TEST(CycleStats, WindowKeepsTheLastSamples) {
  plant::CycleStats s;
  s.start(milliseconds(10));
  s.record(Time{0}, Time{5'000}, 0);  // 5 ms late, then pushed out of the window
  for (std::size_t k = 1; k <= plant::CycleStats::kSamples; ++k) {
    const Time due{static_cast<std::int64_t>(k) * 10'000};
    s.record(due, due + microseconds(100), 0);
  }
  const auto sum = s.summary();
  EXPECT_EQ(sum.samples, plant::CycleStats::kSamples);
  EXPECT_EQ(sum.max_us, 100u);
  EXPECT_EQ(sum.max_ever_us, 5000u);
  EXPECT_EQ(sum.missed, 0u);
}

TEST(BusMonitor, StuffedBitsUpperBound) {
  // 11-bit, 8 bytes: 47 + 64 = 111 bits unstuffed; stuffed part 34 + 64 = 98 → 24 stuff bits.
  const std::array<std::uint8_t, 8> eight{};
  EXPECT_EQ(http::frame_bits_stuffed(can::Frame::std_data(0x123, eight)), 111u + 24u);
  // 29-bit, 0 bytes: 67 unstuffed; stuffed part 54 → 13.
  EXPECT_EQ(http::frame_bits_stuffed(can::Frame::ext_data(0x1234567, {})), 67u + 13u);
  // Remote frame: no data bits even with DLC 8 (47 + (34 - 1) / 4 = 47 + 8).
  EXPECT_EQ(http::frame_bits_stuffed(can::Frame::rtr(0x123, false, 8)), 55u);
}

TEST(BusMonitor, CountsAndKeepsTheLastFrames) {
  http::BusMonitor m;
  const std::array<std::uint8_t, 1> one{0x42};
  EXPECT_TRUE(m.trace().empty());
  for (std::uint32_t i = 0; i < 3; ++i) m.on_frame(can::Frame::std_data(i, one), Time{i * 100});
  ASSERT_EQ(m.trace().size(), 3u);  // fewer than kTrace: all of them, oldest first
  EXPECT_EQ(m.trace().front().seq, 1u);
  EXPECT_EQ(m.trace().back().frame.id, 2u);
  for (std::uint32_t i = 3; i < http::BusMonitor::kTrace + 10; ++i)
    m.on_frame(can::Frame::std_data(i, one), Time{i * 100});
  EXPECT_EQ(m.frames(), http::BusMonitor::kTrace + 10);
  EXPECT_EQ(m.bits(), m.frames() * http::frame_bits_stuffed(can::Frame::std_data(0, one)));
  ASSERT_EQ(m.trace().size(), http::BusMonitor::kTrace);
  EXPECT_EQ(m.trace().front().seq, 11u);
  EXPECT_EQ(m.trace().front().frame.id, 10u);
  EXPECT_EQ(m.trace().back().time, Time{(http::BusMonitor::kTrace + 9) * 100});
}

struct Sink final : gw::TxPort {
  std::vector<can::Frame> sent;
  bool tx_active() const override { return true; }
  void transmit(const can::Frame& f) override { sent.push_back(f); }
};

TEST(SlotStats, CountsPerConfiguredSlot) {
  gw::SlotConfig cfg;
  gw::Slot tx;
  tx.index = 0;
  tx.kind = gw::SlotKind::Tx;
  tx.offset = 0;
  tx.length = tx.data_len = 2;
  tx.id = can::Ident{0x201, false};
  gw::Slot rx;
  rx.index = 1;
  rx.kind = gw::SlotKind::Rx;
  rx.offset = 0;
  rx.length = rx.data_len = 2;
  rx.id = can::Ident{0x181, false};
  cfg.slots = {tx, rx};
  gw::SlotEngine e;
  e.configure(cfg);
  Sink sink;
  std::array<std::uint8_t, 2> out{1, 2}, in{};
  e.on_release(Time{1000}, sink);
  e.on_outputs(out, sink, Time{2000});  // first data: sent
                                        // (docs/slots.md "Data exchange in normal mode")
  e.on_outputs(out, sink, Time{3000});  // unchanged: not sent
  out[1] = 3;
  e.on_outputs(out, sink, Time{4000});  // changed: sent
  const std::array<std::uint8_t, 2> b{7, 8};
  EXPECT_TRUE(e.on_frame(can::Frame::std_data(0x181, b), in, Time{5000}));
  EXPECT_FALSE(e.on_frame(can::Frame::std_data(0x182, b), in, Time{6000}));
  ASSERT_EQ(e.slot_stats().size(), 2u);
  EXPECT_EQ(sink.sent.size(), 2u);
  EXPECT_EQ(e.slot_stats()[0].frames, 2u);
  EXPECT_EQ(e.slot_stats()[0].last, Time{4000});
  EXPECT_EQ(e.slot_stats()[1].frames, 1u);
  EXPECT_EQ(e.slot_stats()[1].last, Time{5000});
  e.configure(cfg);  // a new configuration starts from zero
  EXPECT_EQ(e.slot_stats()[0].frames, 0u);
  EXPECT_FALSE(e.slot_stats()[1].last);
}

TEST(LedCodes, ManualTable331) {
  gw::GatewayStatus g;
  g.dp_state = dp::SlaveState::WaitPrm;
  auto c = station::led::codes(g);
  EXPECT_EQ(c.e, 3);  // 3 short flashes: waiting for the parameter telegram
  EXPECT_EQ(c.d, station::led::kOff);
  EXPECT_EQ(c.p, station::led::kOn);
  EXPECT_EQ(c.c, station::led::kOn);  // CAN bus OK
  g.dp_state = dp::SlaveState::WaitCfg;
  EXPECT_EQ(station::led::codes(g).e, 4);
  g.dp_state = dp::SlaveState::DataExch;
  g.bus_state = can::BusState::Warning;
  c = station::led::codes(g);
  EXPECT_EQ(c.d, station::led::kOn);
  EXPECT_EQ(c.e, station::led::kOff);
  EXPECT_EQ(c.c, 0x57);  // Morse 'W' short-long-long
  g.bus_state = can::BusState::ErrorPassive;
  EXPECT_EQ(station::led::codes(g).c, 0x45);  // Morse 'E'
  g.bus_state = can::BusState::BusOff;
  EXPECT_EQ(station::led::codes(g).c, 0x4F);  // Morse 'O'
}

constexpr const char* kConfig = R"({
  "modbus": {"listen": "127.0.0.1:1502"}, %HTTP%
  "buses": {"can0": {"type": "virtual"}},
  "gateways": [{"name": "gw3", "address": 3, "bus": "can0",
                "slots": [{"io": "output", "address": 0, "length": 2, "comment": "02,01,00"}]}]
})";

config::Result<config::DaemonConfig> parse_with(const std::string& http) {
  std::string text = kConfig;
  text.replace(text.find("%HTTP%"), 6, http);
  return config::parse_daemon(text, "t.json");
}

TEST(HttpConfig, ListenKey) {
  auto off = parse_with("");
  ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(off));
  EXPECT_FALSE(std::get<config::DaemonConfig>(off).http_listen);  // absent = off

  auto on = parse_with(R"("http": {"listen": "127.0.0.1:8080"},)");
  ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(on));
  ASSERT_TRUE(std::get<config::DaemonConfig>(on).http_listen);
  EXPECT_EQ(std::get<config::DaemonConfig>(on).http_listen->port, 8080);

  auto bad = parse_with(R"("http": {"listen": "localhost:80"},)");
  ASSERT_TRUE(std::holds_alternative<config::ConfigError>(bad));
  EXPECT_EQ(std::get<config::ConfigError>(bad).json_path, "$.http.listen");

  auto typo = parse_with(R"("http": {"listn": "127.0.0.1:80"},)");
  ASSERT_TRUE(std::holds_alternative<config::ConfigError>(typo));

  auto clash = parse_with(R"("http": {"listen": "127.0.0.1:1502"},)");
  ASSERT_TRUE(std::holds_alternative<config::ConfigError>(clash));
  EXPECT_NE(std::get<config::ConfigError>(clash).message.find("already used"), std::string::npos);
}

TEST(HttpConfig, ClientLimits) {
  auto dflt = parse_with(R"("http": {"listen": "127.0.0.1:8080"},)");
  ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(dflt));
  EXPECT_EQ(std::get<config::DaemonConfig>(dflt).http_max_clients, 64u);
  EXPECT_EQ(std::get<config::DaemonConfig>(dflt).http_idle_timeout_s, 60u);

  auto set = parse_with(
      R"("http": {"listen": "127.0.0.1:8080", "max_clients": 1100, "idle_timeout_s": 0},)");
  ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(set));
  EXPECT_EQ(std::get<config::DaemonConfig>(set).http_max_clients, 1100u);
  EXPECT_EQ(std::get<config::DaemonConfig>(set).http_idle_timeout_s, 0u);

  for (const auto* bad : {R"("http": {"listen": "127.0.0.1:8080", "max_clients": 0},)",
                          R"("http": {"listen": "127.0.0.1:8080", "max_clients": 10001},)",
                          R"("http": {"listen": "127.0.0.1:8080", "idle_timeout_s": -1},)"}) {
    auto r = parse_with(bad);
    ASSERT_TRUE(std::holds_alternative<config::ConfigError>(r)) << bad;
    EXPECT_EQ(std::get<config::ConfigError>(r).json_path.rfind("$.http.", 0), 0u) << bad;
  }
}

}  // namespace
}  // namespace candp2

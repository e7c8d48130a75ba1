// The in-process line in time (docs/profibus.md "The line in time"), in virtual time: TSYN, TSDR,
// TID1/TID2 and the slot time to the bit, retries and a lost station when the slot time says, a
// watchdog that expires when the cycle outgrows it, a repeat with the same bytes, a gateway capped
// at its MaxTsdr, the bus cycle as the prediction has it, and the watchdog rule held to the plant.
// Expected times come from the bus parameters and the telegrams' lengths, not from the output.
#include "plant/timed_line.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <tuple>
#include <variant>

#include "config/config.hpp"
#include "config/watchdog_check.hpp"
#include "gateway/line_limits.hpp"
#include "plant/plant.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"
#include "profibus_sim/fdl/line_timing.hpp"
#include "profibus_sim/fdl/watchdog_rule.hpp"

namespace candp2 {
namespace {

using plant::TimedLine;

// `n` gateways at DP addresses 3.., one output slot of 2 bytes each.
std::string config_text(std::size_t n, std::string master, std::string parameters_extra = "") {
  std::string gws;
  for (std::size_t i = 0; i < n; ++i) {
    if (i) gws += ",\n";
    gws += R"({ "name": "gw)" + std::to_string(i) + R"(", "address": )" + std::to_string(3 + i) +
           R"(, "bus": "can0", "parameters": { "can_bitrate": "500k" )" + parameters_extra +
           R"( }, "slots": [ { "io": "output", "address": )" + std::to_string(2 * i) +
           R"(, "length": 2, "comment": "02,01,00" } ] })";
  }
  return R"({ "master": )" + master + R"(, "buses": { "can0": { "type": "virtual" } },
              "gateways": [ )" +
         gws + "] }";
}

struct Rig {
  explicit Rig(const std::string& text, Duration line_step = Duration(0),
               Duration line_catch_up = Duration(0)) {
    auto parsed = config::parse_daemon(text, "line.json");
    if (auto* e = std::get_if<config::ConfigError>(&parsed)) {
      ADD_FAILURE() << e->message;
      return;
    }
    cfg = std::get<config::DaemonConfig>(parsed);
    std::string error;
    plant::Options o;
    o.log = &log;
    o.first_cycle_at_start = true;
    o.step = line_step;
    o.line_catch_up = line_catch_up;
    plant = plant::Plant::build(cfg, std::move(o), Time{0}, &error);
    EXPECT_TRUE(plant) << error;
  }
  void run_until(Time end) {
    while (const auto next = plant->next_deadline()) {
      if (*next > end) break;
      plant->advance(*next);
    }
    if (plant->now() < end) plant->advance(end);
  }
  TimedLine& line() { return *plant->timed_line(); }
  config::DaemonConfig cfg;
  MemoryLog log;
  std::unique_ptr<plant::Plant> plant;
};

fdl::Telegram decoded(const TimedLine::Telegram& t) {
  return fdl::decode(t.bytes).telegram.value_or(fdl::Telegram{});
}

TEST(TimedLine, IdealLineWithoutBaud) {
  Rig rig(config_text(1, R"({ "cycle_ms": 10 })"));
  ASSERT_TRUE(rig.plant);
  EXPECT_EQ(rig.plant->timed_line(), nullptr);
}

// 9.6 kbit/s, cycle 1 ms: the line is always the bottleneck, rotations run back to back, so every
// idle is exactly what the standard asks for.
TEST(TimedLine, KeepsTsynTsdrTidAndSlotTimeToTheBit) {
  Rig rig(config_text(1, R"({ "cycle_ms": 1, "baud": 9600,
                              "bus_parameters": { "min_tsdr_bits": 20, "gap_factor": 3 } })"));
  ASSERT_TRUE(rig.plant);
  TimedLine& line = rig.line();
  line.set_record(true);
  rig.run_until(Time{3'000'000});
  const auto& p = line.parameters();
  const auto& tg = line.record();
  ASSERT_GT(tg.size(), 40u);
  const std::uint64_t tid1 = 33 + 2 + 2 * p.tset_bits + p.tqui_bits;  // min_TSDR 20 < 37
  const std::uint64_t tid2 = std::max<std::uint64_t>(tid1, p.max_tsdr_bits);
  bool prm_seen = false;
  std::size_t tokens = 0, gaps = 0, exchanges = 0;
  for (std::size_t i = 0; i < tg.size(); ++i) {
    const auto& t = tg[i];
    EXPECT_EQ(t.end_bit - t.start_bit, 11 * t.bytes.size()) << i;
    const fdl::Telegram d = decoded(t);
    if (!t.from_master) {
      // The answer starts TSDR after the request's last character: 11 until Set_Prm set 20.
      ASSERT_GT(i, 0u);
      EXPECT_EQ(t.start_bit - tg[i - 1].end_bit, prm_seen ? 20u : 11u) << i;
      continue;
    }
    if (d.dsap == fdl::kSapSetPrm) prm_seen = true;
    if (d.kind == fdl::Kind::SD4) {
      ++tokens;
      EXPECT_EQ(d.da, 1);
      EXPECT_EQ(d.sa, 1);
    }
    if (d.kind == fdl::Kind::SD2 && !d.dsap && d.da == 3) ++exchanges;
    if (i == 0) continue;
    const auto& prev = tg[i - 1];
    const std::uint64_t idle = t.start_bit - prev.end_bit;
    EXPECT_GE(idle, fdl::kTsynBits) << i;
    const fdl::Telegram pd = decoded(prev);
    if (!prev.from_master) {
      EXPECT_EQ(idle, tid1) << i;  // after an answer: TID1
    } else if (pd.kind == fdl::Kind::SD4) {
      EXPECT_EQ(idle, tid2) << i;  // after the token: TID2
    } else {
      // A request nobody answered (the GAP's FDL_Status): the slot time, then the token at once.
      EXPECT_EQ(pd.function(), fdl::kFcFdlStatus) << i;
      EXPECT_NE(pd.da, 3) << i;
      EXPECT_EQ(idle, p.slot_time_bits) << i;
      EXPECT_EQ(d.kind, fdl::Kind::SD4) << i;
      ++gaps;
    }
  }
  EXPECT_GT(exchanges, 10u);
  // Every third rotation (gap_factor 3) asks one GAP address (2, 4, 5, ... not the gateway at 3).
  EXPECT_EQ(gaps, tokens / 3);
}

// A gateway answers no later than its GSD's MaxTsdr (gateway/line_limits.hpp): at 187.5 kbit/s
// 60 bit times, even when the master's Set_Prm asks for a min_TSDR of 80.
TEST(TimedLine, AGatewayAnswersNoLaterThanItsMaxTsdr) {
  Rig rig(config_text(1, R"({ "cycle_ms": 5, "baud": 187500,
                              "bus_parameters": { "min_tsdr_bits": 80, "max_tsdr_bits": 100,
                                                  "slot_time_bits": 200 } })"));
  ASSERT_TRUE(rig.plant);
  TimedLine& line = rig.line();
  line.set_record(true);
  rig.run_until(Time{200'000});
  ASSERT_EQ(rig.plant->master().slave(3)->state, dp::MasterSlaveState::DataExch);
  const std::uint32_t max_tsdr = *gw::max_tsdr_bits(187500);
  ASSERT_LT(max_tsdr, 80u);
  EXPECT_EQ(line.tsdr_bits(3), max_tsdr);
  const auto& tg = line.record();
  bool prm_seen = false;
  std::size_t capped = 0;
  for (std::size_t i = 1; i < tg.size(); ++i) {
    if (tg[i].from_master) {
      if (decoded(tg[i]).dsap == fdl::kSapSetPrm) prm_seen = true;
      continue;
    }
    EXPECT_EQ(tg[i].start_bit - tg[i - 1].end_bit, prm_seen ? max_tsdr : 11u) << i;
    capped += prm_seen;
  }
  EXPECT_GT(capped, 10u);
}

// A station that got a request and did not answer (as an offline one) gets the same bytes on the
// repeat: the line hands the request over, the repeat takes them from the telegram it travels in.
TEST(TimedLine, ARepeatCarriesTheSameBytes) {
  struct App final : dp::SlaveApplication {
    std::optional<dp::PrmFault> on_set_prm(std::span<const std::uint8_t>, Time) override {
      return std::nullopt;
    }
    std::optional<dp::CfgFault> on_chk_cfg(std::span<const std::uint8_t>, Time) override {
      return std::nullopt;
    }
    void on_enter_data_exchange(Time) override {}
    void on_leave_data_exchange(Time) override {}
    void on_data_exchange(std::span<const std::uint8_t>, std::span<std::uint8_t>, Time) override {}
    std::size_t output_length() const override { return 0; }
    std::size_t input_length() const override { return 0; }
  } app;
  dp::DpSlave slave(dp::SlaveInfo{}, app);
  struct Flaky final : dp::SlaveLink {
    std::uint8_t address() const override { return 3; }
    void request(dp::Request req, Time now, dp::Completion done) override {
      seen.push_back(std::move(req.data));
      dp::Response r;  // the first time no answer
      if (seen.size() > 1) r.status = dp::Response::Status::Ok;
      done(r, now);
    }
    std::vector<std::vector<std::uint8_t>> seen;
  } flaky;
  TimedLine line(187500, *fdl::default_bus_parameters(187500), 1, Time{0});
  dp::SlaveLink& link = line.add_station(flaky, slave, std::nullopt);
  const std::vector<std::uint8_t> prm{0x88, 0x01, 0x02, 0x0B, 0x04, 0xA4, 0x00};
  std::optional<dp::Response> got;
  link.request({dp::Service::SetPrm, 1, prm}, Time{0},
               [&](const dp::Response& r, Time) { got = r; });
  for (int i = 0; i < 20 && !got; ++i) line.advance(line.next_deadline().value_or(Time{0}));
  ASSERT_TRUE(got);
  EXPECT_EQ(got->status, dp::Response::Status::Ok);
  ASSERT_EQ(flaky.seen.size(), 2u);
  EXPECT_EQ(flaky.seen[0], prm);
  EXPECT_EQ(flaky.seen[1], prm);
  EXPECT_EQ(line.retries(), 1u);
}

TEST(TimedLine, RetryAndLostStationWhenTheSlotTimeSays) {
  Rig rig(config_text(1, R"({ "cycle_ms": 5, "retry_ms": 200, "baud": 187500,
                              "bus_parameters": { "retry_limit": 2 } })"));
  ASSERT_TRUE(rig.plant);
  TimedLine& line = rig.line();
  rig.run_until(Time{100'000});
  ASSERT_EQ(rig.plant->master().slave(3)->state, dp::MasterSlaveState::DataExch);
  // Between two rotations: no request of the station is on the line when it goes.
  while (line.rotating()) rig.plant->advance(*rig.plant->next_deadline());
  line.set_record(true);
  rig.plant->gateways()[0]->gateway().dp().set_offline(true);
  rig.run_until(Time{600'000});
  const auto& p = line.parameters();
  const auto& tg = line.record();
  // The first request to station 3 without an answer, then its repetitions.
  std::vector<std::size_t> to3;
  for (std::size_t i = 0; i < tg.size(); ++i)
    if (tg[i].from_master && decoded(tg[i]).da == 3) to3.push_back(i);
  ASSERT_GE(to3.size(), 4u);
  for (std::size_t k = 1; k <= p.retry_limit; ++k) {
    const auto& a = tg[to3[k - 1]];
    const auto& b = tg[to3[k]];
    EXPECT_EQ(to3[k], to3[k - 1] + 1) << "nothing between a request and its repetition";
    EXPECT_EQ(b.start_bit, a.end_bit + p.slot_time_bits);  // repeated when the slot time ends
    EXPECT_EQ(b.bytes, a.bytes);                           // the same telegram, the same FCB
  }
  EXPECT_EQ(line.retries() % p.retry_limit, 0u);  // each loss after retry_limit repetitions
  // After the last repetition's slot time the station is lost: the next telegram (the token)
  // starts then, and the master asks again (FDL_Status) only after retry_ms.
  const auto& last = tg[to3[p.retry_limit]];
  const std::uint64_t lost_bit = last.end_bit + p.slot_time_bits;
  EXPECT_EQ(tg[to3[p.retry_limit] + 1].start_bit, lost_bit);
  EXPECT_EQ(rig.plant->master().slave(3)->station_lost, 1u);
  const auto& again = tg[to3[p.retry_limit + 1]];
  EXPECT_EQ(decoded(again).function(), fdl::kFcFdlStatus);
  const Time lost_at = line.time_of(lost_bit);
  EXPECT_GE(line.time_of(again.start_bit), lost_at + milliseconds(200));
  EXPECT_LT(line.time_of(again.start_bit), lost_at + milliseconds(200 + 6));
}

// A watchdog of 20 ms: at 1.5 Mbit/s the master comes back every few hundred µs; at 9.6 kbit/s one
// rotation takes longer than 20 ms and the gateway leaves Data_Exch (its watchdog expired).
TEST(TimedLine, WatchdogExpiresWhenTheCycleOutgrowsIt) {
  for (const std::uint32_t baud : {1500000u, 9600u}) {
    SCOPED_TRACE(baud);
    Rig rig(config_text(
        1, R"({ "cycle_ms": 1, "retry_ms": 100, "baud": )" + std::to_string(baud) + " }",
        R"(, "watchdog_ms": 20)"));
    ASSERT_TRUE(rig.plant);
    rig.run_until(Time{3'000'000});
    const auto v = rig.plant->master().slave(3);
    ASSERT_TRUE(v);
    const auto cycle = rig.line().bus_cycle();
    if (baud == 9600) {
      EXPECT_GT(cycle.max, milliseconds(20));
      EXPECT_GT(v->parameterizations, 3u);  // parameterized again after every expiry
    } else {
      EXPECT_LT(cycle.last, milliseconds(1));
      EXPECT_EQ(v->parameterizations, 1u);
      EXPECT_EQ(v->state, dp::MasterSlaveState::DataExch);
    }
  }
}

// docs/profibus.md "The line in time": the master parameterizes a station in one go. Four
// stations at 9.6 kbit/s start together: each one's FDL_Status, Slave_Diag, Set_Prm, Chk_Cfg,
// Slave_Diag and first Data_Exchange follow one another, TID1 after each answer, before the next
// station's first request; so the watchdog the Set_Prm set (100 ms: longer than one station's
// parameterization, shorter than the rotation that parameterizes all four, and shorter than the
// three other stations' Set_Prm that came between a Set_Prm and its Chk_Cfg before) does not
// expire before the first Data_Exchange.
TEST(TimedLine, ParameterizesAStationInOneGo) {
  Rig rig(config_text(4, R"({ "cycle_ms": 1, "retry_ms": 100, "baud": 9600 })",
                      R"(, "watchdog_ms": 100)"));
  ASSERT_TRUE(rig.plant);
  TimedLine& line = rig.line();
  line.set_record(true);
  while (line.parameterization_cycle().count == 0) rig.plant->advance(*rig.plant->next_deadline());
  const auto& tg = line.record();
  const auto tid1 = fdl::tid1_bits(line.parameters());
  // The master's requests of the first rotation, by station and kind.
  std::vector<std::pair<std::uint8_t, std::string>> seen;
  for (std::size_t i = 0; i < tg.size(); ++i) {
    if (!tg[i].from_master) continue;
    const fdl::Telegram d = decoded(tg[i]);
    if (d.kind == fdl::Kind::SD4) break;  // the rotation's token
    if (d.da < 3 || d.da > 6) continue;   // the GAP
    std::string what = d.function() == fdl::kFcFdlStatus ? "FDL_Status"
                       : d.dsap == fdl::kSapSlaveDiag    ? "Slave_Diag"
                       : d.dsap == fdl::kSapSetPrm       ? "Set_Prm"
                       : d.dsap == fdl::kSapChkCfg       ? "Chk_Cfg"
                       : !d.dsap                         ? "Data_Exchange"
                                                         : "?";
    seen.emplace_back(d.da, what);
    // Each request of a station after its first follows the answer before it by TID1.
    if (seen.size() > 1 && seen[seen.size() - 2].first == d.da) {
      ASSERT_GT(i, 0u);
      EXPECT_FALSE(tg[i - 1].from_master) << i;
      EXPECT_EQ(tg[i].start_bit, tg[i - 1].end_bit + tid1) << i;
    }
  }
  const std::vector<std::string> one_go = {"FDL_Status", "Slave_Diag", "Set_Prm",
                                           "Chk_Cfg",    "Slave_Diag", "Data_Exchange"};
  ASSERT_EQ(seen.size(), 4 * one_go.size());
  for (std::size_t k = 0; k < seen.size(); ++k) {
    EXPECT_EQ(seen[k].first, 3 + k / one_go.size()) << k;
    EXPECT_EQ(seen[k].second, one_go[k % one_go.size()]) << k;
  }
  // The start-up rotation outlasts the watchdog; it is no bus cycle of the steady line.
  EXPECT_GT(line.parameterization_cycle().last, milliseconds(100));
  EXPECT_EQ(line.bus_cycle().count, 0u);
  for (const auto& v : rig.plant->master().slaves()) {  // each reached Data_Exch at the first try
    EXPECT_EQ(v.state, dp::MasterSlaveState::DataExch) << int(v.address);
    EXPECT_EQ(v.parameterizations, 1u) << int(v.address);
    EXPECT_EQ(v.data_exchanges, 1u) << int(v.address);
  }
}

// docs/daemon.md "Statistics of the steady line": the bus cycle counts the rotations that
// parameterized no station; the start-up rotation and a re-parameterization are counted apart.
TEST(TimedLine, TheBusCycleIsTheSteadyLine) {
  Rig rig(config_text(2, R"({ "cycle_ms": 1, "baud": 9600 })"));
  ASSERT_TRUE(rig.plant);
  TimedLine& line = rig.line();
  rig.run_until(Time{3'000'000});
  const auto predicted = fdl::predict_cycle(
      9600, line.parameters(), std::vector<fdl::CycleStation>(2, {.outputs = 2, .inputs = 0}));
  const auto start_up = line.parameterization_cycle();
  EXPECT_EQ(start_up.count, 1u);
  const auto steady = line.bus_cycle();
  EXPECT_GT(steady.count, 30u);
  EXPECT_GT(start_up.max, steady.max * 2);  // two stations' parameterizations in it
  // Steady rotations only: the longest is a rotation with the GAP request.
  EXPECT_NEAR(static_cast<double>(steady.max.count()), static_cast<double>(predicted.worst.count()),
              predicted.worst.count() * 0.01);
  EXPECT_NEAR(static_cast<double>(steady.mean().count()),
              static_cast<double>(predicted.mean.count()), predicted.mean.count() * 0.02);
  rig.plant->master().reparameterize(4, rig.plant->now());
  rig.run_until(rig.plant->now() + milliseconds(500));
  EXPECT_EQ(line.parameterization_cycle().count, 2u);
  EXPECT_EQ(line.bus_cycle().max, steady.max);
  EXPECT_GT(line.bus_cycle().count, steady.count);
}

// The prediction (docs/profibus.md "The line in time") and the simulation agree within 2 %.
TEST(TimedLine, PredictionAgreesWithTheSimulation) {
  for (const std::size_t n : {1u, 8u, 32u, 122u}) {
    for (const std::uint32_t baud : {9600u, 187500u, 1500000u, 12000000u}) {
      SCOPED_TRACE(std::to_string(n) + " stations at " + std::to_string(baud));
      Rig rig(config_text(n, R"({ "cycle_ms": 1, "baud": )" + std::to_string(baud) + " }"));
      ASSERT_TRUE(rig.plant);
      const auto p = *fdl::default_bus_parameters(baud);
      std::vector<fdl::CycleStation> st(n, fdl::CycleStation{.outputs = 2, .inputs = 0});
      const auto predicted = fdl::predict_cycle(baud, p, st);
      // Until every station is in Data_Exch, then 100 rotations measured.
      const Duration rotation = predicted.mean;
      auto all_exchange = [&] {
        for (const auto& v : rig.plant->master().slaves())
          if (v.state != dp::MasterSlaveState::DataExch) return false;
        return true;
      };
      for (int k = 0; k < 40 && !all_exchange(); ++k)
        rig.run_until(rig.plant->now() + rotation * 2);
      ASSERT_TRUE(all_exchange());
      // A window of exactly 10 × gap_factor rotations, from the end of a rotation with a GAP
      // request to the end of the tenth such rotation after it.
      auto step_to_gap_rotation = [&] {
        for (;;) {
          const auto count = rig.line().bus_cycle().count;
          const auto gaps = rig.line().gap_polls();
          while (rig.line().bus_cycle().count == count)
            rig.plant->advance(*rig.plant->next_deadline());
          if (rig.line().gap_polls() != gaps) return;
        }
      };
      step_to_gap_rotation();
      const auto before = rig.line().bus_cycle();
      for (int k = 0; k < 10; ++k) step_to_gap_rotation();
      const auto after = rig.line().bus_cycle();
      ASSERT_EQ(after.count - before.count, 10u * p.gap_factor);
      const double measured = static_cast<double>((after.sum - before.sum).count()) /
                              static_cast<double>(after.count - before.count);
      const double want = static_cast<double>(predicted.mean.count());
      EXPECT_NEAR(measured, want, want * 0.02);
      std::printf("| %zu | %u | %.0f | %.0f | %+.2f %% |\n", n, baud, want, measured,
                  100.0 * (measured - want) / want);
    }
  }
}

// The watchdog rule (docs/validate.md "The watchdog rule") against the plant that runs the line:
// the first rotation, which parameterizes every station, is the rule's parameterizing rotation
// (with or without its GAP request); a watchdog the rule lets hold never expires, one it calls
// shorter than the cycle itself expires.
TEST(TimedLine, TheWatchdogRuleHoldsInThePlant) {
  for (const auto& [baud, cycle_ms] : {std::pair{9600u, 10u}, std::pair{1500000u, 30u}}) {
    SCOPED_TRACE(baud);
    const std::string master = R"({ "cycle_ms": )" + std::to_string(cycle_ms) +
                               R"(, "host_stall_ms": 0, "baud": )" + std::to_string(baud) + " }";
    const auto watchdog = [&](std::uint32_t ms) {
      return R"(, "watchdog_ms": )" + std::to_string(ms);
    };
    Rig probe(config_text(4, master));
    ASSERT_TRUE(probe.plant);
    const auto line = config::watchdog_line(probe.cfg);
    const auto b = fdl::watchdog_bounds(line);
    const auto p = line.params;
    const auto startup = fdl::startup_rotation_bits(p, line.stations, true);
    const std::uint32_t holds =
        static_cast<std::uint32_t>((b.needed().count() + 9999) / 10000 * 10);
    const std::uint32_t never = static_cast<std::uint32_t>((b.cycle.count() / 1000 - 1) / 10 * 10);
    ASSERT_EQ(fdl::judge_watchdog(b, holds).verdict, fdl::WatchdogVerdict::Holds);
    ASSERT_EQ(fdl::judge_watchdog(b, never).verdict, fdl::WatchdogVerdict::NeverHolds);

    Rig ok(config_text(4, master, watchdog(holds)));
    ASSERT_TRUE(ok.plant);
    ok.run_until(Time{5'000'000});
    // The start-up rotation parameterizes every station: the longest of those counted apart.
    const auto first = ok.line().parameterization_cycle().max;
    // Stamps are whole microseconds: 2 µs either way.
    EXPECT_GE(first + microseconds(2), fdl::bits_to_time(baud, startup - fdl::gap_poll_bits(p)));
    EXPECT_LE(first, fdl::bits_to_time(baud, startup) + microseconds(2));
    for (const auto& v : ok.plant->master().slaves()) {
      EXPECT_EQ(v.parameterizations, 1u) << "watchdog " << holds << " ms expired";
      EXPECT_EQ(v.state, dp::MasterSlaveState::DataExch);
    }

    Rig short_wd(config_text(4, master, watchdog(never)));
    ASSERT_TRUE(short_wd.plant);
    short_wd.run_until(Time{5'000'000});
    for (const auto& v : short_wd.plant->master().slaves())
      EXPECT_GT(v.parameterizations, 1u) << "watchdog " << never << " ms held";
  }
}

// candp2d's line step (docs/profibus.md "The line in time"): the plant woken at most once a
// millisecond, and later than asked (a loop's jitter), puts every telegram on the same bit as the
// line driven at every event's own bit (replay): back-to-back rotations follow their token after
// TID2, cycles on their grid start at their grid point.
TEST(TimedLine, TheLineStepMovesNoTelegram) {
  for (const auto& [n, baud, cycle_ms] :
       {std::tuple{4u, 187500u, 1}, std::tuple{3u, 12000000u, 1}, std::tuple{3u, 1500000u, 2}}) {
    SCOPED_TRACE(std::to_string(n) + " stations at " + std::to_string(baud));
    const std::string text = config_text(n, R"({ "cycle_ms": )" + std::to_string(cycle_ms) +
                                                R"(, "baud": )" + std::to_string(baud) + " }");
    Rig exact(text), stepped(text, milliseconds(1));
    ASSERT_TRUE(exact.plant && stepped.plant);
    exact.line().set_record(true);
    stepped.line().set_record(true);
    const Time end{300'000};
    exact.run_until(end);
    stepped.plant->advance(Time{0});  // the first cycle anchors the grid where it runs
    std::uint32_t jitter = 1;         // then 0..399 µs late, the same sequence every run
    while (const auto next = stepped.plant->next_deadline()) {
      jitter = jitter * 1103515245u + 12345u;
      const Time at = *next + Duration((jitter >> 16) % 400);
      if (at > end + milliseconds(20)) break;  // past `end`: its last step is done
      stepped.plant->advance(at);
    }
    const auto& a = exact.line().record();
    const auto& b = stepped.line().record();
    ASSERT_GT(a.size(), 100u);
    ASSERT_GE(b.size(), a.size());
    std::size_t tokens = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a[i].start_bit, b[i].start_bit) << "telegram " << i;
      ASSERT_EQ(a[i].bytes, b[i].bytes) << "telegram " << i;
      if (i + 1 < a.size() && decoded(a[i]).kind == fdl::Kind::SD4) {
        // The token to itself, then the next rotation's first request: TID2 when back to back.
        if (cycle_ms == 1 && baud == 187500u) {
          EXPECT_EQ(b[i + 1].start_bit - b[i].end_bit, fdl::tid2_bits(stepped.line().parameters()));
        }
        ++tokens;
      }
    }
    EXPECT_GT(tokens, 10u);
  }
}

// A plant held back longer than its catch-up limit (candp2d with master.host_stall_ms 0 and the
// host stopped for 300 ms) does not run the line of the stall in the past: the next rotation
// starts when the plant woke and the grid points in between are missed.
TEST(TimedLine, AStallBeyondTheCatchUpIsLateness) {
  Rig rig(config_text(2, R"({ "cycle_ms": 5, "baud": 1500000 })"), milliseconds(1),
          milliseconds(51));
  ASSERT_TRUE(rig.plant);
  rig.line().set_record(true);
  rig.run_until(Time{100'000});
  const auto missed = rig.plant->cycle_stats().missed();
  const Time woke{400'000};
  rig.plant->advance(woke);
  // The rotation on the line at 100 ms ends at its bits; no other starts before the plant woke.
  std::size_t later = 0;
  for (const auto& t : rig.line().record()) {
    const Time start = rig.line().time_of(t.start_bit);
    EXPECT_TRUE(start < Time{101'000} || start >= woke) << start.count() << " µs";
    if (start >= woke) ++later;
  }
  EXPECT_GT(later, 0u);
  EXPECT_GE(rig.plant->cycle_stats().missed(), missed + 50);
}

}  // namespace
}  // namespace candp2

// What an analyser counts from the telegrams on the wire (fdl::LineStatistics, docs/profibus.md
// "Line statistics") and what a line fault does to a telegram (fdl::wire_faults, docs/faults.md
// "Line faults"). Each scenario is a sequence of telegrams built with the codec and the DP wire
// helpers (dp_wire.hpp) as a class 1 master and its slaves exchange them; the expected counters
// follow from the scenario as written here.
#include "profibus_sim/fdl/line_stats.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <vector>

#include "common/hex.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"
#include "profibus_sim/fdl/fdl.hpp"
#include "profibus_sim/fdl/wire_faults.hpp"

namespace candp2::fdl {
namespace {

using Bytes = std::vector<std::uint8_t>;
constexpr std::uint8_t kMaster = 2;

// A DP request from the master with the station's FCB sequence.
Bytes request(dp::Service s, std::uint8_t station, const FcbSequence& seq = {}, Bytes data = {}) {
  return encode(dp_request(dp::Request{s, kMaster, std::move(data)}, station, kMaster, seq));
}
// The slave's positive answer to `req` (Set_Prm/Chk_Cfg: SC; Slave_Diag: DL with `data`).
Bytes answer(const Bytes& req, dp::Service s, Bytes data = {}) {
  const auto t = decode(req).telegram;
  const auto a = dp_answer(*t, s, dp::Response{dp::Response::Status::Ok, std::move(data), false});
  return encode(*a);
}
Bytes token(std::uint8_t from = kMaster) {
  return encode(Telegram::token(from, from));
}
const Bytes kDiag = {0x02, 0x05, 0x00, 0xFF, 0x04, 0xA4};  // 6 standard diagnosis bytes
const Bytes kPrm = {0x88, 0x01, 0x01, 0x0B, 0x04, 0xA4, 0x00};

// A line: telegrams 100 µs apart unless told otherwise.
struct Line {
  LineStatistics stats;
  Time now{0};
  void put(const Bytes& b, Duration after = microseconds(100)) {
    now += after;
    stats.observe(b, now);
  }
  void bad(Duration after = microseconds(100)) {
    now += after;
    stats.observe_illegal(now);
  }
  // A request and its answer.
  void exchange(const Bytes& req, const Bytes& ans) {
    put(req);
    put(ans);
  }
  // A Data_Exchange with the station, repeated `repeats` times before its answer; FCB toggled.
  void data_exchange(std::uint8_t station, FcbSequence& seq, int repeats);
};

void Line::data_exchange(std::uint8_t station, FcbSequence& seq, int repeats) {
  const Bytes r = request(dp::Service::DataExchange, station, seq, {0x01});
  for (int i = 0; i <= repeats; ++i) put(r);
  put(encode(data_exchange_answer(decode(r).telegram.value(), Bytes{0x02}, false)));
  seq.advance();
}

StationCounters counters(std::uint64_t lost, std::uint64_t syncs, std::uint64_t repeats,
                         std::uint64_t repeats_max, std::uint64_t illegals,
                         std::uint64_t diagnostics) {
  return {lost, syncs, repeats, repeats_max, illegals, diagnostics};
}

TEST(LineStatistics, TheTableNamesEveryCounterOnce) {
  std::set<std::string_view> names;
  StationCounters s;
  std::uint64_t v = 1;
  for (const auto& f : kStationCounters) {
    EXPECT_TRUE(names.insert(f.name).second) << f.name;
    EXPECT_EQ(station_counter(f.name), &f);
    s.*f.member = v++;
  }
  EXPECT_EQ(kStationCounterCount, 6u);
  EXPECT_EQ(s, counters(1, 2, 3, 4, 5, 6)) << "table order = struct order";
  EXPECT_EQ(station_counter("nonsense"), nullptr);
}

TEST(LineStatistics, AParameterizationAndDataExchangeCountSyncsAndDiagnostics) {
  Line l;
  FcbSequence seq;
  const Bytes st = encode(fdl_status_request(3, kMaster));
  l.exchange(st, encode(short_answer(decode(st).telegram.value(), kFcOk)));
  Bytes r = request(dp::Service::SlaveDiag, 3, seq);
  l.exchange(r, answer(r, dp::Service::SlaveDiag, kDiag));
  seq.advance();
  r = request(dp::Service::SetPrm, 3, seq, kPrm);
  l.exchange(r, answer(r, dp::Service::SetPrm));
  seq.advance();
  r = request(dp::Service::ChkCfg, 3, seq, {0x21});
  l.exchange(r, answer(r, dp::Service::ChkCfg));
  seq.advance();
  r = request(dp::Service::SlaveDiag, 3, seq);
  l.exchange(r, answer(r, dp::Service::SlaveDiag, kDiag));
  seq.advance();
  r = request(dp::Service::DataExchange, 3, seq, {0x11, 0x22});
  l.exchange(r, encode(data_exchange_answer(decode(r).telegram.value(), Bytes{0x33}, false)));
  l.put(encode(Telegram::with_data(kBroadcast, kMaster, request_fc(kFcSdnHigh), kSapGlobalControl,
                                   kMasterSap, {0x08, 0x00})));  // Global_Control: no answer

  EXPECT_EQ(l.stats.station(3), counters(0, 1, 0, 0, 0, 2));
  EXPECT_EQ(l.stats.live(3), Live::Ok);
  EXPECT_EQ(l.stats.telegrams(), 13u);
  EXPECT_EQ(l.stats.illegals_unattributed(), 0u);
  EXPECT_EQ(l.stats.stations(), std::vector<std::uint8_t>{3});
}

TEST(LineStatistics, ARepeatAfterAnUnansweredRequest) {
  Line l;
  const Bytes r = request(dp::Service::DataExchange, 3, {}, {0x01});
  const Bytes a = encode(data_exchange_answer(decode(r).telegram.value(), Bytes{0x02}, false));
  l.exchange(r, a);
  FcbSequence seq;
  seq.advance();
  const Bytes r2 = request(dp::Service::DataExchange, 3, seq, {0x01});
  l.put(r2);  // no answer
  l.put(r2);  // the same telegram (same FCB): a repeat
  l.put(a);   // answered this time: not lost
  EXPECT_EQ(l.stats.station(3), counters(0, 0, 1, 1, 0, 0));
  EXPECT_EQ(l.stats.live(3), Live::Ok);
  // The same bytes again after an answer are a new request (a master would have toggled FCB).
  l.put(r2);
  l.put(a);
  EXPECT_EQ(l.stats.station(3).repeats, 1u);
}

// docs/profibus.md "Line statistics": lost counts a drop out of data exchange.
TEST(LineStatistics, LostOnlyForAStationInDataExchangeANeverAnsweringOneIsMissing) {
  Line l;
  FcbSequence seq;
  Bytes r = request(dp::Service::SlaveDiag, 3, seq);
  l.exchange(r, answer(r, dp::Service::SlaveDiag, kDiag));  // 3 is live
  seq.advance();
  r = request(dp::Service::DataExchange, 3, seq, {0x01});
  l.exchange(r, answer(r, dp::Service::DataExchange, {0x02}));  // and in data exchange
  seq.advance();
  r = request(dp::Service::DataExchange, 3, seq, {0x01});
  l.put(r);
  l.put(r);
  l.put(r);        // two repeats, no answer
  l.put(token());  // the master gave up: 3 is lost
  // 5 never answers: repeated, abandoned, but never lost (it never was there).
  const Bytes r5 = request(dp::Service::SlaveDiag, 5);
  for (int round = 0; round < 2; ++round) {
    l.put(r5);
    l.put(r5);
    l.put(token());
  }
  // 3 again unanswered after it was lost: no second loss.
  l.put(r);
  l.put(token());
  // 7 answers its Slave_Diag but never reaches data exchange: unanswered later, it is not lost.
  const Bytes r7 = request(dp::Service::SlaveDiag, 7);
  l.exchange(r7, answer(r7, dp::Service::SlaveDiag, kDiag));
  l.put(r7);
  l.put(token());
  EXPECT_EQ(l.stats.station(7).lost, 0u);

  EXPECT_EQ(l.stats.station(3), counters(1, 0, 2, 2, 0, 1));
  EXPECT_EQ(l.stats.live(3), Live::Missing);
  EXPECT_EQ(l.stats.station(5), counters(0, 0, 2, 1, 0, 0));
  EXPECT_EQ(l.stats.live(5), Live::Missing);
  // An answer brings 3 back.
  seq.advance();
  r = request(dp::Service::SlaveDiag, 3, seq);
  l.exchange(r, answer(r, dp::Service::SlaveDiag, kDiag));
  EXPECT_EQ(l.stats.live(3), Live::Ok);
  EXPECT_EQ(l.stats.station(3).lost, 1u);
  EXPECT_EQ(l.stats.station(3).diagnostics, 2u);
}

// A new Set_Prm to a station in data exchange: it had dropped out (the master starts again).
TEST(LineStatistics, SetPrmToAStationInDataExchangeCountsItLost) {
  Line l;
  FcbSequence seq;
  Bytes r = request(dp::Service::DataExchange, 3, seq, {0x01});
  l.exchange(r, answer(r, dp::Service::DataExchange, {0x02}));
  const Bytes p = request(dp::Service::SetPrm, 3, {}, kPrm);
  l.exchange(p, answer(p, dp::Service::SetPrm));
  l.exchange(p, answer(p, dp::Service::SetPrm));  // not in data exchange since: no second loss
  EXPECT_EQ(l.stats.station(3).lost, 1u);
  EXPECT_EQ(l.stats.station(3).syncs, 2u);
}

TEST(LineStatistics, SyncsCountSetPrmRequestsNotTheirRepeats) {
  Line l;
  FcbSequence seq;
  Bytes r = request(dp::Service::SetPrm, 4, seq, kPrm);
  l.put(r);
  l.put(r);
  l.put(r);  // two repeats of one Set_Prm
  l.put(answer(r, dp::Service::SetPrm));
  seq.advance();
  r = request(dp::Service::SetPrm, 4, seq, kPrm);  // a second parameterization
  l.exchange(r, answer(r, dp::Service::SetPrm));
  EXPECT_EQ(l.stats.station(4), counters(0, 2, 2, 2, 0, 0));
}

TEST(LineStatistics, DiagnosticsCountAnsweredSlaveDiagOnly) {
  Line l;
  FcbSequence seq;
  Bytes r = request(dp::Service::SlaveDiag, 6, seq);
  l.put(r);  // unanswered
  l.put(token());
  l.exchange(r, answer(r, dp::Service::SlaveDiag, kDiag));
  seq.advance();
  r = request(dp::Service::GetCfg, 6, seq);  // answered with data, not a diagnosis
  l.exchange(r, answer(r, dp::Service::GetCfg, {0x21}));
  EXPECT_EQ(l.stats.station(6).diagnostics, 1u);
  EXPECT_EQ(l.stats.station(6).illegals, 0u);
}

TEST(LineStatistics, IllegalTelegramsAreBlamedOnTheStationWhoseAnswerWasDue) {
  Line l;
  FcbSequence seq;
  const Bytes r = request(dp::Service::SlaveDiag, 3, seq);
  const Bytes a = answer(r, dp::Service::SlaveDiag, kDiag);
  l.put(r);
  l.put(corrupt_fcs(a));  // 1: a corrupt answer where 3's answer was due
  l.put(r);               // the master repeats
  l.bad();                // 2: dropped by the receiver (parity) where the answer was due
  l.put(r);
  l.put(garble(a, 7));  // 3: noise where the answer was due
  l.put(r);
  l.put(a);  // finally a valid answer
  l.put(a);  // 4: the same answer again, which nobody asked for
  EXPECT_EQ(l.stats.station(3), counters(0, 0, 3, 3, 4, 1));
  EXPECT_EQ(l.stats.illegals_unattributed(), 0u);

  // No answer due: after a token, after an answered request, after an SDN.
  l.put(token());
  l.bad();                                     // 1
  l.put(garble(token(), 1));                   // 2
  l.put(encode(Telegram::sc()));               // 3: an SC answers nothing
  l.put(corrupt_fcs(encode(Telegram::sc())));  // 4
  // An answer from another station while 3's is due: 9's illegal, 3 still owes its answer.
  seq.advance();
  const Bytes r2 = request(dp::Service::SlaveDiag, 3, seq);
  l.put(r2);
  l.put(answer(request(dp::Service::SlaveDiag, 9), dp::Service::SlaveDiag, kDiag));
  l.put(answer(r2, dp::Service::SlaveDiag, kDiag));
  EXPECT_EQ(l.stats.illegals_unattributed(), 4u);
  EXPECT_EQ(l.stats.station(9), counters(0, 0, 0, 0, 1, 0));
  EXPECT_EQ(l.stats.live(9), Live::None) << "an unexpected answer is not a live station";
  EXPECT_EQ(l.stats.station(3), counters(0, 0, 3, 3, 4, 2));
  // Valid: 4 requests and 2 answers to 3, the token, the SC, the last 3.
  EXPECT_EQ(l.stats.telegrams(), 11u);
}

TEST(LineStatistics, RepeatsMaxIsTheMostRepeatsInOneTokenRotation) {
  Line l;
  FcbSequence seq;
  l.put(token());
  auto cycle = [&](int repeats) { l.data_exchange(3, seq, repeats); };
  cycle(1);
  cycle(1);  // two repeats in the first rotation
  l.put(token());
  cycle(1);  // one in the second
  l.put(token());
  cycle(0);
  l.put(token());
  EXPECT_EQ(l.stats.station(3), counters(0, 0, 3, 2, 0, 0));
  cycle(3);  // three in the last
  EXPECT_EQ(l.stats.station(3), counters(0, 0, 6, 3, 0, 0));
}

TEST(LineStatistics, WithoutTokensRepeatsMaxIsPerRequestAndTheMasterTellsANewRequest) {
  // A master that passes no token (candp2d in role master, docs/profibus.md "Line statistics in
  // role master"): no rotation ends a run of repeats, a new request to the station does.
  Line l;
  FcbSequence seq;
  auto exchange = [&](int repeats) { l.data_exchange(3, seq, repeats); };
  exchange(1);
  exchange(2);
  exchange(1);
  EXPECT_EQ(l.stats.station(3), counters(0, 0, 4, 2, 0, 0));
  // The station stops answering: FDL_Status asked, repeated, given up, asked again later with
  // the same bytes. Told by the master, the second one is a new request, not a third repeat.
  const Bytes status = encode(Telegram::no_data(3, kMaster, request_fc(kFcFdlStatus)));
  l.stats.new_request();
  l.put(status);
  l.put(status);  // its repeat
  l.stats.new_request();
  l.put(status);
  l.put(status);
  EXPECT_EQ(l.stats.station(3).repeats, 6u);
  EXPECT_EQ(l.stats.station(3).repeats_max, 2u);
  EXPECT_EQ(l.stats.station(3).lost, 1u);  // it dropped out of data exchange once
  EXPECT_EQ(l.stats.live(3), Live::Missing);
}

TEST(LineStatistics, LiveListLearntFromTheMastersDpServices) {
  Line l;
  Bytes r = request(dp::Service::SlaveDiag, 3);
  l.exchange(r, answer(r, dp::Service::SlaveDiag, kDiag));  // ok
  l.put(request(dp::Service::SlaveDiag, 5));                // missing
  l.put(token());
  const Bytes st = encode(fdl_status_request(7, kMaster));  // a gap poll, not a DP service
  l.exchange(st, encode(short_answer(decode(st).telegram.value(), kFcOk)));  // phantom
  l.put(encode(fdl_status_request(8, kMaster)));                             // nobody there: none
  l.put(token());
  EXPECT_EQ(l.stats.live(3), Live::Ok);
  EXPECT_EQ(l.stats.live(5), Live::Missing);
  EXPECT_EQ(l.stats.live(7), Live::Phantom);
  EXPECT_EQ(l.stats.live(8), Live::None);
  EXPECT_TRUE(l.stats.configured(5));
  EXPECT_FALSE(l.stats.configured(7));
  EXPECT_EQ(l.stats.stations(), (std::vector<std::uint8_t>{3, 5, 7}));
}

TEST(LineStatistics, LiveListOfAConfiguredMaster) {
  Line l;
  l.stats.configure(3);
  l.stats.configure(4);
  Bytes r = request(dp::Service::SlaveDiag, 3);
  l.exchange(r, answer(r, dp::Service::SlaveDiag, kDiag));
  r = request(dp::Service::SlaveDiag, 5);  // answers but is not configured
  l.exchange(r, answer(r, dp::Service::SlaveDiag, kDiag));
  l.put(request(dp::Service::SlaveDiag, 6));  // a DP service does not configure when told
  l.put(token());
  EXPECT_EQ(l.stats.live(3), Live::Ok);
  EXPECT_EQ(l.stats.live(4), Live::Missing) << "configured, never addressed";
  EXPECT_EQ(l.stats.live(5), Live::Phantom);
  EXPECT_EQ(l.stats.live(6), Live::None);
  EXPECT_EQ(l.stats.stations(), (std::vector<std::uint8_t>{3, 4, 5}));
}

TEST(LineStatistics, TokenRotationFromTheFirstTokensSender) {
  Line l;
  EXPECT_EQ(l.stats.rotation().count, 0u);
  l.put(token(), microseconds(50));    // t = 50: the master
  l.put(token(9), microseconds(300));  // another master's token: not a rotation of ours
  l.put(token(), microseconds(700));   // 1000
  l.put(token(), microseconds(2000));  // 2000
  l.put(token(), microseconds(500));   // 500
  const RotationTimes& rt = l.stats.rotation();
  EXPECT_EQ(rt.count, 3u);
  EXPECT_EQ(rt.last, microseconds(500));
  EXPECT_EQ(rt.min, microseconds(500));
  EXPECT_EQ(rt.max, microseconds(2000));
  EXPECT_EQ(rt.sum, microseconds(3500));
  EXPECT_EQ(rt.mean(), microseconds(3500 / 3));
  EXPECT_EQ(l.stats.telegrams(), 5u);
}

// ---- wire faults -------------------------------------------------------------------------------

std::vector<Bytes> samples() {
  const Bytes diag = request(dp::Service::SlaveDiag, 3);
  return {
      encode(fdl_status_request(3, kMaster)),                                 // SD1
      diag,                                                                   // SD2
      encode(Telegram::with_data(3, 2, request_fc(kFcSrdHigh), std::nullopt,  // SD3
                                 std::nullopt, Bytes(8, 0x5A))),
      answer(diag, dp::Service::SlaveDiag, kDiag),  // SD2 answer
      token(),                                      // SD4
      encode(Telegram::sc()),                       // SC
  };
}

TEST(WireFaults, CorruptFcsGivesAnFcsErrorAndAnScOrATokenNoStartDelimiter) {
  const auto all = samples();
  ASSERT_EQ(decode(all[2]).telegram->kind, Kind::SD3);
  for (const Bytes& t : all) {
    const auto kind = decode(t).telegram->kind;
    const Bytes c = corrupt_fcs(t);
    ASSERT_EQ(c.size(), t.size());
    std::size_t changed = 0;
    for (std::size_t i = 0; i < t.size(); ++i) changed += c[i] != t[i];
    EXPECT_EQ(changed, 1u);
    // SC and token have no FCS: their start delimiter is hit (a token's DA would make a valid
    // token to another station).
    const bool no_fcs = kind == Kind::SC || kind == Kind::SD4;
    EXPECT_EQ(decode(c).error, no_fcs ? Error::BadStart : Error::BadFcs) << to_string(kind);
  }
}

TEST(WireFaults, SuperposeOfTwoIdenticalTelegramsFiveBitsApartDoesNotDecode) {
  for (const Bytes& t : samples()) {
    const Superposed s = superpose(t, t, 5);
    EXPECT_FALSE(decode(s.bytes).telegram) << hex_bytes(t);
    EXPECT_GE(s.bits, 11 * t.size() + 5);
    // In step, two transmitters of the same bytes are one telegram.
    const Superposed same = superpose(t, t, 0);
    EXPECT_EQ(same.bytes, t);
    EXPECT_EQ(same.parity_errors, 0u);
    EXPECT_EQ(same.bits, 11 * t.size());
  }
}

TEST(WireFaults, GarbleNeverDecodesAndIsTheSameForTheSameSeed) {
  for (const Bytes& t : samples()) {
    std::set<Bytes> distinct;
    for (std::uint64_t seed = 0; seed < 500; ++seed) {
      const Bytes g = garble(t, seed);
      ASSERT_EQ(g.size(), t.size());
      ASSERT_FALSE(decode(g).telegram) << "seed " << seed;
      EXPECT_EQ(garble(t, seed), g);
      distinct.insert(g);
    }
    EXPECT_GT(distinct.size(), 1u) << "the seed draws the damage";
  }
}

}  // namespace
}  // namespace candp2::fdl

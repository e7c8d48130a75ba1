// The response-time analysis of one CAN bus (can/response_time.hpp, docs/can-bus.md "Response
// times"; Davis, Burns, Bril, Lukkien 2007): examples worked by hand in the comments, equation by
// equation (eq. 7 the busy period t, eq. 8 the instances Q, eq. 9 the queuing delay w(q), eq. 10
// R(q) = J + w(q) - qT + C), and the paper's properties checked on random message sets against a
// simulation of the bus.
#include "can/response_time.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "can/frame_bits.hpp"
#include "can/timed_bus.hpp"

namespace candp2::can {
namespace {

using std::chrono::microseconds;
using std::chrono::nanoseconds;

RtaMessage msg(std::uint32_t id, std::uint8_t dlc, microseconds period, microseconds jitter = {},
               bool extended = false, bool remote = false) {
  return {.id = {id, extended}, .remote = remote, .dlc = dlc, .period = period, .jitter = jitter};
}

// The paper's own example (section 3.3): three messages A > B > C of 125 bits each at 125 kbit/s
// (C = 1 ms; an 11-bit frame with DLC 7 is 34 + 56 + 13 + floor(89 / 4) = 125 bits), T_A = 2.5 ms,
// T_B = T_C = 3.5 ms; tau_bit = 8 us. Times below in us.
//   A: B = 1000 (C's or B's frame). t: 1000 -> 1000 + ceil(1000/2500)*1000 = 2000 -> 2000: t =
//   2000,
//      Q = ceil(2000/2500) = 1. w(0) = B = 1000 (no hp). R = 1000 + 1000 = 2000.
//   B: B = 1000 (C). t: 1000 -> 1000 + 1000 + 1000 = 3000 -> 1000 + 2*1000 + 1000 = 4000
//      -> 1000 + 2000 + 2000 = 5000 -> 5000: Q = ceil(5000/3500) = 2.
//      w(0): 1000 -> 1000 + ceil(1008/2500)*1000 = 2000 -> 2000; R(0) = 2000 + 1000 = 3000.
//      w(1): 2000 -> 2000 + ceil(2008/2500)*1000 = 3000 -> 2000 + ceil(3008/2500)*1000 = 4000
//      -> 4000; R(1) = 4000 - 3500 + 1000 = 1500. R = 3000.
//   C: B = 0 (lowest). t: 1000 -> 1000 + 1000 + 1000 = 3000 -> 2000 + 1000 + 1000 = 4000
//      -> 2000 + 2000 + 2000 = 6000 -> 3000 + 2000 + 2000 = 7000 -> 7000: Q = 2.
//      w(0): 0 -> ceil(8/2500)*1000 + ceil(8/3500)*1000 = 2000 -> 2000; R(0) = 3000.
//      w(1): 1000 -> 1000 + 1000 + 1000 = 3000 -> 1000 + 2000 + 1000 = 4000
//      -> 1000 + 2000 + 2000 = 5000 -> 1000 + 3000 + 2000 = 6000 -> 6000;
//      R(1) = 6000 - 3500 + 1000 = 3500 = T_C: the second instance is the worst, which the
//      original analysis (R(0) alone, 3000) missed.
TEST(ResponseTime, PaperExampleSecondInstanceIsTheWorst) {
  const std::vector<RtaMessage> set = {msg(0x100, 7, microseconds(2500)),
                                       msg(0x200, 7, microseconds(3500)),
                                       msg(0x300, 7, microseconds(3500))};
  const RtaReport r = analyse_response_times(set, 125'000);
  ASSERT_EQ(r.messages.size(), 3u);
  for (const auto& m : r.messages) {
    EXPECT_EQ(m.frame_bits, 125u);
    EXPECT_EQ(m.transmission, microseconds(1000));
  }
  EXPECT_NEAR(r.utilisation, 0.4 + 2.0 / 3.5, 1e-12);

  const auto& a = r.messages[0];
  EXPECT_EQ(a.blocking, microseconds(1000));
  EXPECT_EQ(a.busy_period, microseconds(2000));
  EXPECT_EQ(a.instances, 1u);
  EXPECT_EQ(a.response, microseconds(2000));

  const auto& b = r.messages[1];
  EXPECT_EQ(b.blocking, microseconds(1000));
  EXPECT_EQ(b.busy_period, microseconds(5000));
  EXPECT_EQ(b.instances, 2u);
  EXPECT_EQ(b.response, microseconds(3000));
  EXPECT_EQ(b.worst_instance, 0u);

  const auto& c = r.messages[2];
  EXPECT_EQ(c.blocking, microseconds(0));
  EXPECT_EQ(c.busy_period, microseconds(7000));
  EXPECT_EQ(c.instances, 2u);
  EXPECT_EQ(c.response_first, microseconds(3000));
  EXPECT_EQ(c.response, microseconds(3500));
  EXPECT_EQ(c.worst_instance, 1u);
  EXPECT_TRUE(c.schedulable);  // R = D exactly
  EXPECT_TRUE(r.schedulable());
}

// Blocking alone makes a short frame with a short period miss its deadline, at 55 % load.
// 125 kbit/s: A = 11-bit DLC 0, 34 + 13 + floor(33/4) = 55 bits = 440 us, T = 1 ms;
// L = 11-bit DLC 8, 34 + 64 + 13 + floor(97/4) = 135 bits = 1080 us, T = 10 ms.
//   A: B = 1080. t: 440 -> 1080 + 440 = 1520 -> 1080 + 2*440 = 1960 -> 1960: Q = 2.
//      w(0) = 1080, R(0) = 1080 + 440 = 1520 > 1000. w(1) = 1080 + 440 = 1520,
//      R(1) = 1520 - 1000 + 440 = 960. R = 1520: missed.
//   L: B = 0. t: 1080 -> 1080 + 2*440 = 1960 -> 1960: Q = 1.
//      w(0): 0 -> ceil(8/1000)*440 = 440 -> ceil(448/1000)*440 = 440; R = 440 + 1080 = 1520.
TEST(ResponseTime, BlockingByALongerLowerPriorityFrameMissesADeadline) {
  const std::vector<RtaMessage> set = {msg(0x010, 0, microseconds(1000)),
                                       msg(0x020, 8, microseconds(10000))};
  const RtaReport r = analyse_response_times(set, 125'000);
  EXPECT_NEAR(r.utilisation, 0.44 + 0.108, 1e-12);
  const auto& a = r.messages[0];
  EXPECT_EQ(a.frame_bits, 55u);
  EXPECT_EQ(a.blocking, microseconds(1080));
  EXPECT_EQ(a.busy_period, microseconds(1960));
  EXPECT_EQ(a.instances, 2u);
  EXPECT_EQ(a.response, microseconds(1520));
  EXPECT_EQ(a.worst_instance, 0u);
  EXPECT_FALSE(a.schedulable);
  const auto& l = r.messages[1];
  EXPECT_EQ(l.frame_bits, 135u);
  EXPECT_EQ(l.response, microseconds(1520));
  EXPECT_TRUE(l.schedulable);
  EXPECT_FALSE(r.schedulable());
}

// Queuing jitter adds to the response one for one, and to the interference it causes below:
// 1 Mbit/s, A = DLC 8 (135 us), T = 1 ms, J = 300 us; B = DLC 8, T = 1 ms.
//   A: B = 135; t: 135 -> 135 + 135 = 270 -> 270: Q = ceil((270 + 300)/1000) = 1.
//      w(0) = 135; R = 300 + 135 + 135 = 570.
//   B: t: 135 -> 135 + ceil(435/1000)*135 = 270 -> 270: Q = 1.
//      w(0): 0 -> ceil((0 + 300 + 1)/1000)*135 = 135 -> ceil(436/1000)*135 = 135; R = 270.
TEST(ResponseTime, JitterAddsToTheResponse) {
  const std::vector<RtaMessage> set = {msg(0x100, 8, microseconds(1000), microseconds(300)),
                                       msg(0x200, 8, microseconds(1000))};
  const RtaReport r = analyse_response_times(set, 1'000'000);
  EXPECT_EQ(r.messages[0].response, microseconds(570));
  EXPECT_EQ(r.messages[1].response, microseconds(270));
  // Jitter of 900 us: A's next instance can follow 100 us after the first (eq. 9 counts it).
  //   B: w(0): 0 -> ceil(901/1000)*135 = 135 -> ceil(1036/1000)*135 = 270 -> ceil(1171/1000) = 2
  //      -> 270; R = 270 + 135 = 405.
  const std::vector<RtaMessage> late = {msg(0x100, 8, microseconds(1000), microseconds(900)),
                                        msg(0x200, 8, microseconds(1000))};
  EXPECT_EQ(analyse_response_times(late, 1'000'000).messages[1].response, microseconds(405));
}

// Two nodes sending the same identifier: each is counted as the other's higher priority.
// 125 kbit/s, DLC 7 (1 ms), T = 10 ms: B = 0, w(0): 0 -> ceil(8/10000)*1000 = 1000 -> 1000,
// R = 2000 for both.
TEST(ResponseTime, TheSameIdentifierTwiceInterferesBothWays) {
  const std::vector<RtaMessage> set = {msg(0x181, 7, microseconds(10000)),
                                       msg(0x181, 7, microseconds(10000))};
  const RtaReport r = analyse_response_times(set, 125'000);
  EXPECT_EQ(r.messages[0].response, microseconds(2000));
  EXPECT_EQ(r.messages[1].response, microseconds(2000));
}

// Arbitration orders the set: an 11-bit frame beats a 29-bit frame with the same base identifier,
// and a data frame a remote frame of its identifier; the loser's frame blocks the winner.
// 1 Mbit/s: 29-bit DLC 8 is 54 + 64 + 13 + floor(117/4) = 160 bits; 11-bit remote is
// 34 + 13 + floor(33/4) = 55 bits.
TEST(ResponseTime, ArbitrationDecidesBlockingAndInterference) {
  const std::vector<RtaMessage> set = {
      msg(0x100u << 18, 8, microseconds(10000), {}, true),  // loses to both
      msg(0x100, 8, microseconds(10000), {}, false, true),  // remote: loses to data
      msg(0x100, 8, microseconds(10000))};                  // wins
  const RtaReport r = analyse_response_times(set, 1'000'000);
  EXPECT_EQ(r.messages[0].frame_bits, 160u);
  EXPECT_EQ(r.messages[1].frame_bits, 55u);
  EXPECT_EQ(r.messages[2].blocking, microseconds(160));
  EXPECT_EQ(r.messages[1].blocking, microseconds(160));
  EXPECT_EQ(r.messages[0].blocking, microseconds(0));
  // The 29-bit frame waits for both others: w = 135 + 55 = 190, R = 190 + 160 = 350.
  EXPECT_EQ(r.messages[0].response, microseconds(350));
}

// A node with one FIFO transmit queue (RtaMessage::fifo, docs/can-bus.md "Response times"): its
// high-priority frame can wait behind its own low one, so each of its messages is analysed at the
// queue's lowest priority with all of the queue's messages as interference. 125 kbit/s, DLC 0
// (55 bits = 440 us), T = 10 ms; node 1 queues 0x100 and 0x300, node 2 (priority order) 0x200.
//   0x100 alone in priority order: B = 440 (a lower frame), w = 440, R = 880.
//   0x100 in the FIFO: level 0x300, hp = {0x300 (its queue), 0x200 (beats 0x300)}, B = 0 (nothing
//   below 0x300): w(0): 0 -> 440 + 440 = 880 -> 880 (ceil(888/10000) = 1), R = 880 + 440 = 1320.
//   0x200: B = 440 (0x300), hp = {0x100}: w = 440 + 440 = 880, R = 1320 in both cases.
TEST(ResponseTime, FifoQueueAnalysedAtItsLowestPriority) {
  std::vector<RtaMessage> set = {msg(0x100, 0, microseconds(10000)),
                                 msg(0x300, 0, microseconds(10000)),
                                 msg(0x200, 0, microseconds(10000))};
  EXPECT_EQ(analyse_response_times(set, 125'000).messages[0].response, microseconds(880));
  set[0].fifo = set[1].fifo = 1;
  const RtaReport r = analyse_response_times(set, 125'000);
  EXPECT_EQ(r.messages[0].blocking, microseconds(0));
  EXPECT_EQ(r.messages[0].response, microseconds(1320));
  EXPECT_EQ(r.messages[1].response, microseconds(1320));
  EXPECT_EQ(r.messages[2].response, microseconds(1320));
}

// Paper, section 4: the busy period only ends below 100 % load at a priority. Over 100 % the lower
// messages have no bound and the set is not schedulable; the higher ones are still analysed.
TEST(ResponseTime, OverloadLeavesTheLowerMessagesUnbounded) {
  // 125 kbit/s, DLC 7 = 1 ms each: 0.5 + 0.4 + 0.25 = 1.15.
  const std::vector<RtaMessage> set = {msg(0x100, 7, microseconds(2000)),
                                       msg(0x200, 7, microseconds(2500)),
                                       msg(0x300, 7, microseconds(4000))};
  const RtaReport r = analyse_response_times(set, 125'000);
  EXPECT_GT(r.utilisation, 1.0);
  EXPECT_FALSE(r.schedulable());
  EXPECT_TRUE(r.messages[0].response.has_value());
  EXPECT_TRUE(r.messages[1].response.has_value());  // 0.9 at its priority
  EXPECT_FALSE(r.messages[2].response.has_value());
  EXPECT_FALSE(r.messages[2].busy_period.has_value());
  EXPECT_FALSE(r.messages[2].schedulable);
}

TEST(ResponseTime, NoPeriodOrNoBitRateIsNotAnalysed) {
  const std::vector<RtaMessage> set = {msg(0x100, 8, microseconds(0))};
  const RtaReport r = analyse_response_times(set, 500'000);
  EXPECT_EQ(r.messages[0].frame_bits, 135u);
  EXPECT_FALSE(r.messages[0].response.has_value());
  EXPECT_FALSE(r.schedulable());
  const std::vector<RtaMessage> ok = {msg(0x100, 8, microseconds(1000))};
  EXPECT_FALSE(analyse_response_times(ok, 0).messages[0].response.has_value());
  EXPECT_TRUE(analyse_response_times(ok, 500'000).schedulable());
  EXPECT_TRUE(analyse_response_times({}, 500'000).schedulable());
}

// A bus simulated frame by frame (no jitter): every message released at its offset and then
// every period; when the bus is idle the pending frame with the smallest arbitration key goes,
// `C` long. Returns the longest release-to-end time per message over `horizon`.
std::vector<std::int64_t> simulate(const std::vector<RtaMessage>& set,
                                   const std::vector<std::int64_t>& offsets, const RtaReport& a,
                                   std::int64_t horizon) {
  const std::size_t n = set.size();
  std::vector<std::int64_t> next(offsets), worst(n, 0);
  std::vector<std::vector<std::int64_t>> pending(n);
  std::int64_t now = 0;
  while (now < horizon) {
    for (std::size_t i = 0; i < n; ++i)
      while (next[i] <= now) {
        pending[i].push_back(next[i]);
        next[i] += set[i].period.count();
      }
    std::optional<std::size_t> win;
    for (std::size_t i = 0; i < n; ++i)
      if (!pending[i].empty() && (!win || arbitration_key(set[i].id, set[i].remote) <
                                              arbitration_key(set[*win].id, set[*win].remote)))
        win = i;
    if (!win) {
      now = *std::min_element(next.begin(), next.end());
      continue;
    }
    now += a.messages[*win].transmission.count();
    worst[*win] = std::max(worst[*win], now - pending[*win].front());
    pending[*win].erase(pending[*win].begin());
  }
  return worst;
}

// The analysis is an upper bound: on random sets below 100 % load no simulated frame is later
// than its bound; R >= R(0) >= C + B is never below the first instance's; and a set over 100 %
// load is never schedulable (paper, section 4).
TEST(ResponseTime, RandomSetsBoundTheSimulatedBus) {
  std::mt19937 rng(36);
  const std::int64_t periods[] = {1000, 2000, 2500, 5000, 10000, 20000};  // us
  int analysed = 0, overloaded = 0;
  for (int round = 0; round < 200; ++round) {
    std::vector<RtaMessage> set;
    const int n = 2 + static_cast<int>(rng() % 7);
    for (int i = 0; i < n; ++i)
      set.push_back(msg(static_cast<std::uint32_t>(rng() % 0x800),
                        static_cast<std::uint8_t>(rng() % 9), microseconds(periods[rng() % 6])));
    const RtaReport r = analyse_response_times(set, 250'000);
    if (r.utilisation > 1.0) {
      ++overloaded;
      EXPECT_FALSE(r.schedulable());
      continue;
    }
    std::vector<std::int64_t> offsets;
    for (int i = 0; i < n; ++i) offsets.push_back(static_cast<std::int64_t>(rng() % 20000) * 1000);
    const auto worst = simulate(set, offsets, r, 200'000'000);  // 200 ms
    for (int i = 0; i < n; ++i) {
      const auto& m = r.messages[i];
      if (!m.response) continue;
      ++analysed;
      EXPECT_LE(worst[i], m.response->count()) << "round " << round << " message " << i;
      EXPECT_GE(*m.response, *m.response_first);
      EXPECT_GE(*m.response_first, m.transmission + m.blocking);
    }
  }
  EXPECT_GT(analysed, 300);
  EXPECT_GT(overloaded, 5);
}

// The analysis against can::TimedBus (docs/can-bus.md "The bus in time"), whose nodes have FIFO
// transmit queues: random sets of messages spread over 1..3 nodes, released at random offsets and
// then every period for 200 ms of bus time. With each node's queue declared (RtaMessage::fifo) no
// frame's request-to-end is ever above its bound; analysed as if every node sent in priority
// order, the bound is exceeded in some sets (a node's high frame behind its own low one).
TEST(ResponseTime, FifoNodesBoundTheTimedBus) {
  std::mt19937 rng(3611);
  const std::int64_t periods[] = {2000, 2500, 5000, 10000, 20000};  // us
  int analysed = 0, exceeded_without_fifo = 0;
  for (int round = 0; round < 150; ++round) {
    const int n = 2 + static_cast<int>(rng() % 7), nodes = 1 + static_cast<int>(rng() % 3);
    std::vector<RtaMessage> set;
    std::vector<std::uint32_t> ids;
    for (int i = 0; i < n; ++i) {
      std::uint32_t id = 0;
      do id = static_cast<std::uint32_t>(rng() % 0x800);
      while (std::find(ids.begin(), ids.end(), id) != ids.end());
      ids.push_back(id);
      set.push_back(
          msg(id, static_cast<std::uint8_t>(rng() % 9), microseconds(periods[rng() % 5])));
      set.back().fifo = 1 + static_cast<std::uint32_t>(rng() % static_cast<unsigned>(nodes));
    }
    const RtaReport r = analyse_response_times(set, 250'000);
    std::vector<RtaMessage> priority_order = set;
    for (auto& m : priority_order) m.fifo = 0;
    const RtaReport naive = analyse_response_times(priority_order, 250'000);
    if (!r.schedulable()) continue;
    TimedBus bus(250'000, Time{0});
    for (int k = 0; k < nodes; ++k) bus.add_node(64);
    std::vector<Time> next;
    for (int i = 0; i < n; ++i) next.push_back(Time{static_cast<std::int64_t>(rng() % 20000)});
    const Time horizon{200'000};
    for (;;) {
      const Time release = *std::min_element(next.begin(), next.end());
      const auto on_bus = bus.next_deadline();
      if (release > horizon && (!on_bus || *on_bus > horizon)) break;
      if (on_bus && *on_bus <= release) {
        bus.advance(*on_bus);
        continue;
      }
      bus.advance(release);
      for (int i = 0; i < n; ++i)
        if (next[i] == release) {
          const auto& m = set[i];
          ASSERT_TRUE(bus.request(
              m.fifo - 1, Frame::std_data(m.id.id, std::vector<std::uint8_t>(m.dlc)), release));
          next[i] += std::chrono::duration_cast<Duration>(m.period);
        }
    }
    bool exceeded = false;
    for (int i = 0; i < n; ++i) {
      const auto s = bus.identifiers().at(arbitration_key(set[i].id, false));
      // Request to end: the queueing latency (to the start of frame, stamped to the microsecond
      // at or after its bit) and the frame's exact length.
      const auto end =
          std::chrono::duration_cast<nanoseconds>(s.latency_max) +
          frame_duration(Frame::std_data(set[i].id.id, std::vector<std::uint8_t>(set[i].dlc)),
                         250'000);
      ++analysed;
      EXPECT_LE(end, *r.messages[i].response + microseconds(1))
          << "round " << round << " message " << i << " 0x" << std::hex << set[i].id.id;
      exceeded = exceeded || !naive.messages[i].response ||
                 end > *naive.messages[i].response + microseconds(1);
    }
    exceeded_without_fifo += exceeded ? 1 : 0;
  }
  EXPECT_GT(analysed, 200);
  EXPECT_GT(exceeded_without_fifo, 0);
}

}  // namespace
}  // namespace candp2::can

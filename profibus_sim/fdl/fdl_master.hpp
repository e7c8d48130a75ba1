// The FDL master station (docs/profibus.md): the simulated DP master's remote stations on one
// serial line. Pure: bytes out through a callback, bytes in through on_bytes(), time passed in,
// no I/O, no clock, no threads.
//
// It is the only master on its line (a single-master line). It sends no token telegrams (SD4):
// the token only moves the right to send between masters, and there is no other master to pass
// it to; slaves ignore SD4 (the table in docs/profibus.md). pyprofibus, an open-source class 1
// master, does the same (pyprofibus/dp_master.py never sends a token; a received one is ignored,
// "TODO handle token"), and the capture of docs/profibus.md starts with FDL_Status, no token. A
// standard master alone in its logical ring would pass the token to itself (SD4 with DA = SA); that
// only lets another master join the ring, which this product does not support.
//
// Behaviour (docs/profibus.md):
//  - one telegram outstanding on the line at a time; DP requests queue up in arrival order;
//  - a station is first asked for its FDL_Status (SD1 FC 0x49), at start and after it was lost;
//  - FCB per station: the first SRD after FDL_Status carries FCB=1 FCV=0, every later one FCV=1
//    and the toggled FCB; a retry repeats the SAME FCB (the slave then resends its last answer);
//  - slot time: the answer must start within slot_time_bits bit times after the request's last
//    character; once a character arrived, the master waits for the rest of the telegram (the wire
//    time of the longest telegram, plus the allowance). The request's own wire time (11 bits a
//    character) is added, since the slot time runs from its last character, plus
//    `latency_allowance` for the PHY/OS latency of a pty or a USB adapter;
//  - no valid answer within the slot time (nothing, a bad FCS, a framing/parity error, a telegram
//    from another station): the request is repeated up to `retries` times (max_retry_limit), then
//    the DP request completes with NoResponse and the station needs FDL_Status again;
//  - between telegrams the line idles ≥ TSYN (33 bit times).
//
// Wiring it into the daemon (candp2d, role master):
//
//   fdl::FdlMaster line({.address = 2, .baud = 19200, .slot_time_bits = 100, .retries = 1,
//                        .latency_allowance = milliseconds(5)},
//                       [&](std::span<const std::uint8_t> bytes, Time now) { phy.write(bytes); },
//                       log);
//   dp::DpMaster master(options, log);
//   master.add_slave(line.station(3), params);  // one per remote gateway, its DP address
//   // event loop:
//   //   serial readable          → line.on_bytes(bytes, now)
//   //   (PHY saw a parity error) → line.on_bad_char(byte, now)
//   //   (PHY saw idle ≥ TSYN)    → line.on_gap(now)        (optional: the slot timer also ends it)
//   //   timer at line.next_deadline() → line.advance(now)
//   //   master cycle timer       → master.cycle(now)
//   // status: line.stats(3), line.line_stats(); both only read.
//
// DP completions (and so the DP master's state machine) run from inside on_bytes()/advance().
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "common/line_physics.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "profibus_sim/dp/slave_link.hpp"
#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl {

struct MasterStationOptions {
  std::uint8_t address = 2;  // this master's FDL address (0..126)
  std::uint32_t baud = 19200;
  // TSL in bit times (docs/profibus.md: typical 100 at ≤ 187.5k; the bus parameters set it).
  std::uint32_t slot_time_bits = 100;
  // max_retry_limit: repetitions of a request that got no valid answer (docs/profibus.md: 1).
  std::uint8_t retries = 1;
  // Added to the slot time: what the PHY, the OS and a USB adapter add to the answer's delay.
  Duration latency_allowance{0};
};

// Response-time histogram buckets (upper bounds, µs): ≤100, ≤200, ≤500, ≤1000, ≤2000, ≤5000,
// ≤10000, more.
inline constexpr std::array<std::int64_t, 7> kResponseBuckets = {100,  200,  500,  1000,
                                                                 2000, 5000, 10000};

struct MasterStationStats {
  std::uint64_t telegrams_sent = 0;  // requests put on the line (FDL_Status and retries included)
  std::uint64_t responses = 0;       // valid answers
  std::uint64_t timeouts = 0;        // slot times that expired without a valid answer
  std::uint64_t invalid = 0;         // answers not taken: wrong station/SAPs, unexpected kind
  std::uint64_t lost = 0;            // times the station was given up (retries exhausted)
  std::uint64_t fdl_status = 0;      // FDL_Status requests sent
  // Response time: request's last character → answer complete (as on_bytes() saw it).
  Duration rt_min{0}, rt_max{0}, rt_sum{0};
  std::array<std::uint64_t, kResponseBuckets.size() + 1> rt_histogram{};
  Duration rt_avg() const {
    return responses ? Duration(rt_sum.count() / static_cast<std::int64_t>(responses))
                     : Duration(0);
  }
};

class FdlMaster {
 public:
  // Bytes of one telegram to put on the line, at `now` (the PHY writes them at once).
  using SendFn = std::function<void(std::span<const std::uint8_t> bytes, Time now)>;

  FdlMaster(MasterStationOptions options, SendFn send, LogSink* log = nullptr);
  ~FdlMaster();
  FdlMaster(const FdlMaster&) = delete;
  FdlMaster& operator=(const FdlMaster&) = delete;

  // The remote station at `address` (1..126) as a dp::SlaveLink for dp::DpMaster::add_slave;
  // created on first use, owned by this object.
  dp::SlaveLink& station(std::uint8_t address);

  // Received bytes (telegrams may be split over calls or share one).
  void on_bytes(std::span<const std::uint8_t> bytes, Time now);
  // A character received with a parity/framing error: the telegram it belongs to is dropped.
  void on_bad_char(std::uint8_t byte, Time now);
  // Idle ≥ TSYN: a partial telegram is abandoned.
  void on_gap(Time now);

  std::optional<Time> next_deadline() const;
  void advance(Time now);

  // A duration of `bits` bit times at the configured rate (rounded up to the microsecond).
  Duration bit_times(std::uint64_t bits) const;
  // Wire time of `bytes` characters (docs/profibus.md "The line's physics").
  Duration wire_time(std::size_t bytes) const { return bit_times(phy::kBitsPerChar * bytes); }

  const MasterStationStats* stats(std::uint8_t address) const;
  // The telegram being sent repeats one that got no valid answer (the same FCB): true inside the
  // send callback of a repeat. The repeats themselves are counted once, by whoever watches the
  // line (fdl::LineStatistics' `repeats`, docs/profibus.md "Line statistics in role master").
  bool repeating() const { return current_ && current_->attempt > 0; }
  const ParserStats& line_stats() const { return parser_.stats(); }
  const MasterStationOptions& options() const { return options_; }
  // What the PHY adds to the slot time; known once the port is open (a pty, a USB adapter).
  void set_latency_allowance(Duration d) { options_.latency_allowance = d; }
  // Sees every valid telegram received on the line, as its raw bytes (a capture's tap).
  using ObserveFn = std::function<void(std::span<const std::uint8_t> raw, Time now)>;
  void set_observer(ObserveFn observe) { observe_ = std::move(observe); }
  // Sees every telegram received and dropped (bad FCS, framing, parity, cut by a gap), as the
  // bytes the parser abandoned (a line statistics' illegal telegram).
  void set_drop_observer(ObserveFn observe) { drop_observe_ = std::move(observe); }
  bool idle() const { return !current_ && queue_.empty(); }

 private:
  class Remote;
  struct Pending {
    Remote* station = nullptr;
    dp::Request request;
    dp::Completion done;
  };
  struct Outstanding {
    Pending pending;
    bool fdl_status = false;  // this telegram is the FDL_Status request before `pending`
    std::vector<std::uint8_t> bytes;
    std::uint8_t fc = 0;
    int attempt = 0;              // 0 = first send, 1.. = retries
    Time request_end{0};          // the request's last character on the wire
    Time deadline{0};             // slot time expiry
    bool answer_started = false;  // a character arrived within the slot time
  };

  void enqueue(Pending p, Time now);
  void start_next(Time now);
  void transmit(Time now);
  void on_telegram(const Telegram& t, Time now);
  void expire(Time now);
  void finish(dp::Response r, Time now);
  std::optional<dp::Response> match(const Telegram& t) const;
  std::vector<std::uint8_t> build(Outstanding& o);
  ObserveFn observe_;
  ObserveFn drop_observe_;
  void drain(Time now);

  MasterStationOptions options_;
  SendFn send_;
  Logger log_;
  std::map<std::uint8_t, std::unique_ptr<Remote>> stations_;
  std::deque<Pending> queue_;
  std::optional<Outstanding> current_;
  Time line_free_at_{0};  // end of the last telegram on the line + TSYN
  StreamParser parser_;
  bool completing_ = false;  // inside a DP completion: start_next() waits until it returns
};

}  // namespace candp2::fdl

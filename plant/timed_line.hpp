// The in-process PROFIBUS line in time (docs/profibus.md "The line in time"): the built-in master
// and the emulated stations share one line with a baud rate and bus parameters. One scheduler owns
// the line's time and puts one telegram after the other on it:
//
//   request (after TID1/TID2 idle) ─ last character: the station gets it ─ TSDR ─ response ─ TID1
//
// A station's DP services run when the request's last character has arrived (a gateway applies
// its outputs then and sends its CAN frames from then on); the master's request completes when the
// response's last character has arrived. No answer within the slot time: the request is repeated up
// to retry_limit times, then it completes with NoResponse. A station is asked for its FDL_Status
// before its first DP request and after it was lost. A request the master makes while it handles a
// station's answer (the next step of a parameterization, the first Data_Exchange, the Slave_Diag
// after a refusal) goes next, before the other stations' requests: a station is parameterized in
// one go. When the master's requests of a rotation are
// done it passes the token to itself (SD4) and, every gap_factor rotations, asks one address of
// its GAP (above its own, up to HSA) for its FDL_Status, where nobody answers within the slot time.
//
// Time is counted in bit times from the line's origin, so TSYN, TSDR, TID1/TID2 and the slot time
// hold to the bit; events are stamped with the first microsecond at or after their bit. One event
// per telegram (the request's end, the response's end), none per bit. Pure: time passed in.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "common/log.hpp"
#include "common/time.hpp"
#include "plant/line_fault.hpp"
#include "profibus_sim/dp/slave_link.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"
#include "profibus_sim/fdl/line_stats.hpp"
#include "profibus_sim/fdl/line_timing.hpp"
#include "profibus_sim/fdl/wire_faults.hpp"

namespace candp2::plant {

class TimedLine {
 public:
  // One telegram as it is on the wire, stamped with the time its first character starts.
  using TapFn =
      std::function<void(std::span<const std::uint8_t> telegram, bool from_master, Time start)>;
  // One telegram on the line in bit times from the origin (tests, the capture check).
  struct Telegram {
    std::uint64_t start_bit = 0, end_bit = 0;
    bool from_master = false;
    std::vector<std::uint8_t> bytes;
  };

  // An idle before a telegram shorter than this is not an event of its own (the event loop's
  // timer slack is 50 µs): the telegram is given to the tap when it is put on the line.
  static constexpr Duration kMergeBelow{50};

  TimedLine(std::uint32_t baud, fdl::BusParameters params, std::uint8_t master, Time origin,
            LogSink* log = nullptr);
  ~TimedLine();
  TimedLine(const TimedLine&) = delete;
  TimedLine& operator=(const TimedLine&) = delete;

  // The station behind `inner` (a dp::InProcessLink: it completes within its call) as the link
  // the master uses. `max_tsdr_bits`: the GSD's MaxTsdr at this rate; it answers no later.
  // `slave` says whether it is on the bus (an offline station answers nothing, FDL_Status neither).
  dp::SlaveLink& add_station(dp::SlaveLink& inner, const dp::DpSlave& slave,
                             std::optional<std::uint32_t> max_tsdr_bits);
  // The station restarted: its next request starts with FDL_Status again.
  void restarted(std::uint8_t address);
  void set_tap(TapFn tap) { tap_ = std::move(tap); }
  // Keeps every telegram (bit times) for tests; off by default.
  void set_record(bool on) { record_ = on; }
  const std::vector<Telegram>& record() const { return recorded_; }

  // The master's rotation: begin_rotation() before DpMaster::cycle(), end_issue() after it (the
  // requests of the cycle are polled in address order). The rotation ends after the token.
  void begin_rotation(Time now);
  void end_issue(Time now);
  bool rotating() const { return rotating_; }

  // With a step: the next event comes due no sooner than `step` after the last advance (a real
  // time driver's batching; the line's bits and stamps stay exact, its effects come late by less
  // than the step). 0: at every event's own bit.
  void set_step(Duration step) { step_ = step; }
  std::optional<Time> next_deadline() const;
  void advance(Time now);

  std::uint32_t baud() const { return baud_; }
  const fdl::BusParameters& parameters() const { return params_; }
  Time time_of(std::uint64_t bit) const { return origin_ + fdl::bits_to_time(baud_, bit); }
  // The bit a request that is ready at `t` starts at: the line's free bit when `t` is the time
  // stamp of that bit (cycles back to back), else the first whole bit at or after `t`.
  std::uint64_t start_bit(Time t) const;
  // The time of the earliest bit the next request may start at (after a rotation: the end of
  // the TID2 after its token).
  Time free_time() const { return time_of(free_bit_); }
  // The station's answer delay (min_TSDR of its last Set_Prm, at most its MaxTsdr).
  std::uint32_t tsdr_bits(std::uint8_t address) const;

  // The measured bus cycle: one rotation from its first telegram to the end of the idle after the
  // token (docs/profibus.md "The line in time"), of the steady line: rotations in which the master
  // parameterized no station. A rotation with a station's FDL_Status, Set_Prm or Chk_Cfg (the
  // start-up, a station lost or parameterized again) is counted apart.
  const fdl::RotationTimes& bus_cycle() const { return cycles_; }
  const fdl::RotationTimes& parameterization_cycle() const { return parameterizing_; }
  std::uint64_t retries() const { return retries_; }
  std::uint64_t gap_polls() const { return gap_polls_; }

  // What an analyser on this line counts (docs/profibus.md "Line statistics").
  const fdl::LineStatistics& statistics() const { return stats_; }

  // Faults on cue (docs/faults.md "Line faults"). A station's fault applies to one answer in every
  // `every` requests it receives (repeats included), `count` times, or for `duration` instead; a
  // new fault replaces the one before, kind None cancels. False: no such station.
  // A station's fault (plant/line_fault.hpp; noise has noise()). False: no such station.
  bool inject(const LineFault& fault, Time now);
  // Every telegram that starts on the line from now for `duration` is garbled.
  void noise(Duration duration, Time now);
  // The station's active fault: kind, remaining count (0 with a duration), every, remaining time.
  struct FaultState {
    fdl::StationFault kind = fdl::StationFault::None;
    std::uint32_t remaining = 0, every = 1;
    Duration remaining_time{0};
  };
  FaultState fault(std::uint8_t address, Time now) const;
  // The same at the line's last advance (the faces' view between events).
  FaultState fault(std::uint8_t address) const { return fault(address, now_); }
  Time now() const { return now_; }
  Duration noise_remaining(Time now) const {
    return now < noise_until_ ? noise_until_ - now : Duration(0);
  }

 private:
  class Station;
  struct Job {
    Station* station = nullptr;
    dp::Request request;
    dp::Completion done;
  };
  // Idle: nothing on the line. Sync: the idle before a request (ends when it starts); Request: its
  // characters; Tsdr: the station's delay; Response: the answer's characters; SlotTime: nobody
  // answered yet; Unanswered: TID2 after a telegram without an answer.
  enum class Phase : std::uint8_t { Idle, Sync, Request, Tsdr, Response, SlotTime, Unanswered };
  // The exchange on the line: one, kept from telegram to telegram with its buffers (no allocation
  // a telegram once they have held the longest).
  struct OnLine {
    std::optional<Job> job;   // none: FDL_Status to a GAP address or the token
    bool fdl_status = false;  // this telegram is the FDL_Status before the job
    std::vector<std::uint8_t> request;
    fdl::Telegram telegram;
    std::uint32_t attempt = 0;
    dp::Response answer;       // the station's (a repeat gets it again, an SDN's is empty)
    bool stored = false;       // the station answered it once: a repeat gets the same answer (FCB)
    bool handed_over = false;  // job->request went to the station (moved: its data is gone)
    std::vector<std::uint8_t> response;
    std::uint64_t response_bits = 0;
    bool deaf = false;     // the request was garbled on the wire (`request` is not `telegram`): the
                           // station did not get it
    bool illegal = false;  // the answer was garbled: the master cannot use it
    std::vector<std::uint8_t> late;  // an answer that comes after the slot time
    fdl::Telegram answer_telegram;   // what `response` is, unless `illegal`
    void begin();                    // a new exchange
  };
  // A late answer: it starts on the line when the slot time has expired.
  struct Late {
    std::uint64_t bit = 0;
    std::vector<std::uint8_t> bytes;
  };

  void enqueue(Job job, Time now);
  // The exchange's completion, told to the master: a request it makes for the same station
  // meanwhile goes next (docs/profibus.md "The line in time": in one go).
  void complete(const dp::Response& r, std::uint64_t at_bit);
  void start_next(std::uint64_t at_bit);
  // The current exchange's telegram on the line from `at_bit` (or when the line is free).
  void put_request(std::uint64_t at_bit);
  void on_request_start();
  void on_request_end();
  void on_response_start();
  void on_response_end();
  void on_slot_expired();
  void on_unanswered_end();
  void unanswered(std::uint64_t free_bit);
  // An idle of `bits` is shorter than kMergeBelow: not an event of its own.
  bool merged(std::uint64_t bits) const { return fdl::bits_to_time(baud_, bits) < kMergeBelow; }
  // time_of(event_bit_), computed once an event.
  Time event_time() const;
  void flush_late();
  bool noisy(std::uint64_t bit) const;
  void finish(dp::Response r);
  void emit(std::span<const std::uint8_t> bytes, bool from_master, std::uint64_t start,
            std::uint64_t end, const fdl::Telegram* decoded = nullptr);
  std::optional<std::uint8_t> next_gap_address();

  std::uint32_t baud_;
  fdl::BusParameters params_;
  std::uint8_t master_;
  Time origin_;
  Logger log_;
  TapFn tap_;
  bool record_ = false;
  std::vector<Telegram> recorded_;
  std::map<std::uint8_t, std::unique_ptr<Station>> stations_;
  // The requests waiting: queue_[head_..] (a vector that is emptied when all are taken).
  std::vector<Job> queue_;
  std::size_t head_ = 0;
  std::size_t sorted_from_ = 0;  // queue_ index where the requests of this cycle start
  // The station whose answer the master is handling: its next request goes first.
  const Station* answering_ = nullptr;
  Phase phase_ = Phase::Idle;
  OnLine current_;               // valid while phase_ is not Idle
  std::uint64_t event_bit_ = 0;  // the bit the current phase ends at
  std::uint64_t free_bit_ = 0;   // the earliest bit the next request may start at
  bool rotating_ = false;
  bool holding_ = false;  // issuing or handling an event: new requests wait in the queue
  bool token_sent_ = false;
  bool gap_done_ = false;                                 // this rotation looked after its GAP
  std::uint64_t request_start_ = 0, response_start_ = 0;  // of the telegrams on the line
  std::uint64_t request_end_ = 0;
  std::optional<std::uint64_t> rotation_start_;
  std::uint64_t rotations_ = 0;
  std::uint8_t gap_next_ = 0;
  std::uint64_t retries_ = 0, gap_polls_ = 0;
  fdl::RotationTimes cycles_, parameterizing_;
  bool parameterizes_ = false;  // this rotation has a station's FDL_Status, Set_Prm or Chk_Cfg
  fdl::LineStatistics stats_;
  std::optional<Late> late_;
  Time noise_from_{0}, noise_until_{0};
  Time now_{0};  // of the last advance()
  Duration step_{0};
  Time handled_{0};  // when advance() last handled an event (the step counts from there)
  mutable std::uint64_t deadline_bit_ = ~std::uint64_t{0};
  mutable Time deadline_time_{0};
};

}  // namespace candp2::plant

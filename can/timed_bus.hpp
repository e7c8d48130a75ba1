// A classic CAN bus in time (docs/can-bus.md "The bus in time"): nodes with transmit queues, one
// frame on the bus at a time, bitwise arbitration among the frames at the heads of the queues when
// the bus is idle, each frame on the bus for its exact length (can/frame_bits.hpp) at the bit rate,
// its receivers getting it at its end:
//
//   request ─ queue ─ (bus idle, wins arbitration) start of frame ─ frame_bits_exact ─ end:
//   received
//
// Time is counted in bit times from the bus's origin, so back-to-back frames follow one another to
// the bit; a frame is stamped with the first microsecond at or after its bit. One event per frame
// (its end, where the next frame is chosen), none per bit. A frame requested past a full queue is
// lost: request() says so and the owner counts it where the device counts it. Statistics per bus
// (load over each second of bus time, frames, lost) and per identifier (frames, period, jitter,
// queueing latency from request to start of frame).
//
// Error confinement (docs/can-bus.md "Error confinement", ISO 11898-1 / Bosch CAN 2.0 part B §8):
// per node a transmit and a receive error counter and the state they give (error active, warning,
// error passive, bus-off and its recovery); a frame in error occupies the bus up to its error, then
// the error frame, and is retransmitted. Errors come from faults set on cue (error frames on an
// identifier or a node, noise, a node unplugged or at a wrong bit rate) and, once
// check_acknowledgement(true), from frames nobody else acknowledges. Without them every frame is
// received without error, as before. The frames' way over the bus is can/timed_bus.cpp, the
// confinement rules can/timed_bus_confinement.cpp.
//
// Pure: no sockets, no clock, no threads; time passed in.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "can/channel.hpp"
#include "can/frame.hpp"
#include "can/id_counts.hpp"
#include "common/ring.hpp"
#include "common/time.hpp"

namespace candp2::can {

class TimedBus {
 public:
  // Why a frame ends in an error frame (docs/can-bus.md "Error confinement"), by where the error is
  // detected: the sender at a wrong bit rate (at the sixth bit), a fault on cue (at the last CRC
  // bit), nobody acknowledged (at the ACK slot).
  enum class Error : std::uint8_t { None, WrongBitrate, Injected, Ack };
  // A frame on the bus: its sender (node index), its first bit and its end (after intermission;
  // after the error frame's intermission when it is in error), in bit times from the origin, and
  // their time stamps. A frame in error is not received and stays at the head of its queue.
  struct OnBus {
    std::size_t node = 0;
    Frame frame;
    std::uint64_t start_bit = 0, end_bit = 0;
    Time requested{0}, start{0}, end{0};
    Error error = Error::None;
  };
  // An error frame: error flag (6), error delimiter (8), then the intermission (3).
  static constexpr std::uint32_t kErrorFrameBits = 6 + 8 + 3;
  // The first bit of the error flag of a frame in error.
  static std::uint64_t error_flag_bit(const OnBus& f) { return f.end_bit - kErrorFrameBits; }
  // A node's error confinement (ISO 11898-1 fault confinement).
  struct Confinement {
    std::uint32_t tec = 0, rec = 0;
    BusState state = BusState::Ok;
    std::uint64_t error_frames_sent = 0;  // error frames in its own frames
    std::uint64_t error_frames_seen = 0;  // error frames in the others' frames it took part in
    std::uint64_t bus_off = 0;            // times it went bus-off
    std::uint64_t discarded = 0;          // frames its queue held when it went bus-off
  };
  // Error frames on cue: on the frames of `node` or of `id` (neither: every frame, noise), one in
  // every `every` of them, `count` times, or every such frame that starts before `until`.
  struct ErrorFault {
    std::optional<std::size_t> node;
    std::optional<Ident> id;
    std::uint32_t count = 1, every = 1;
    std::optional<Time> until;
    std::uint64_t matched = 0;  // frames of it seen so far
  };
  // Called when a frame starts (it won arbitration) and when it has ended (its receivers get it).
  using Hook = std::function<void(const OnBus&)>;

  // Per identifier: frames, period, jitter, queueing latency (can/id_counts.hpp).
  using IdStatistics = can::IdStatistics;
  // The load of one second of bus time: the bits that frames occupied in it over the bits it has.
  struct Load {
    double last_pct = 0;  // the last complete second
    double max_pct = 0;   // the most loaded complete second so far
  };

  TimedBus(std::uint32_t bitrate, Time origin);
  TimedBus(const TimedBus&) = delete;
  TimedBus& operator=(const TimedBus&) = delete;

  // A node with a transmit queue of `depth` frames (FIFO: its head contends).
  std::size_t add_node(std::size_t depth);
  // The node's name (status documents; the engine does not use it).
  void set_name(std::size_t node, std::string name) { nodes_.at(node).name = std::move(name); }
  const std::string& name(std::size_t node) const { return nodes_.at(node).name; }
  bool present(std::size_t node) const { return nodes_.at(node).present; }
  // A new depth for the node's queue (frames already queued beyond it stay).
  void set_depth(std::size_t node, std::size_t depth) { nodes_.at(node).depth = depth; }
  // The node left the bus: its queue is emptied (a frame on the bus still ends).
  void remove_node(std::size_t node);
  // The node asks to send `frame` at `now` (not before the last advance). False: its queue is full
  // and the frame is lost (counted in lost()), or the node is bus-off (not counted: its owner
  // refuses to send while bus-off). `node` is one add_node() gave.
  bool request(std::size_t node, const Frame& frame, Time now);

  void on_start(Hook hook) { on_start_ = std::move(hook); }
  void on_end(Hook hook) { on_end_ = std::move(hook); }
  // Called when next_deadline() may have moved (a request, an advance, a node leaving or
  // unplugged): the owner of many buses asks again only those (the plant, docs/can-bus.md
  // "Performance").
  void on_moved(std::function<void()> hook) {
    on_moved_ = std::move(hook);
    told_ = false;
  }
  // Called when a node's confinement state changes (after the frame that changed it, or at its
  // bus-off recovery).
  void on_state(std::function<void(std::size_t node, BusState)> hook) {
    on_state_ = std::move(hook);
  }

  // ---- error confinement and faults on cue (docs/can-bus.md "Error confinement") -----------
  // With it, a frame that no other node acknowledges (present, plugged, at the bus's bit rate,
  // not bus-off) is an ACK error. Without it (the default) every frame is acknowledged: the bus
  // as a timing model alone.
  void check_acknowledgement(bool on) { check_ack_ = on; }
  // Error frames on cue (at each start of frame from now on).
  void inject_errors(const ErrorFault& fault) { faults_.push_back(fault); }
  // The error frames on cue still in force (`count` what is left of a count; one whose `until`
  // has passed goes at the next start of frame).
  const std::vector<ErrorFault>& error_faults() const { return faults_; }
  // The node sends nothing (its queue waits), acknowledges nothing, gets nothing.
  void set_unplugged(std::size_t node, bool on) {
    nodes_.at(node).unplugged = on;
    recount();
    moved();
  }
  // The node runs at another bit rate: its frames are errors for all, the others' for it.
  void set_wrong_bitrate(std::size_t node, bool on) {
    nodes_.at(node).wrong_bitrate = on;
    recount();
  }
  bool wrong_bitrate(std::size_t node) const { return nodes_.at(node).wrong_bitrate; }
  // A node that receives but never acknowledges (a listen-only analyser): false.
  void set_acknowledges(std::size_t node, bool on) {
    nodes_.at(node).acknowledges = on;
    recount();
  }
  // Cancels a node's faults (error frames on it, unplugged, wrong bit rate), or with nullopt
  // every fault on the bus.
  void clear_faults(std::optional<std::size_t> node);
  const Confinement& confinement(std::size_t node) const { return nodes_.at(node).conf; }
  // The node takes a frame that ends without error: present, plugged, at the bus's bit rate and
  // not bus-off.
  bool receives(std::size_t node) const { return receives(nodes_.at(node)); }
  // Every node on the bus receives (none unplugged, at a wrong bit rate or bus-off; recount()).
  bool all_receive() const { return all_receive_; }
  std::uint64_t error_frames() const { return error_frames_; }
  std::size_t nodes() const { return nodes_.size(); }

  // When the bus next needs advancing: the end of the frame on it, or the start of the next.
  // Kept until the bus changes (the plant asks for it at every step of every bus).
  std::optional<Time> next_deadline() const;
  // Runs every start and end of frame at or before `now`. When the bus goes idle at a bit, the
  // heads of the queues requested by then contend; the smallest arbitration_key wins.
  void advance(Time now);

  std::uint32_t bitrate() const { return bitrate_; }
  Time time_of(std::uint64_t bit) const {
    // A bit a whole number of microseconds long (every CAN-DP/2 rate but 666.6k, 333.3k, 166k,
    // 66.6k and 33.3k): no rounding, so bits_to_time() is that product (docs/can-bus.md
    // "Performance": the divisions cost).
    if (us_per_bit_ != 0) return origin_ + Duration(static_cast<std::int64_t>(bit * us_per_bit_));
    return time_of_rounded(bit);
  }
  // The first whole bit at or after `t`.
  std::uint64_t bit_at(Time t) const {
    // A bit a whole number of microseconds long: the microseconds over it, rounded up, which is
    // what time_to_bits() gives, with one division instead of its two, none at 1 µs a bit (asked
    // at every request).
    if (us_per_bit_ == 0) return bit_at_rounded(t);
    if (t <= origin_) return 0;
    const auto us = static_cast<std::uint64_t>((t - origin_).count());
    return us_per_bit_ == 1 ? us : (us + us_per_bit_ - 1) / us_per_bit_;
  }
  bool busy() const { return busy_; }
  std::size_t queued(std::size_t node) const { return nodes_.at(node).queue.size(); }

  // Frames put on the bus without error (a frame in error counts in error_frames()).
  std::uint64_t frames() const { return frames_; }
  std::uint64_t lost() const { return lost_; }
  std::uint64_t busy_bits() const { return busy_bits_; }
  // The load as of `now` (a second with no frame counts as 0 %); a second the bus has not been
  // advanced through while frames wait counts as not complete.
  Load load(Time now) const;
  // By arbitration_key (the order of priority); built at each call (replay's expect_bus looks
  // identifiers up by key; not per frame).
  std::map<std::uint32_t, IdStatistics> identifiers() const { return ids_.identifiers(); }
  // The same in the same order as a list, into `out` (cleared, its storage kept): the status
  // documents list every identifier of every bus, twice a second with a panel open, and a map's
  // node per identifier cost more than the rest (docs/can-bus.md "Performance").
  void identifiers(std::vector<IdStatistics>& out) const { ids_.identifiers(out); }

 private:
  struct Pending {
    Frame frame;
    Time requested{0};
    std::uint64_t requested_bit = 0;  // bit_at(requested), counted once
    std::uint32_t key = 0;            // arbitration_key(frame), counted once
    // frame_bits_exact(frame), counted at the request: the frame and the tables are in the cache
    // then (a node sends its frames in bursts), and a frame repeated after an error is not
    // counted again (docs/can-bus.md "Performance").
    std::uint32_t bits = 0;
  };
  // A node's transmit queue: a ring that grows to the most frames it held, so that no frame
  // allocates (docs/can-bus.md "Performance").
  // The head's request time, bit and key are kept beside the ring: arbitration and the bus's
  // deadline read them for every node at every start of frame without reaching into the ring.
  class Fifo {
   public:
    bool empty() const { return ring_.empty(); }
    std::size_t size() const { return ring_.size(); }
    const Pending& front() const { return ring_.front(); }
    Time front_requested() const { return front_requested_; }
    std::uint64_t front_bit() const { return front_bit_; }
    std::uint32_t front_key() const { return front_key_; }
    // Queues a frame, its fields written in place.
    void push_back(const Frame& frame, Time requested, std::uint64_t bit, std::uint32_t key,
                   std::uint32_t bits) {
      Pending& p = ring_.push_back_slot();
      p.frame = frame;
      p.requested = requested;
      p.requested_bit = bit;
      p.key = key;
      p.bits = bits;
      if (ring_.size() == 1) keep_front();
    }
    void pop_front() {
      ring_.pop_front();
      if (!ring_.empty()) keep_front();
    }
    void clear() { ring_.clear(); }

   private:
    void keep_front() {
      const Pending& p = ring_.front();
      front_requested_ = p.requested;
      front_bit_ = p.requested_bit;
      front_key_ = p.key;
    }
    Ring<Pending> ring_;
    Time front_requested_{0};
    std::uint64_t front_bit_ = 0;
    std::uint32_t front_key_ = 0;
  };

  struct Node {
    std::size_t depth = 0;
    bool present = true;
    Fifo queue;
    bool unplugged = false, wrong_bitrate = false, acknowledges = true;
    std::string name;
    Confinement conf;
    std::uint64_t suspend_until = 0;  // error passive: no start of frame before this bit
    // Bus-off recovery: occurrences of 11 recessive bits counted, and where the current recessive
    // run began (nullopt while a frame is on the bus).
    std::uint32_t recessive_runs = 0;
    std::optional<std::uint64_t> run_from;
    // Its last frame's entry in ids_ (0: none).
    std::uint32_t last = 0;
  };
  // The node may start a frame at `bit`, whose time is `at` (present, plugged, not bus-off, not
  // suspended, a frame requested by then).
  bool contends(const Node& n, std::uint64_t bit, Time at) const;
  static bool receives(const Node& n) {
    return n.present && !n.unplugged && !n.wrong_bitrate && n.conf.state != BusState::BusOff;
  }
  Time time_of_rounded(std::uint64_t bit) const;
  std::uint64_t bit_at_rounded(Time t) const;
  // Another node takes a frame of `node` and acknowledges it (recount()).
  bool acknowledged(std::size_t node) const {
    return acknowledgers_ > 1 || (acknowledgers_ == 1 && acknowledger_ != node);
  }
  // Bus-off recovery (Bosch CAN 2.0 part B §8 rule 12): 128 occurrences of 11 recessive bits.
  static constexpr std::uint32_t kRecessiveRun = 11;
  static constexpr std::uint32_t kRecoveryRuns = 128;
  // No such bit (plain numbers, not std::optional: these are asked at every start and end of
  // frame, docs/can-bus.md "Performance").
  static constexpr std::uint64_t kNoBit = ~std::uint64_t{0};
  // The bit the next frame may start at (kNoBit: nothing queued), and in `winner` the node ready
  // at it with the smallest arbitration key (the first of equal keys).
  std::uint64_t next_start(std::size_t& winner) const;
  // The first bit a bus-off node recovers at, if the bus stays idle (kNoBit: none).
  std::uint64_t next_recovery() const;
  // advance()'s loop: every start, end and recovery due by `now`.
  void run(Time now);
  void recover(std::uint64_t bit);
  // The node that wins arbitration at `bit` (some node contends there).
  std::size_t arbitrate(std::uint64_t bit) const;
  // The head of node `index`'s queue starts at `bit`.
  void start(std::uint64_t bit, std::size_t index);
  // Why the frame `node` starts at `at` ends in an error frame, if it does. Without faults on cue
  // or a wrong bit rate only the ACK can fail, read from recount()'s count (at every frame:
  // docs/can-bus.md "Performance").
  Error error_of(std::size_t node, const Frame& frame, Time at) {
    const bool injected = !faults_.empty() && count_faults(node, frame, at);
    if (nodes_[node].wrong_bitrate) return Error::WrongBitrate;
    if (injected) return Error::Injected;
    return !check_ack_ || acknowledged(node) ? Error::None : Error::Ack;
  }
  // Every fault on cue that matches the frame counts it, expired ones go; true: one of them puts
  // an error frame on it.
  bool count_faults(std::size_t node, const Frame& frame, Time at);
  void finish();
  // The counters and states after frame `f` of node `tx`; not asked for a frame without error on
  // a calm bus (calm_), which changes none.
  void confine(std::size_t tx, const OnBus& f);
  void set_state(std::size_t node);
  // The frame's bits in the load: within the second being counted at once, else count_seconds().
  void count_bits(std::uint64_t from, std::uint64_t bits) {
    busy_bits_ += bits;
    if (from + bits <= (window_ + 1) * bitrate_)
      window_bits_ += bits;
    else
      count_seconds(from, bits);
  }
  void count_seconds(std::uint64_t from, std::uint64_t bits);

  std::uint32_t bitrate_;
  std::uint64_t us_per_bit_;  // when a bit is a whole number of microseconds, else 0
  Time origin_;
  std::vector<Node> nodes_;
  OnBus on_bus_;  // the frame on the bus while busy_, the last one after
  bool busy_ = false;
  std::uint64_t free_bit_ = 0;  // the first bit after the last frame
  std::size_t pending_ = 0;     // frames in all queues
  Hook on_start_, on_end_;
  std::function<void(std::size_t, BusState)> on_state_;
  bool check_ack_ = false;
  std::vector<ErrorFault> faults_;
  std::uint64_t error_frames_ = 0;
  std::uint64_t frames_ = 0, lost_ = 0, busy_bits_ = 0;
  std::uint64_t window_ = 0;       // the second of bus time being counted
  std::uint64_t window_bits_ = 0;  // busy bits in it
  double last_pct_ = 0, max_pct_ = 0;
  // next_deadline() as of the last change (request, advance, a node leaving or unplugged).
  mutable std::optional<Time> deadline_;
  mutable bool deadline_known_ = false;
  mutable bool told_ = false;  // on_moved_ called, next_deadline() not asked since
  std::optional<Time> compute_deadline() const;
  std::function<void()> on_moved_;
  void moved();
  IdCounts ids_;                   // per identifier, counted at each start of frame without error
  std::size_t bus_off_nodes_ = 0;  // nodes in BusOff (none: no recovery to look for)
  // What every frame would otherwise ask of every node, counted again at each change of a node's
  // counters, state or faults (docs/can-bus.md "Performance"): calm_, no node with an error
  // counter above 0, a state other than error active or a wrong bit rate (a frame without error
  // then changes no counter: confine()); the nodes that take frames and acknowledge them
  // (error_of()'s ACK), and the last of them; all_receive_, every node present receives
  // (deliveries at the end of a frame).
  bool calm_ = true, all_receive_ = true;
  std::size_t acknowledgers_ = 0, acknowledger_ = 0;
  void recount();
};

}  // namespace candp2::can

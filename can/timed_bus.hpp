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
// Pure: no sockets, no clock, no threads; time passed in. Error frames, acknowledgement and error
// confinement are not modelled (every frame is received without error).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "can/frame.hpp"
#include "common/time.hpp"

namespace candp2::can {

class TimedBus {
 public:
  // A frame on the bus: its sender (node index), its first bit and its end (after intermission),
  // in bit times from the origin, and their time stamps.
  struct OnBus {
    std::size_t node = 0;
    Frame frame;
    std::uint64_t start_bit = 0, end_bit = 0;
    Time requested{0}, start{0}, end{0};
  };
  // Called when a frame starts (it won arbitration) and when it has ended (its receivers get it).
  using Hook = std::function<void(const OnBus&)>;

  // Per identifier (the arbitration field: identifier, IDE and RTR; a remote frame apart from the
  // data frames of its identifier). Period: the time between two starts of frame; jitter: the
  // largest period less the smallest. Latency: send request to start of frame.
  struct IdStatistics {
    Ident id;
    bool remote = false;
    std::uint64_t frames = 0;
    Time last_start{0};
    Duration period_last{0}, period_min{0}, period_max{0}, period_sum{0};
    Duration latency_last{0}, latency_max{0}, latency_sum{0};
    Duration period_mean() const;
    Duration jitter() const { return period_max - period_min; }
    Duration latency_mean() const;
  };
  // The load of one second of bus time: the bits that frames occupied in it over the bits it has.
  struct Load {
    double last_pct = 0;  // the last complete second
    double max_pct = 0;   // the most loaded complete second so far
  };

  TimedBus(std::uint32_t bitrate, Time origin);

  // A node with a transmit queue of `depth` frames (FIFO: its head contends).
  std::size_t add_node(std::size_t depth);
  // A new depth for the node's queue (frames already queued beyond it stay).
  void set_depth(std::size_t node, std::size_t depth) { nodes_.at(node).depth = depth; }
  // The node left the bus: its queue is emptied (a frame on the bus still ends).
  void remove_node(std::size_t node);
  // The node asks to send `frame` at `now` (not before the last advance). False: its queue is full
  // and the frame is lost.
  bool request(std::size_t node, const Frame& frame, Time now);

  void on_start(Hook hook) { on_start_ = std::move(hook); }
  void on_end(Hook hook) { on_end_ = std::move(hook); }

  // When the bus next needs advancing: the end of the frame on it, or the start of the next.
  std::optional<Time> next_deadline() const;
  // Runs every start and end of frame at or before `now`. When the bus goes idle at a bit, the
  // heads of the queues requested by then contend; the smallest arbitration_key wins.
  void advance(Time now);

  std::uint32_t bitrate() const { return bitrate_; }
  Time time_of(std::uint64_t bit) const;
  // The first whole bit at or after `t`.
  std::uint64_t bit_at(Time t) const;
  bool busy() const { return on_bus_.has_value(); }
  std::size_t queued(std::size_t node) const { return nodes_.at(node).queue.size(); }

  std::uint64_t frames() const { return frames_; }
  std::uint64_t lost() const { return lost_; }
  std::uint64_t busy_bits() const { return busy_bits_; }
  // The load as of `now` (a second with no frame counts as 0 %).
  Load load(Time now) const;
  // By arbitration_key (the order of priority).
  const std::map<std::uint32_t, IdStatistics>& identifiers() const { return ids_; }

 private:
  struct Pending {
    Frame frame;
    Time requested{0};
  };
  struct Node {
    std::size_t depth = 0;
    bool present = true;
    std::deque<Pending> queue;
  };
  // The bit the next frame may start at (nullopt: nothing queued).
  std::optional<std::uint64_t> next_start() const;
  void start(std::uint64_t bit);
  void finish();
  void count_bits(std::uint64_t from, std::uint64_t bits);

  std::uint32_t bitrate_;
  Time origin_;
  std::vector<Node> nodes_;
  std::optional<OnBus> on_bus_;
  std::uint64_t free_bit_ = 0;  // the first bit after the last frame
  std::size_t pending_ = 0;     // frames in all queues
  Hook on_start_, on_end_;
  std::uint64_t frames_ = 0, lost_ = 0, busy_bits_ = 0;
  std::uint64_t window_ = 0;       // the second of bus time being counted
  std::uint64_t window_bits_ = 0;  // busy bits in it
  double last_pct_ = 0, max_pct_ = 0;
  std::map<std::uint32_t, IdStatistics> ids_;
};

}  // namespace candp2::can

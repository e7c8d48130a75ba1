#include "can/timed_bus.hpp"

#include <algorithm>
#include <limits>

#include "can/frame_bits.hpp"
#include "common/line_physics.hpp"

namespace candp2::can {

namespace {
constexpr std::uint64_t kMicrosPerSecond = 1'000'000;
// Where an error is detected, in bits from start of frame to the first bit of the error flag
// (docs/can-bus.md "Error confinement"): a sender at a wrong bit rate breaks the stuffing rule
// within the first six bits the others sample; an error on cue is seen at the last CRC bit;
// an unacknowledged frame at its ACK slot (after the CRC delimiter).
constexpr std::uint32_t kWrongBitrateDetectBits = 6;
constexpr std::uint32_t kAckDetectAfterCrc = 2;
}  // namespace

TimedBus::TimedBus(std::uint32_t bitrate, Time origin)
    : bitrate_(bitrate),
      us_per_bit_(bitrate != 0 && kMicrosPerSecond % bitrate == 0 ? kMicrosPerSecond / bitrate : 0),
      origin_(origin) {}

// Split so that neither product overflows: whole seconds, then the rest of one.
// Bits and microseconds rounded up both ways, as the line in time (common/line_physics.hpp).
Time TimedBus::time_of_rounded(std::uint64_t bit) const {
  return origin_ + phy::bits_to_time(bitrate_, bit);
}

std::uint64_t TimedBus::bit_at_rounded(Time t) const {
  return t <= origin_ ? 0 : phy::time_to_bits(bitrate_, t - origin_);
}

std::size_t TimedBus::add_node(std::size_t depth) {
  Node n;
  n.depth = depth;
  nodes_.push_back(std::move(n));
  recount();
  moved();
  return nodes_.size() - 1;
}

void TimedBus::remove_node(std::size_t node) {
  Node& n = nodes_.at(node);
  pending_ -= n.queue.size();
  n.queue.clear();
  n.present = false;
  recount();
  moved();
}

bool TimedBus::request(std::size_t node, const Frame& frame, Time now) {
  Node& n = nodes_[node];  // the owner's own node (add_node())
  if (n.present && n.conf.state == BusState::BusOff) return false;
  if (!n.present || n.queue.size() >= n.depth) {
    ++lost_;
    return false;
  }
  n.queue.push_back(frame, now, bit_at(now), arbitration_key(frame), frame_bits_exact(frame));
  ++pending_;
  // While a frame is on the bus the deadline is its end, whatever is queued: nothing moved.
  if (!busy_) moved();
  return true;
}

bool TimedBus::contends(const Node& n, std::uint64_t bit, Time at) const {
  return !n.queue.empty() && !n.unplugged && n.conf.state != BusState::BusOff &&
         n.suspend_until <= bit && n.queue.front_requested() <= at;
}

std::uint64_t TimedBus::next_start(std::size_t& winner) const {
  if (pending_ == 0) return kNoBit;
  std::uint64_t first = kNoBit;
  std::uint32_t best = 0;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Node& n = nodes_[i];
    if (n.queue.empty() || n.unplugged || n.conf.state == BusState::BusOff) continue;
    const std::uint64_t ready = std::max({free_bit_, n.queue.front_bit(), n.suspend_until});
    const std::uint32_t key = n.queue.front_key();
    // The earliest ready; of those ready at the same bit the smallest key, the first node of
    // equal keys (as arbitrate() picks).
    if (ready < first || (ready == first && key < best)) {
      first = ready;
      best = key;
      winner = i;
    }
  }
  return first;
}

void TimedBus::moved() {
  deadline_known_ = false;
  // Told once until somebody asks again: the owner marks the bus at the first call and asks
  // next_deadline() for it before it trusts the bus's deadline again (a burst of requests to an
  // idle bus told it once per frame: docs/can-bus.md "Performance").
  if (on_moved_ && !told_) {
    told_ = true;
    on_moved_();
  }
}

std::optional<Time> TimedBus::next_deadline() const {
  told_ = false;
  if (!deadline_known_) {
    deadline_ = compute_deadline();
    deadline_known_ = true;
  }
  return deadline_;
}

std::optional<Time> TimedBus::compute_deadline() const {
  if (busy_) return on_bus_.end;
  std::size_t winner = 0;
  const std::uint64_t s = next_start(winner), r = next_recovery();
  if (r != kNoBit && r <= s) return time_of(r);
  if (s != kNoBit) return time_of(s);
  return std::nullopt;
}

void TimedBus::advance(Time now) {
  // Nothing due by now: the bus stays as it is (the loop below would return at once).
  const auto d = next_deadline();
  if (!d || *d > now) return;
  // Behind by a step (candp2d), several frames are due: the counts of this step's frames are
  // fetched together now, arriving while the first frame is chosen (one cold line at each start
  // of frame otherwise: docs/can-bus.md "Performance"), from the last frame's (its node's last
  // counted entry). Advanced at its deadline (replay), the bus has one event: nothing to fetch.
  if (*d < now && !nodes_.empty()) ids_.prefetch_after(nodes_[on_bus_.node].last);
  run(now);
  // Known again at the next ask (a hook may have asked while the bus was changing).
  moved();
}

void TimedBus::run(Time now) {
  while (true) {
    if (busy_) {
      if (on_bus_.end > now) return;
      finish();
      continue;
    }
    std::size_t winner = 0;
    const std::uint64_t s = next_start(winner), r = next_recovery();
    if (r != kNoBit && r <= s) {
      if (time_of(r) > now) return;
      recover(r);
      continue;
    }
    if (s == kNoBit || time_of(s) > now) return;
    // A bit a whole number of microseconds long: the nodes that contend at s are those ready at
    // s, so next_start()'s pick is arbitration's (docs/can-bus.md "Performance"); else a frame
    // requested within the microsecond of s contends too, as arbitrate() finds.
    start(s, us_per_bit_ != 0 ? winner : arbitrate(s));
  }
}

// ISO 11898-1 bitwise arbitration: of the frames ready when the bus goes idle (each node's head of
// queue), the smallest arbitration field wins; the others wait for the next idle.
std::size_t TimedBus::arbitrate(std::uint64_t bit) const {
  const Time at = time_of(bit);
  std::size_t index = nodes_.size();
  std::uint32_t best = 0;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Node& n = nodes_[i];
    if (!contends(n, bit, at)) continue;
    const std::uint32_t key = n.queue.front_key();
    if (index == nodes_.size() || key < best) {
      index = i;
      best = key;
    }
  }
  return index;
}

void TimedBus::start(std::uint64_t bit, std::size_t index) {
  const Time at = time_of(bit);
  // A bus-off node counts the recessive run this start of frame ends.
  if (bus_off_nodes_ > 0)
    for (Node& n : nodes_)
      if (n.conf.state == BusState::BusOff && n.run_from) {
        n.recessive_runs += static_cast<std::uint32_t>((bit - *n.run_from) / kRecessiveRun);
        n.run_from.reset();
      }
  Node* const winner = &nodes_[index];
  const std::uint32_t best = winner->queue.front_key();
  const Pending& p = winner->queue.front();
  // The identifier's counts are fetched while the frame's error is looked for (a cache miss at
  // every frame otherwise: docs/can-bus.md "Performance"); only a frame without error makes a
  // new entry.
  const std::uint32_t known = ids_.find(winner->last, best);
  if (known) ids_.prefetch(known);
  const Error error = error_of(index, p.frame, at);
  std::uint32_t bits = p.bits;
  if (error != Error::None) {
    // The frame occupies the bus up to its error, then the error frame; it stays at the head of
    // its queue and contends again (automatic retransmission).
    const std::uint32_t stuffed = bits - kTrailerBits;
    const std::uint32_t detect = error == Error::WrongBitrate ? kWrongBitrateDetectBits
                                 : error == Error::Ack        ? stuffed + kAckDetectAfterCrc
                                                              : stuffed;
    bits = detect + kErrorFrameBits;
  }
  // Field by field into the frame on the bus (a temporary copied whole stalled on its own stores).
  busy_ = true;
  on_bus_.node = index;
  on_bus_.frame = p.frame;
  on_bus_.start_bit = bit;
  on_bus_.end_bit = bit + bits;
  on_bus_.requested = p.requested;
  on_bus_.start = at;
  on_bus_.end = time_of(bit + bits);
  on_bus_.error = error;
  count_bits(bit, bits);
  if (error != Error::None) {
    ++error_frames_;
    if (on_start_) on_start_(on_bus_);
    return;
  }
  winner->queue.pop_front();  // p is on_bus_ from here
  --pending_;
  ++frames_;

  ids_.count(winner->last, known ? known : ids_.add(best), at, on_bus_.requested);
  if (on_start_) on_start_(on_bus_);
}

void TimedBus::finish() {
  // The frame stays in on_bus_ until the next start of frame, which only run() makes: the hooks
  // below read it there (no copy).
  const OnBus& done = on_bus_;
  busy_ = false;
  free_bit_ = done.end_bit;
  // A frame without error on a bus whose nodes are all error active with both counters at 0 and
  // none at a wrong bit rate changes no counter and no state (docs/can-bus.md "Performance").
  if (done.error != Error::None || !calm_) confine(done.node, done);
  // The frame's last 11 bits (ACK delimiter, end of frame, intermission; or error delimiter and
  // intermission) are recessive: a bus-off node's run starts there.
  if (bus_off_nodes_ > 0)
    for (Node& n : nodes_)
      if (n.conf.state == BusState::BusOff) n.run_from = done.end_bit - kRecessiveRun;
  if (on_end_) on_end_(done);
}

// Second k of bus time holds bits [k·bitrate, (k+1)·bitrate): a frame across the boundary counts
// in both, each its own bits.
void TimedBus::count_seconds(std::uint64_t from, std::uint64_t bits) {
  while (bits > 0) {
    const std::uint64_t w = from / bitrate_;
    if (w > window_) {
      const double pct = 100.0 * static_cast<double>(window_bits_) / bitrate_;
      max_pct_ = std::max(max_pct_, pct);
      last_pct_ = w == window_ + 1 ? pct : 0.0;
      window_ = w;
      window_bits_ = 0;
    }
    const std::uint64_t take = std::min(bits, (w + 1) * bitrate_ - from);
    window_bits_ += take;
    from += take;
    bits -= take;
  }
}

TimedBus::Load TimedBus::load(Time now) const {
  // A frame's bits count at its start of frame. With frames queued, a bus not yet advanced to
  // `now` (candp2d's steps, docs/can-bus.md "In the plant") knows its seconds up to its next
  // deadline only: a second that ends later is still being counted. Without frames queued nothing
  // starts before the next request, which comes at `now` or later.
  if (pending_ > 0)
    if (const auto d = next_deadline(); d && *d < now) now = *d;
  const std::uint64_t w =
      now <= origin_ ? 0 : static_cast<std::uint64_t>((now - origin_).count()) / kMicrosPerSecond;
  if (w <= window_) return {last_pct_, max_pct_};
  // The second being counted is complete: it is the last one (or an idle second came after it).
  const double pct = 100.0 * static_cast<double>(window_bits_) / bitrate_;
  return {w == window_ + 1 ? pct : 0.0, std::max(max_pct_, pct)};
}

}  // namespace candp2::can

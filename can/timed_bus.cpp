#include "can/timed_bus.hpp"

#include <algorithm>

#include "can/frame_bits.hpp"
#include "common/line_physics.hpp"

namespace candp2::can {

namespace {
constexpr std::uint64_t kMicrosPerSecond = 1'000'000;
}  // namespace

Duration TimedBus::IdStatistics::period_mean() const {
  return frames > 1 ? period_sum / static_cast<std::int64_t>(frames - 1) : Duration(0);
}

Duration TimedBus::IdStatistics::latency_mean() const {
  return frames ? latency_sum / static_cast<std::int64_t>(frames) : Duration(0);
}

TimedBus::TimedBus(std::uint32_t bitrate, Time origin) : bitrate_(bitrate), origin_(origin) {}

// Split so that neither product overflows: whole seconds, then the rest of one.
// Bits and microseconds rounded up both ways, as the line in time (common/line_physics.hpp).
Time TimedBus::time_of(std::uint64_t bit) const {
  return origin_ + phy::bits_to_time(bitrate_, bit);
}

std::uint64_t TimedBus::bit_at(Time t) const {
  return t <= origin_ ? 0 : phy::time_to_bits(bitrate_, t - origin_);
}

std::size_t TimedBus::add_node(std::size_t depth) {
  nodes_.push_back(Node{depth, true, {}});
  return nodes_.size() - 1;
}

void TimedBus::remove_node(std::size_t node) {
  Node& n = nodes_.at(node);
  pending_ -= n.queue.size();
  n.queue.clear();
  n.present = false;
}

bool TimedBus::request(std::size_t node, const Frame& frame, Time now) {
  Node& n = nodes_.at(node);
  if (!n.present || n.queue.size() >= n.depth) {
    ++lost_;
    return false;
  }
  n.queue.push_back(Pending{frame, now});
  ++pending_;
  return true;
}

std::optional<std::uint64_t> TimedBus::next_start() const {
  if (pending_ == 0) return std::nullopt;
  std::optional<Time> first;
  for (const Node& n : nodes_)
    if (!n.queue.empty() && (!first || n.queue.front().requested < *first))
      first = n.queue.front().requested;
  return std::max(free_bit_, bit_at(*first));
}

std::optional<Time> TimedBus::next_deadline() const {
  if (on_bus_) return on_bus_->end;
  if (const auto s = next_start()) return time_of(*s);
  return std::nullopt;
}

void TimedBus::advance(Time now) {
  while (true) {
    if (on_bus_) {
      if (on_bus_->end > now) return;
      finish();
      continue;
    }
    const auto s = next_start();
    if (!s || time_of(*s) > now) return;
    start(*s);
  }
}

// ISO 11898-1 bitwise arbitration: of the frames ready when the bus goes idle (each node's head of
// queue), the smallest arbitration field wins; the others wait for the next idle.
void TimedBus::start(std::uint64_t bit) {
  const Time at = time_of(bit);
  Node* winner = nullptr;
  std::size_t index = 0;
  std::uint32_t best = 0;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    Node& n = nodes_[i];
    if (n.queue.empty() || n.queue.front().requested > at) continue;
    const std::uint32_t key = arbitration_key(n.queue.front().frame);
    if (!winner || key < best) {
      winner = &n;
      index = i;
      best = key;
    }
  }
  const Pending p = winner->queue.front();
  winner->queue.pop_front();
  --pending_;
  const std::uint32_t bits = frame_bits_exact(p.frame);
  on_bus_ = OnBus{index, p.frame, bit, bit + bits, p.requested, at, time_of(bit + bits)};
  ++frames_;
  count_bits(bit, bits);

  IdStatistics& s = ids_[best];
  s.id = ident_of(p.frame);
  s.remote = p.frame.remote;
  if (s.frames > 0) {
    const Duration period = at - s.last_start;
    s.period_last = period;
    s.period_min = s.frames == 1 ? period : std::min(s.period_min, period);
    s.period_max = std::max(s.period_max, period);
    s.period_sum += period;
  }
  const Duration latency = at - p.requested;
  s.latency_last = latency;
  s.latency_max = std::max(s.latency_max, latency);
  s.latency_sum += latency;
  s.last_start = at;
  ++s.frames;
  if (on_start_) on_start_(*on_bus_);
}

void TimedBus::finish() {
  const OnBus done = *on_bus_;
  on_bus_.reset();
  free_bit_ = done.end_bit;
  if (on_end_) on_end_(done);
}

// Second k of bus time holds bits [k·bitrate, (k+1)·bitrate): a frame across the boundary counts
// in both, each its own bits.
void TimedBus::count_bits(std::uint64_t from, std::uint64_t bits) {
  busy_bits_ += bits;
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
  const std::uint64_t w =
      now <= origin_ ? 0 : static_cast<std::uint64_t>((now - origin_).count()) / kMicrosPerSecond;
  if (w <= window_) return {last_pct_, max_pct_};
  // The second being counted is complete: it is the last one (or an idle second came after it).
  const double pct = 100.0 * static_cast<double>(window_bits_) / bitrate_;
  return {w == window_ + 1 ? pct : 0.0, std::max(max_pct_, pct)};
}

}  // namespace candp2::can

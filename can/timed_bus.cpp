#include "can/timed_bus.hpp"

#include <algorithm>

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
// Bosch CAN 2.0 part B §8 / ISO 11898-1 fault confinement.
constexpr std::uint32_t kTecOnError = 8;
constexpr std::uint32_t kWarningLimit = 96;
constexpr std::uint32_t kPassiveLimit = 128;
constexpr std::uint32_t kBusOffLimit = 255;      // bus-off when TEC exceeds it
constexpr std::uint32_t kRecAfterPassive = 127;  // REC > 127 on success: back to 119..127
constexpr std::uint32_t kSuspendBits = 8;        // an error-passive transmitter's suspend
constexpr std::uint32_t kRecessiveRun = 11;      // bus-off recovery: 128 runs of 11 bits
constexpr std::uint32_t kRecoveryRuns = 128;
// An arbitration key's first slot in an index of `size` (a power of two) slots: Fibonacci hashing
// (the identifiers of one bus are often consecutive).
std::size_t slot_of(std::uint32_t key, std::size_t size) {
  return static_cast<std::size_t>((std::uint64_t{key} * 0x9E3779B97F4A7C15ull) >> 32) & (size - 1);
}
}  // namespace

Duration TimedBus::IdStatistics::period_mean() const {
  return frames > 1 ? period_sum / static_cast<std::int64_t>(frames - 1) : Duration(0);
}

Duration TimedBus::IdStatistics::latency_mean() const {
  return frames ? latency_sum / static_cast<std::int64_t>(frames) : Duration(0);
}

TimedBus::TimedBus(std::uint32_t bitrate, Time origin)
    : bitrate_(bitrate),
      us_per_bit_(bitrate != 0 && kMicrosPerSecond % bitrate == 0 ? kMicrosPerSecond / bitrate : 0),
      origin_(origin) {}

void TimedBus::recount() {
  calm_ = std::all_of(nodes_.begin(), nodes_.end(), [](const Node& n) {
    return (n.conf.tec | n.conf.rec) == 0 && !n.wrong_bitrate && n.conf.state == BusState::Ok;
  });
  acknowledgers_ = 0;
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (receives(nodes_[i]) && nodes_[i].acknowledges) {
      ++acknowledgers_;
      acknowledger_ = i;
    }
}

// Split so that neither product overflows: whole seconds, then the rest of one.
// Bits and microseconds rounded up both ways, as the line in time (common/line_physics.hpp).
Time TimedBus::time_of_rounded(std::uint64_t bit) const {
  return origin_ + phy::bits_to_time(bitrate_, bit);
}

std::uint64_t TimedBus::bit_at(Time t) const {
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
  Node& n = nodes_.at(node);
  if (n.present && n.conf.state == BusState::BusOff) return false;
  if (!n.present || n.queue.size() >= n.depth) {
    ++lost_;
    return false;
  }
  n.queue.push_back(
      Pending{frame, now, bit_at(now), arbitration_key(frame), frame_bits_exact(frame)});
  ++pending_;
  // While a frame is on the bus the deadline is its end, whatever is queued: nothing moved.
  if (!busy_) moved();
  return true;
}

bool TimedBus::contends(const Node& n, std::uint64_t bit, Time at) const {
  return !n.queue.empty() && !n.unplugged && n.conf.state != BusState::BusOff &&
         n.suspend_until <= bit && n.queue.front_requested() <= at;
}

std::uint64_t TimedBus::next_start() const {
  if (pending_ == 0) return kNoBit;
  std::uint64_t first = kNoBit;
  for (const Node& n : nodes_) {
    if (n.queue.empty() || n.unplugged || n.conf.state == BusState::BusOff) continue;
    first = std::min(first, std::max({free_bit_, n.queue.front_bit(), n.suspend_until}));
  }
  return first;
}

std::uint64_t TimedBus::next_recovery() const {
  if (busy_ || bus_off_nodes_ == 0) return kNoBit;
  std::uint64_t first = kNoBit;
  for (const Node& n : nodes_) {
    if (!n.present || n.conf.state != BusState::BusOff || !n.run_from) continue;
    first = std::min(first, *n.run_from + (kRecoveryRuns - n.recessive_runs) * kRecessiveRun);
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
  const std::uint64_t s = next_start(), r = next_recovery();
  if (r != kNoBit && r <= s) return time_of(r);
  if (s != kNoBit) return time_of(s);
  return std::nullopt;
}

void TimedBus::advance(Time now) {
  // Nothing due by now: the bus stays as it is (the loop below would return at once).
  if (const auto d = next_deadline(); !d || *d > now) return;
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
    const std::uint64_t s = next_start(), r = next_recovery();
    if (r != kNoBit && r <= s) {
      if (time_of(r) > now) return;
      recover(r);
      continue;
    }
    if (s == kNoBit || time_of(s) > now) return;
    start(s);
  }
}

// Bosch CAN 2.0 part B §8 rule 12: after 128 occurrences of 11 consecutive recessive bits a
// bus-off node is error active again with both counters 0.
void TimedBus::recover(std::uint64_t bit) {
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    Node& n = nodes_[i];
    if (n.conf.state != BusState::BusOff || !n.run_from ||
        *n.run_from + (kRecoveryRuns - n.recessive_runs) * kRecessiveRun > bit)
      continue;
    n.conf.tec = n.conf.rec = 0;
    n.recessive_runs = 0;
    n.run_from.reset();
    n.suspend_until = 0;
    n.conf.state = BusState::Ok;
    --bus_off_nodes_;
    recount();
    if (on_state_) on_state_(i, n.conf.state);
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
    // A bus-off node counts the recessive run this start of frame ends.
    if (n.conf.state == BusState::BusOff && n.run_from) {
      n.recessive_runs += static_cast<std::uint32_t>((bit - *n.run_from) / kRecessiveRun);
      n.run_from.reset();
    }
    if (!contends(n, bit, at)) continue;
    const std::uint32_t key = n.queue.front_key();
    if (!winner || key < best) {
      winner = &n;
      index = i;
      best = key;
    }
  }
  const Pending& p = winner->queue.front();
  // The identifier's statistics are fetched while the frame's error is looked for (a cache miss
  // at every frame otherwise: docs/can-bus.md "Performance"); only a frame without error makes a
  // new entry.
  IdStatistics* known = find_statistics(best);
  if (known) {
    __builtin_prefetch(known, 1);
    __builtin_prefetch(reinterpret_cast<const char*>(known + 1) - 1, 1);
  }
  // Without faults on cue or a wrong bit rate only the ACK can fail (error_of()'s walk skipped).
  const Error error = !faults_.empty() || winner->wrong_bitrate ? error_of(index, p.frame, at)
                      : !check_ack_ || acknowledged(index)      ? Error::None
                                                                : Error::Ack;
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
  if (bit + bits <= (window_ + 1) * bitrate_) {  // within the second being counted
    busy_bits_ += bits;
    window_bits_ += bits;
  } else {
    count_bits(bit, bits);
  }
  if (error != Error::None) {
    ++error_frames_;
    if (on_start_) on_start_(on_bus_);
    return;
  }
  winner->queue.pop_front();  // p is on_bus_ from here
  --pending_;
  ++frames_;

  IdStatistics& s = known ? *known : id_statistics(best);
  s.id = ident_of(on_bus_.frame);
  s.remote = on_bus_.frame.remote;
  if (s.frames > 0) {
    const Duration period = at - s.last_start;
    s.period_last = period;
    s.period_min = s.frames == 1 ? period : std::min(s.period_min, period);
    s.period_max = std::max(s.period_max, period);
    s.period_sum += period;
  }
  const Duration latency = at - on_bus_.requested;
  s.latency_last = latency;
  s.latency_max = std::max(s.latency_max, latency);
  s.latency_sum += latency;
  s.last_start = at;
  ++s.frames;
  if (on_start_) on_start_(on_bus_);
}

std::size_t TimedBus::id_slot(std::uint32_t key) const {
  std::size_t i = slot_of(key, id_index_.size());
  while (id_index_[i].index && id_index_[i].key != key) i = (i + 1) & (id_index_.size() - 1);
  return i;
}

TimedBus::IdStatistics* TimedBus::find_statistics(std::uint32_t key) {
  if (id_index_.empty()) return nullptr;
  const IdSlot& e = id_index_[id_slot(key)];
  return e.index ? &id_stats_[e.index - 1] : nullptr;
}

TimedBus::IdStatistics& TimedBus::id_statistics(std::uint32_t key) {
  if (2 * (id_stats_.size() + 1) > id_index_.size()) {  // grow: at most half full
    std::vector<IdSlot> old(std::max<std::size_t>(64, 2 * id_index_.size()));
    old.swap(id_index_);
    for (const IdSlot& e : old)
      if (e.index) id_index_[id_slot(e.key)] = e;
  }
  IdSlot& e = id_index_[id_slot(key)];
  if (!e.index) {
    id_stats_.emplace_back();
    e = IdSlot{key, static_cast<std::uint32_t>(id_stats_.size())};
  }
  return id_stats_[e.index - 1];
}

std::map<std::uint32_t, TimedBus::IdStatistics> TimedBus::identifiers() const {
  std::map<std::uint32_t, IdStatistics> out;
  for (const IdSlot& e : id_index_)
    if (e.index) out.emplace(e.key, id_stats_[e.index - 1]);
  return out;
}

TimedBus::Error TimedBus::error_of(std::size_t node, const Frame& frame, Time at) {
  Error error = Error::None;
  // Every fault that matches the frame counts it; expired ones go.
  for (auto it = faults_.begin(); it != faults_.end();) {
    ErrorFault& f = *it;
    if (f.until && at >= *f.until) {
      it = faults_.erase(it);
      continue;
    }
    const bool match = f.node ? *f.node == node : (!f.id || *f.id == ident_of(frame));
    if (match && f.matched++ % std::max<std::uint32_t>(f.every, 1) == 0) {
      error = Error::Injected;
      if (!f.until && --f.count == 0) {
        it = faults_.erase(it);
        continue;
      }
    }
    ++it;
  }
  if (nodes_[node].wrong_bitrate) return Error::WrongBitrate;
  if (error != Error::None || !check_ack_) return error;
  return acknowledged(node) ? Error::None : Error::Ack;
}

void TimedBus::finish() {
  // The frame stays in on_bus_ until the next start of frame, which only run() makes: the hooks
  // below read it there (no copy).
  const OnBus& done = on_bus_;
  busy_ = false;
  free_bit_ = done.end_bit;
  // A frame without error on a calm bus changes no counter (confine()'s fast path, without the
  // call).
  if (done.error != Error::None || !calm_) confine(done.node, done);
  // The frame's last 11 bits (ACK delimiter, end of frame, intermission; or error delimiter and
  // intermission) are recessive: a bus-off node's run starts there.
  if (bus_off_nodes_ > 0)
    for (Node& n : nodes_)
      if (n.conf.state == BusState::BusOff) n.run_from = done.end_bit - kRecessiveRun;
  if (on_end_) on_end_(done);
}

// Bosch CAN 2.0 part B §8 (ISO 11898-1 fault confinement), the rules this model uses:
// a transmitter's error TEC += 8 (rule 3), except an error-passive transmitter's ACK error
// (exception 1 of rule 3); a receiver's error REC += 1 (rule 1); a frame sent without error
// TEC −1 (rule 7); received without error REC −1, or from above 127 back to 127 (rule 8).
void TimedBus::confine(std::size_t tx, const OnBus& f) {
  Node& t = nodes_[tx];
  const bool error = f.error != Error::None;
  if (!t.present) return;
  // A frame without error on a bus whose nodes are all error active with both counters at 0 and
  // none at a wrong bit rate changes no counter and no state (docs/can-bus.md "Performance").
  if (!error && calm_) return;
  if (error) {
    ++t.conf.error_frames_sent;
    if (!(f.error == Error::Ack && t.conf.state == BusState::ErrorPassive))
      t.conf.tec += kTecOnError;
  } else if (t.conf.tec > 0) {
    --t.conf.tec;
  }
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    Node& n = nodes_[i];
    if (i == tx || !n.present || n.unplugged || n.conf.state == BusState::BusOff) continue;
    if (error || n.wrong_bitrate) {
      ++n.conf.rec;
      ++n.conf.error_frames_seen;
    } else if (n.conf.rec > kRecAfterPassive) {
      n.conf.rec = kRecAfterPassive;
    } else if (n.conf.rec > 0) {
      --n.conf.rec;
    }
    set_state(i);
  }
  set_state(tx);
  recount();  // the counters changed
  if (t.conf.state == BusState::BusOff) {
    // A bus-off controller's transmit buffer is emptied (docs/faults.md "CAN controller state").
    t.conf.discarded += t.queue.size();
    pending_ -= t.queue.size();
    t.queue.clear();
  } else if (t.conf.state == BusState::ErrorPassive) {
    t.suspend_until = f.end_bit + kSuspendBits;
  }
}

// Bosch CAN 2.0 part B §8: error warning at 96 (the controllers' status flag), error passive at
// 128, bus-off when TEC exceeds 255; bus-off lasts until its recovery (recover()).
void TimedBus::set_state(std::size_t node) {
  Node& n = nodes_[node];
  if (n.conf.state == BusState::BusOff) return;
  const std::uint32_t worst = std::max(n.conf.tec, n.conf.rec);
  const BusState s = n.conf.tec > kBusOffLimit ? BusState::BusOff
                     : worst >= kPassiveLimit  ? BusState::ErrorPassive
                     : worst >= kWarningLimit  ? BusState::Warning
                                               : BusState::Ok;
  if (s == n.conf.state) return;
  n.conf.state = s;
  recount();
  if (s == BusState::BusOff) {
    ++bus_off_nodes_;
    ++n.conf.bus_off;
    n.recessive_runs = 0;
  }
  if (on_state_) on_state_(node, s);
}

void TimedBus::clear_faults(std::optional<std::size_t> node) {
  std::erase_if(faults_, [&](const ErrorFault& f) { return !node || f.node == node; });
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    if (node && i != *node) continue;
    nodes_[i].unplugged = false;
    nodes_[i].wrong_bitrate = false;
  }
  recount();
  moved();
}

// Second k of bus time holds bits [k·bitrate, (k+1)·bitrate): a frame across the boundary counts
// in both, each its own bits.
void TimedBus::count_bits(std::uint64_t from, std::uint64_t bits) {
  busy_bits_ += bits;
  if (from + bits <= (window_ + 1) * bitrate_) {  // within the second being counted
    window_bits_ += bits;
    return;
  }
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

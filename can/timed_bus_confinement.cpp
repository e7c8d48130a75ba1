// The CAN bus in time's error confinement (docs/can-bus.md "Error confinement"; ISO 11898-1 /
// Bosch CAN 2.0 part B §8): errors on cue, the nodes' error counters and states, bus-off and its
// recovery. The frames' way over the bus is can/timed_bus.cpp.
#include <algorithm>

#include "can/timed_bus.hpp"  // its class; the frames' way over the bus: can/timed_bus.cpp

namespace candp2::can {

namespace {
// Bosch CAN 2.0 part B §8 / ISO 11898-1 fault confinement.
constexpr std::uint32_t kTecOnError = 8;
constexpr std::uint32_t kWarningLimit = 96;
constexpr std::uint32_t kPassiveLimit = 128;
constexpr std::uint32_t kBusOffLimit = 255;      // bus-off when TEC exceeds it
constexpr std::uint32_t kRecAfterPassive = 127;  // REC > 127 on success: back to 119..127
constexpr std::uint32_t kSuspendBits = 8;        // an error-passive transmitter's suspend
}  // namespace

void TimedBus::recount() {
  calm_ = std::all_of(nodes_.begin(), nodes_.end(), [](const Node& n) {
    return (n.conf.tec | n.conf.rec) == 0 && !n.wrong_bitrate && n.conf.state == BusState::Ok;
  });
  acknowledgers_ = 0;
  all_receive_ = true;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Node& n = nodes_[i];
    if (!receives(n)) {
      if (n.present) all_receive_ = false;
    } else if (n.acknowledges) {
      ++acknowledgers_;
      acknowledger_ = i;
    }
  }
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

bool TimedBus::count_faults(std::size_t node, const Frame& frame, Time at) {
  bool error = false;
  for (auto it = faults_.begin(); it != faults_.end();) {
    ErrorFault& f = *it;
    if (f.until && at >= *f.until) {
      it = faults_.erase(it);
      continue;
    }
    const bool match = f.node ? *f.node == node : (!f.id || *f.id == ident_of(frame));
    if (match && f.matched++ % std::max<std::uint32_t>(f.every, 1) == 0) {
      error = true;
      if (!f.until && --f.count == 0) {
        it = faults_.erase(it);
        continue;
      }
    }
    ++it;
  }
  return error;
}

// Bosch CAN 2.0 part B §8 (ISO 11898-1 fault confinement), the rules this model uses:
// a transmitter's error TEC += 8 (rule 3), except an error-passive transmitter's ACK error
// (exception 1 of rule 3); a receiver's error REC += 1 (rule 1); a frame sent without error
// TEC −1 (rule 7); received without error REC −1, or from above 127 back to 127 (rule 8).
void TimedBus::confine(std::size_t tx, const OnBus& f) {
  Node& t = nodes_[tx];
  const bool error = f.error != Error::None;
  if (!t.present) return;
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

}  // namespace candp2::can

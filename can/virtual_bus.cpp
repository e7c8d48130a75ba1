#include "can/virtual_bus.hpp"

#include <algorithm>
#include <cstdlib>

namespace candp2::can {

VirtualEndpoint::VirtualEndpoint(VirtualBus* bus, std::string name, bool receive_own,
                                 std::size_t limit)
    : bus_(bus),
      name_(std::move(name)),
      receive_own_(receive_own),
      limit_(std::max<std::size_t>(limit, 1)) {}

VirtualEndpoint::~VirtualEndpoint() {
  if (bus_) bus_->detach(this);
}

// On a bus in time: the worse of the forced state and the node's error confinement
// (docs/can-bus.md "Error confinement").
BusState VirtualEndpoint::bus_state() const {
  if (!bus_) return BusState::BusOff;
  const BusState forced = state_override_ ? *state_override_ : bus_->bus_state();
#ifndef NDEBUG  // the copy holds what the engine says (Debug builds, the sanitizer run)
  if (bus_->timed_ && confined_ != bus_->timed_->confinement(node_).state) std::abort();
#endif
  return bus_->timed_ ? std::max(forced, confined_) : forced;
}

const TimedBus::Confinement* VirtualEndpoint::confinement() const {
  if (!bus_ || !bus_->timed_) return nullptr;
  return &bus_->timed_->confinement(node_);
}

void VirtualEndpoint::set_unplugged(bool on) {
  if (!bus_ || !bus_->timed_) return;
  bus_->timed_->set_unplugged(node_, on);
  bus_->changed();
}

void VirtualEndpoint::set_wrong_bitrate(bool on) {
  wrong_bitrate_cue_ = on;
  apply_wrong_bitrate();
}

void VirtualEndpoint::set_own_bitrate(std::optional<std::uint32_t> bitrate) {
  const bool wrong = bus_ && bus_->timed_ && bitrate && *bitrate != bus_->timed_->bitrate();
  if (wrong == wrong_bitrate_own_) return;
  wrong_bitrate_own_ = wrong;
  apply_wrong_bitrate();
}

void VirtualEndpoint::apply_wrong_bitrate() {
  if (!bus_ || !bus_->timed_) return;
  bus_->timed_->set_wrong_bitrate(node_, wrong_bitrate_cue_ || wrong_bitrate_own_);
  bus_->changed();
}

void VirtualEndpoint::clear_faults() {
  if (!bus_ || !bus_->timed_) return;
  bus_->timed_->clear_faults(node_);
  wrong_bitrate_cue_ = false;
  apply_wrong_bitrate();
}

void VirtualEndpoint::set_acknowledges(bool on) {
  acknowledges_ = on;
  if (bus_ && bus_->timed_) bus_->timed_->set_acknowledges(node_, on);
}

void VirtualEndpoint::send(const Frame& frame) {
  if (!bus_ || bus_state() == BusState::BusOff) {
    ++tx_dropped_;
    return;
  }
  bus_->transmit(this, frame);
}

std::optional<Frame> VirtualEndpoint::receive() {
  if (queue_.empty()) return std::nullopt;
  Frame f = queue_.front();
  queue_.pop_front();
  return f;
}

void VirtualEndpoint::deliver(const Frame& frame) {
  if (bus_state() == BusState::BusOff) return;  // a bus-off controller takes no part in traffic
  if (queue_.size() >= limit_) {
    ++rx_lost_;
    return;
  }
  queue_.push_back(frame);
}

VirtualBus::VirtualBus(Options options) : options_(options) {}

VirtualBus::~VirtualBus() {
  for (auto* ep : endpoints_) ep->bus_ = nullptr;
}

std::unique_ptr<VirtualEndpoint> VirtualBus::endpoint(std::string name, bool receive_own) {
  std::unique_ptr<VirtualEndpoint> ep(
      new VirtualEndpoint(this, std::move(name), receive_own, options_.rx_queue_limit));
  endpoints_.push_back(ep.get());
  if (timed_) attach_timed(ep.get());
  return ep;
}

void VirtualBus::set_bitrate(std::uint32_t bitrate, Time origin) {
  timed_ = std::make_unique<TimedBus>(bitrate, origin);
  timed_->on_start([this](const TimedBus::OnBus& f) { started(f); });
  timed_->on_end([this](const TimedBus::OnBus& f) { ended(f); });
  // docs/can-bus.md "Error confinement": a frame nobody else acknowledges is an ACK error.
  timed_->check_acknowledgement(true);
  timed_->on_state([this](std::size_t node, BusState s) {
    if (nodes_[node]) nodes_[node]->confined_ = s;
    changed();
    state_changed(node, s);
  });
  for (auto* ep : endpoints_) attach_timed(ep);
}

void VirtualBus::attach_timed(VirtualEndpoint* ep) {
  ep->node_ = timed_->add_node(ep->tx_queue_.depth);
  timed_->set_acknowledges(ep->node_, ep->acknowledges_);
  timed_->set_name(ep->node_, ep->name_);
  nodes_.push_back(ep);
}

void VirtualEndpoint::set_tx_queue(TxQueue q) {
  tx_queue_ = q;
  if (bus_ && bus_->timed_) bus_->timed_->set_depth(node_, q.depth);
}

// The frame won arbitration: it is on the bus from its start of frame (the taps' time stamp). A
// frame that ends in an error frame is nobody's frame: the taps see it when it gets through.
void VirtualBus::started(const TimedBus::OnBus& f) {
  in_frame_ = true;
  frame_end_ = f.end;
  if (f.error != TimedBus::Error::None) return started_in_error(f);
  ++frames_sent_;
  const VirtualEndpoint* from = nodes_[f.node];
  const std::string_view sender = from ? std::string_view(from->name()) : std::string_view();
  for (const auto& tap : taps_) tap(f.frame, f.start, sender);
}

void VirtualBus::started_in_error(const TimedBus::OnBus& f) {
  if (!error_tap_) return;
  const auto& c = timed_->confinement(f.node);
  const VirtualEndpoint* from = nodes_[f.node];
  error_tap_(BusError{.time = timed_->time_of(TimedBus::error_flag_bit(f)),
                      .error = f.error,
                      .tec = c.tec,
                      .rec = c.rec,
                      .node = from ? std::string_view(from->name()) : std::string_view()});
}

// Its last bit has passed: every other node that takes part in traffic has it (not one unplugged,
// at a wrong bit rate or bus-off); a frame in error nobody has.
void VirtualBus::ended(const TimedBus::OnBus& f) {
  in_frame_ = false;
  ended_ = true;  // changed() once when advance() returns
  if (f.error != TimedBus::Error::None) return;
  deliver_all(nodes_[f.node], f.frame);
}

// docs/capture.md "Error frames": after a frame, at its end; else a bus-off recovery, now (the
// plant advances the bus at its deadline).
void VirtualBus::state_changed(std::size_t node, BusState s) {
  if (!error_tap_) return;
  const auto& c = timed_->confinement(node);
  const VirtualEndpoint* ep = nodes_[node];
  error_tap_(BusError{.time = in_frame_ ? frame_end_ : now(),
                      .state = s,
                      .recovered = !in_frame_ && s == BusState::Ok,
                      .tec = c.tec,
                      .rec = c.rec,
                      .node = ep ? std::string_view(ep->name()) : std::string_view()});
}

bool VirtualBus::inject_errors(const TimedBus::ErrorFault& fault) {
  if (!timed_) return false;
  timed_->inject_errors(fault);
  changed();
  return true;
}

void VirtualBus::clear_faults() {
  if (!timed_) return;
  timed_->clear_faults(std::nullopt);
  for (auto* ep : endpoints_) {
    ep->wrong_bitrate_cue_ = false;
    ep->apply_wrong_bitrate();
  }
  changed();
}

void VirtualEndpoint::inject_rx_lost(std::uint32_t n) {
  rx_lost_ += n;
  if (bus_) bus_->changed();
}

void VirtualEndpoint::set_bus_state_override(std::optional<BusState> s) {
  state_override_ = s;
  if (bus_) bus_->changed();
}

void VirtualBus::transmit(VirtualEndpoint* from, const Frame& frame) {
  if (timed_) {
    if (!timed_->request(from->node_, frame, now())) {
      // docs/can-bus.md "Transmit queues": lost where the device counts it.
      ++(from->tx_queue_.loss_is_irq_lost ? from->rx_lost_ : from->tx_dropped_);
      changed();
    }
    return;
  }
  ++frames_sent_;
  changed();
  for (const auto& tap : taps_) tap(frame, now(), from->name());
  deliver_all(from, frame);
}

void VirtualBus::deliver_all(VirtualEndpoint* from, const Frame& frame) {
  // Iterate by index: a receiver never adds endpoints during delivery, but keep it robust.
  for (std::size_t i = 0; i < endpoints_.size(); ++i) {
    VirtualEndpoint* ep = endpoints_[i];
    if (ep == from && !ep->receive_own_) continue;
    if (timed_ && ep != from && !timed_->all_receive() && !timed_->receives(ep->node_)) continue;
    ep->deliver(frame);
  }
}

void VirtualBus::detach(VirtualEndpoint* ep) {
  if (timed_) {
    timed_->remove_node(ep->node_);
    nodes_[ep->node_] = nullptr;
  }
  endpoints_.erase(std::remove(endpoints_.begin(), endpoints_.end(), ep), endpoints_.end());
}

}  // namespace candp2::can

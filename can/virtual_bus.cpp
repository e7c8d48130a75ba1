#include "can/virtual_bus.hpp"

#include <algorithm>

namespace candp2::can {

VirtualEndpoint::VirtualEndpoint(VirtualBus* bus, std::string name, bool receive_own,
                                 std::size_t limit)
    : bus_(bus), name_(std::move(name)), receive_own_(receive_own), limit_(limit) {}

VirtualEndpoint::~VirtualEndpoint() {
  if (bus_) bus_->detach(this);
}

BusState VirtualEndpoint::bus_state() const {
  if (state_override_) return *state_override_;
  return bus_ ? bus_->bus_state() : BusState::BusOff;
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
  for (auto* ep : endpoints_) attach_timed(ep);
}

void VirtualBus::attach_timed(VirtualEndpoint* ep) {
  ep->node_ = timed_->add_node(ep->tx_queue_.depth);
  nodes_.push_back(ep);
}

void VirtualEndpoint::set_tx_queue(TxQueue q) {
  tx_queue_ = q;
  if (bus_ && bus_->timed_) bus_->timed_->set_depth(node_, q.depth);
}

// The frame won arbitration: it is on the bus from its start of frame (the taps' time stamp).
void VirtualBus::started(const TimedBus::OnBus& f) {
  ++frames_sent_;
  const VirtualEndpoint* from = nodes_[f.node];
  const std::string_view sender = from ? std::string_view(from->name()) : std::string_view();
  for (const auto& tap : taps_) tap(f.frame, f.start, sender);
}

// Its last bit has passed: every other node has it.
void VirtualBus::ended(const TimedBus::OnBus& f) {
  changed();
  deliver_all(nodes_[f.node], f.frame);
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

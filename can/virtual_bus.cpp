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
  return ep;
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
  ++frames_sent_;
  changed();
  for (const auto& tap : taps_) tap(frame, now(), from->name());
  // Iterate by index: a receiver never adds endpoints during delivery, but keep it robust.
  for (std::size_t i = 0; i < endpoints_.size(); ++i) {
    VirtualEndpoint* ep = endpoints_[i];
    if (ep == from && !ep->receive_own_) continue;
    ep->deliver(frame);
  }
}

void VirtualBus::detach(VirtualEndpoint* ep) {
  endpoints_.erase(std::remove(endpoints_.begin(), endpoints_.end(), ep), endpoints_.end());
}

}  // namespace candp2::can

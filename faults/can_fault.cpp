#include "faults/can_fault.hpp"

namespace candp2::faults {

bool CanFaultLayer::force(std::uint16_t code) {
  if (code > kForceMax) return false;
  if (code == kForceReal)
    forced_.reset();
  else
    forced_ = static_cast<can::BusState>(code);  // 1 Warning, 2 ErrorPassive, 3 BusOff
  return true;
}

std::uint16_t CanFaultLayer::forced_code() const {
  return forced_ ? static_cast<std::uint16_t>(*forced_) : kForceReal;
}

bool CanFaultLayer::pass_tx() {
  if (forced_ == can::BusState::BusOff) {
    ++tx_suppressed_;
    return false;
  }
  return true;
}

bool CanFaultLayer::pass_rx() {
  if (forced_ == can::BusState::BusOff) {
    ++rx_suppressed_;
    return false;
  }
  if (drop_remaining_ > 0) {
    --drop_remaining_;
    ++rx_dropped_;
    return false;
  }
  return true;
}

}  // namespace candp2::faults

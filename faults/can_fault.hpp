// Fault injection between a gateway and its CAN channel (docs/faults.md).
//
// The gateway engine never learns that a fault is injected: it sees the forced controller state
// instead of the channel's real one (diagnosis byte 8, Ext_Diag, status block, LED C follow from
// that, manual §3.3 table 3.3.1 and §3.4.2 table 3.4.5), frames it sends in a forced bus-off are
// dropped here, and received frames are dropped here in a forced bus-off or while a drop budget
// (Modbus holding register 8194) lasts. Budget drops count in IRQ_LOST (diagnosis byte 9), which
// the manual defines as frames the CAN controller lost (manual §3.4.2, table 3.4.5).
// Pure: no sockets, clock or globals; the daemon holds one per gateway.
#pragma once

#include <cstdint>
#include <optional>

#include "can/channel.hpp"

namespace candp2::faults {

// Holding register 8193 values (docs/modbus.md): 0 real state, 1 warning, 2 error-passive,
// 3 bus-off.
inline constexpr std::uint16_t kForceReal = 0;
inline constexpr std::uint16_t kForceMax = 3;

class CanFaultLayer {
 public:
  // 0 = the real controller state, 1..3 = BusState::Warning..BusOff. Values above 3 are refused
  // (returns false, nothing changes).
  bool force(std::uint16_t code);
  std::uint16_t forced_code() const;
  std::optional<can::BusState> forced() const { return forced_; }

  // Drop the next n received frames (replaces any remaining budget; 0 cancels it).
  void drop_next(std::uint32_t n) { drop_remaining_ = n; }
  std::uint32_t drop_remaining() const { return drop_remaining_; }

  // The state the gateway sees.
  can::BusState state(can::BusState real) const { return forced_.value_or(real); }
  // The IRQ_LOST total the gateway sees: the channel's losses plus the injected drops.
  std::uint32_t rx_lost(std::uint32_t real_total) const { return real_total + rx_dropped_; }

  // A frame the gateway transmits: true = pass it to the channel. In a forced bus-off the frame is
  // dropped and counted: a bus-off controller takes no part in bus traffic (ISO 11898-1 §12.1.4.2),
  // and nothing is queued for later (after recovery the controller starts with an empty transmit
  // buffer; docs/faults.md).
  bool pass_tx();
  // A frame from the bus: true = give it to the gateway. A forced bus-off receives nothing
  // (counted in rx_suppressed, not in IRQ_LOST: the controller is off the bus, nothing was lost
  // by it); otherwise the drop budget takes the frame first (counted in IRQ_LOST).
  bool pass_rx();

  std::uint32_t tx_suppressed() const { return tx_suppressed_; }
  std::uint32_t rx_suppressed() const { return rx_suppressed_; }
  std::uint32_t rx_dropped() const { return rx_dropped_; }

 private:
  std::optional<can::BusState> forced_;
  std::uint32_t drop_remaining_ = 0;
  std::uint32_t tx_suppressed_ = 0;
  std::uint32_t rx_suppressed_ = 0;
  std::uint32_t rx_dropped_ = 0;
};

}  // namespace candp2::faults

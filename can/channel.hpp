// The one abstract CAN channel. Implementations: the in-process virtual bus endpoint, SocketCAN
// raw sockets, the socketcand client. One contract test suite runs against all of them.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "can/frame.hpp"

namespace candp2::can {

// CAN controller fault confinement states (ISO 11898-1 §12.1.4), as the gateway reports them in
// diagnosis byte 8 (manual §3.4.2: 00 OK, 40 WARN, 80 ERROR_PASSIVE, C0 BUS_OFF).
enum class BusState : std::uint8_t { Ok, Warning, ErrorPassive, BusOff };

std::string_view to_string(BusState s);

// Receives frames a protocol engine wants to transmit. Engines never own a channel.
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual void send(const Frame& frame) = 0;
};

class Channel : public FrameSink {
 public:
  // Transmit. A frame that cannot be sent (bus-off, transmit queue full) is counted in
  // tx_dropped() and logged by the implementation; send never throws for bus conditions.
  void send(const Frame& frame) override = 0;
  // Non-blocking: the next received frame, if any.
  virtual std::optional<Frame> receive() = 0;
  virtual BusState bus_state() const = 0;
  // Frames lost before this reader saw them (receive queue overflow: IRQ_LOST,
  // docs/dp-slave.md "Diagnosis").
  virtual std::uint32_t rx_lost() const = 0;
  virtual std::uint32_t tx_dropped() const = 0;
  // A descriptor that becomes readable when receive() may return a frame; -1 when the channel is
  // in-process and the owner drains it after every event instead.
  virtual int poll_fd() const { return -1; }
  // Connections re-established after the peer went away (socketcand client); 0 otherwise.
  virtual std::uint32_t reconnects() const { return 0; }
  virtual std::string_view name() const = 0;
};

inline std::string_view to_string(BusState s) {
  switch (s) {
    case BusState::Ok:
      return "ok";
    case BusState::Warning:
      return "warning";
    case BusState::ErrorPassive:
      return "error-passive";
    case BusState::BusOff:
      return "bus-off";
  }
  return "?";
}

}  // namespace candp2::can

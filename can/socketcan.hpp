// Linux SocketCAN raw sockets behind can::Channel.
//  - 11/29-bit and remote frames (CAN_EFF_FLAG / CAN_RTR_FLAG);
//  - error frames (CAN_ERR_FLAG, CAN_RAW_ERR_FILTER) turned into bus_state();
//  - SO_RXQ_OVFL drop counts and controller RX-overflow error frames added to rx_lost() (IRQ_LOST);
//  - non-blocking; poll_fd() is an epoll descriptor (the socket and link events). After it
//    becomes readable, call receive() until it returns nullopt (error frames are consumed inside
//    receive() and never returned);
//  - follows its interface going down, coming up, removed and created again (rtnetlink).
//
// The conversions between can::Frame and the kernel's struct can_frame, and the meaning of error
// frames, are pure functions in namespace `socketcan` below, so they are tested on machines whose
// kernel has no CAN support.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "can/channel.hpp"
#include "common/log.hpp"

namespace candp2::can {

struct SocketCanOptions {
  bool receive_own = false;  // CAN_RAW_RECV_OWN_MSGS
  LogSink* log = nullptr;    // bus state changes, drops and socket errors; null discards
  // Open a down interface too (candp2d: an interface as it is after boot, down and perhaps
  // without bit timing). The channel reports bus-off until the interface is up and recovers by
  // itself when it comes up (docs/transports.md "Down interfaces"). Otherwise a down interface is
  // an error.
  bool allow_down = false;
};

// Opens `interface` (e.g. "vcan0"). On failure returns nullptr and sets *error to a message that
// names the interface and the reason ("interface vcan0 does not exist", "... is down", "this kernel
// has no CAN support (socket(AF_CAN) failed: ...)", "... is not a CAN interface").
//
// The channel follows its interface through rtnetlink link events (can/link_events.hpp): down
// (bus-off), up again (error-active, without waiting for a frame), removed (bus-off) and created
// again under the same name (the socket is bound anew). poll_fd() is then an epoll descriptor
// holding the raw socket and the link event socket.
std::unique_ptr<Channel> open_socketcan(const std::string& interface, std::string* error,
                                        SocketCanOptions options = {});

namespace socketcan {

// The fields of <linux/can.h> struct can_frame that classic CAN uses (can_id with flag bits,
// len 0..8, data), without the kernel header so that this header stays portable.
struct RawFrame {
  std::uint32_t can_id = 0;
  std::uint8_t len = 0;
  std::array<std::uint8_t, 8> data{};
};

RawFrame encode(const Frame& frame);
// nullopt for error frames (CAN_ERR_FLAG); lengths above 8 are clamped, remote frames carry no
// data.
std::optional<Frame> decode(const RawFrame& raw);

// What one error frame (linux/can/error.h) means for the channel.
struct ErrorEffect {
  std::optional<BusState> state;  // new fault confinement state, if the frame reports one
  std::uint32_t rx_lost = 0;      // CAN_ERR_CRTL_RX_OVERFLOW: at least one frame lost
  std::string description;        // for the log: "controller: rx-warning rx-overflow"
};
// `raw` must be an error frame. Classes: CAN_ERR_RESTARTED → Ok; CAN_ERR_CRTL data[1] state bits
// (…_ACTIVE → Ok, …_WARNING → Warning, …_PASSIVE → ErrorPassive, the most severe wins);
// CAN_ERR_BUSOFF → BusOff. Only the class is needed, so socketcand `< error CLASS … >` lines use
// it with zero data.
ErrorEffect decode_error(const RawFrame& raw);

// SO_RXQ_OVFL reports a cumulative 32-bit drop counter per socket; rx_lost() needs the increase.
class OverflowCounter {
 public:
  // Returns the frames dropped since the previous observation (wraps modulo 2^32).
  std::uint32_t observe(std::uint32_t cumulative) {
    const std::uint32_t delta = cumulative - last_;
    last_ = cumulative;
    return delta;
  }

 private:
  std::uint32_t last_ = 0;  // the kernel counter starts at 0 when the option is enabled
};

}  // namespace socketcan
}  // namespace candp2::can

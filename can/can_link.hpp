// The CAN controller behind a SocketCAN interface, through rtnetlink (docs/transports.md, "Bit
// rate and controller state"): its bit timing, its bit rate (down, set, up), restart-ms and its
// fault confinement state. Uses Debian's libsocketcan (libsocketcan-dev) rather than hand-written
// netlink. Calls are synchronous netlink round trips to the local kernel (well below a millisecond)
// and are made from the daemon's one event loop.
//
// The decisions around it (does a configured bit rate match the interface's, what to log) are pure
// functions below, tested without CAN support in the kernel.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "can/channel.hpp"

namespace candp2::can {

// linux/can/netlink.h enum can_state.
enum class ControllerState : std::uint8_t {
  ErrorActive,
  ErrorWarning,
  ErrorPassive,
  BusOff,
  Stopped,
  Sleeping,
};
std::string_view to_string(ControllerState s);
// What a controller state means for diagnosis byte 8 (docs/dp-slave.md "Diagnosis"); Stopped and
// Sleeping (the interface is down) count as bus-off: the gateway cannot send.
BusState to_bus_state(ControllerState s);

struct BitTiming {
  std::uint32_t bitrate = 0;       // bit/s
  std::uint32_t sample_point = 0;  // tenths of a percent (875 = 87.5 %)
};

// What candp2d needs to know about an interface at one moment.
struct LinkInfo {
  bool up = false;          // IFF_UP
  bool controller = false;  // a CAN controller with a netlink state; false for vcan/vxcan
  // None for vcan/vxcan, and for a controller that was never given a bit rate (it cannot be set
  // up before: "bit-timing not yet defined").
  std::optional<BitTiming> bittiming;
};

struct LinkError {
  int error = 0;  // errno of the failed netlink request (EPERM: no CAP_NET_ADMIN)
  std::string message;
};

// One SocketCAN interface's controller. All calls are quick netlink requests.
class CanLink {
 public:
  explicit CanLink(std::string interface) : interface_(std::move(interface)) {}
  const std::string& interface() const { return interface_; }

  // The bit timing; nullopt when the interface has none (vcan, vxcan: no IFLA_CAN_BITTIMING) or
  // cannot be asked (then *error says why).
  std::optional<BitTiming> bittiming(std::string* error = nullptr) const;
  std::optional<ControllerState> state() const;
  // Up, controller, bit timing; nullopt when the interface does not exist.
  std::optional<LinkInfo> info() const;
  std::optional<std::uint32_t> restart_ms() const;

  // Down, bit rate (and restart-ms when given), up: also for an interface that was down or never
  // had a bit timing. On failure the interface is brought up again (best effort: with its previous
  // bit rate, if it had one) and the error says which step failed and why.
  std::optional<LinkError> set_bitrate(std::uint32_t bitrate,
                                       std::optional<std::uint32_t> restart_ms) const;

 private:
  std::string interface_;
};

// A configured bit rate matches the interface's when they differ by at most 1 % (the kernel picks
// the nearest timing its controller clock allows: 666.6k and 333.3k (manual table 5.1.1) are never
// exact; the CAN-DP/2's own SJA1000-class controllers are not either).
bool bitrate_matches(std::uint32_t configured, std::uint32_t actual);

// What to run by hand to put `interface` at `bitrate` and up, for log lines:
//   "ip link set can0 type can bitrate 500000 restart-ms 100 && ip link set can0 up"
// `bitrate` 0 keeps the interface's bit rate ("ip link set can0 up"); `down_first` (the interface
// is up: its bit rate changes only while it is down) puts "ip link set can0 down && " before.
std::string ip_link_command(const std::string& interface, std::uint32_t bitrate,
                            std::optional<std::uint32_t> restart_ms, bool down_first);

// The log line for a refused netlink request: names the interface and the step; for EPERM the
// command to run as root instead (`command`, from ip_link_command) and how to grant CAP_NET_ADMIN
// (the systemd drop-in or setcap).
std::string describe_link_error(const std::string& interface, const LinkError& e,
                                const std::string& command);

}  // namespace candp2::can

#include "can/can_link.hpp"

#include <errno.h>
#include <libsocketcan.h>
#include <linux/can/netlink.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>

namespace candp2::can {

std::string_view to_string(ControllerState s) {
  switch (s) {
    case ControllerState::ErrorActive:
      return "error-active";
    case ControllerState::ErrorWarning:
      return "error-warning";
    case ControllerState::ErrorPassive:
      return "error-passive";
    case ControllerState::BusOff:
      return "bus-off";
    case ControllerState::Stopped:
      return "stopped";
    case ControllerState::Sleeping:
      return "sleeping";
  }
  return "?";
}

BusState to_bus_state(ControllerState s) {
  switch (s) {
    case ControllerState::ErrorActive:
      return BusState::Ok;
    case ControllerState::ErrorWarning:
      return BusState::Warning;
    case ControllerState::ErrorPassive:
      return BusState::ErrorPassive;
    case ControllerState::BusOff:
    case ControllerState::Stopped:
    case ControllerState::Sleeping:
      return BusState::BusOff;
  }
  return BusState::BusOff;
}

bool bitrate_matches(std::uint32_t configured, std::uint32_t actual) {
  const std::uint64_t diff = configured > actual ? configured - actual : actual - configured;
  return diff * 100 <= configured;  // within 1 %
}

std::string ip_link_command(const std::string& interface, std::uint32_t bitrate,
                            std::optional<std::uint32_t> restart_ms, bool down_first) {
  const std::string set = "ip link set " + interface;
  std::string text = down_first ? set + " down && " : std::string();
  if (bitrate) {
    text += set + " type can bitrate " + std::to_string(bitrate);
    if (restart_ms) text += " restart-ms " + std::to_string(*restart_ms);
    text += " && ";
  }
  return text + set + " up";
}

std::string describe_link_error(const std::string& interface, const LinkError& e,
                                const std::string& command) {
  std::string text = "interface " + interface + ": " + e.message;
  if (e.error == EPERM || e.error == EACCES)
    text +=
        "; setting the bit rate needs CAP_NET_ADMIN: run `" + command +
        "` as root, or copy the systemd drop-in "
        "packaging/systemd/candp2d-bitrate-apply.conf to /etc/systemd/system/candp2d.service.d/, "
        "or `setcap cap_net_admin+ep $(command -v candp2d)`, or use \"bitrate\": \"check\" and "
        "configure the interface yourself";
  return text;
}

namespace {

// linux/can/netlink.h states, in the kernel's order.
std::optional<ControllerState> from_kernel(int state) {
  switch (state) {
    case CAN_STATE_ERROR_ACTIVE:
      return ControllerState::ErrorActive;
    case CAN_STATE_ERROR_WARNING:
      return ControllerState::ErrorWarning;
    case CAN_STATE_ERROR_PASSIVE:
      return ControllerState::ErrorPassive;
    case CAN_STATE_BUS_OFF:
      return ControllerState::BusOff;
    case CAN_STATE_STOPPED:
      return ControllerState::Stopped;
    case CAN_STATE_SLEEPING:
      return ControllerState::Sleeping;
    default:
      return std::nullopt;
  }
}

LinkError failed(const char* step, int err) {
  return {err, std::string(step) + " failed: " + (err ? std::strerror(err) : "netlink error")};
}

}  // namespace

std::optional<BitTiming> CanLink::bittiming(std::string* error) const {
  can_bittiming bt{};
  errno = 0;
  if (::can_get_bittiming(interface_.c_str(), &bt) != 0) {
    if (error)
      *error = "cannot read the bit timing of " + interface_ +
               (errno ? std::string(": ") + std::strerror(errno) : std::string());
    return std::nullopt;
  }
  if (bt.bitrate == 0) {  // vcan/vxcan report no IFLA_CAN_BITTIMING at all; be safe about zero
    if (error) *error = "interface " + interface_ + " has no bit timing";
    return std::nullopt;
  }
  return BitTiming{bt.bitrate, bt.sample_point};
}

std::optional<ControllerState> CanLink::state() const {
  int s = -1;
  if (::can_get_state(interface_.c_str(), &s) != 0) return std::nullopt;
  return from_kernel(s);
}

std::optional<LinkInfo> CanLink::info() const {
  if (::if_nametoindex(interface_.c_str()) == 0) return std::nullopt;
  LinkInfo info;
  // SIOCGIFFLAGS works through a socket of any family; AF_INET exists on every kernel.
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd >= 0) {
    ifreq ifr{};
    std::snprintf(ifr.ifr_name, sizeof ifr.ifr_name, "%s", interface_.c_str());
    info.up = ::ioctl(fd, SIOCGIFFLAGS, &ifr) == 0 && (ifr.ifr_flags & IFF_UP);
    ::close(fd);
  }
  info.controller = state().has_value();  // vcan/vxcan have no IFLA_CAN_STATE
  if (info.controller) info.bittiming = bittiming();
  return info;
}

std::optional<std::uint32_t> CanLink::restart_ms() const {
  __u32 ms = 0;
  if (::can_get_restart_ms(interface_.c_str(), &ms) != 0) return std::nullopt;
  return ms;
}

std::optional<LinkError> CanLink::set_bitrate(std::uint32_t bitrate,
                                              std::optional<std::uint32_t> restart_ms) const {
  const char* name = interface_.c_str();
  errno = 0;
  if (::can_do_stop(name) != 0) return failed("ip link set down", errno);
  std::optional<LinkError> result;
  errno = 0;
  if (::can_set_bitrate(name, bitrate) != 0) {
    result = failed(("setting the bit rate to " + std::to_string(bitrate)).c_str(), errno);
  } else if (restart_ms) {
    errno = 0;
    if (::can_set_restart_ms(name, *restart_ms) != 0)
      result = failed(("setting restart-ms " + std::to_string(*restart_ms)).c_str(), errno);
  }
  // Up again in every case: a failed bit rate leaves the previous one in place.
  errno = 0;
  if (::can_do_start(name) != 0 && !result) result = failed("ip link set up", errno);
  return result;
}

}  // namespace candp2::can

// Network interface changes from the kernel (rtnetlink, multicast group RTMGRP_LINK): an interface
// going down, coming up, being removed or created. A SocketCAN channel listens to them so that it
// notices its interface coming back without polling and without a frame to wake it
// (docs/transports.md "Down interfaces"). Subscribing needs no privilege.
//
// The parser is a pure function over one netlink datagram, tested without kernel CAN support.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace candp2::can {

struct LinkEvent {
  enum class Kind : std::uint8_t { New, Removed };  // RTM_NEWLINK (any change), RTM_DELLINK
  Kind kind = Kind::New;
  int index = 0;     // ifinfomsg.ifi_index
  bool up = false;   // IFF_UP in ifinfomsg.ifi_flags
  std::string name;  // IFLA_IFNAME, empty when the message has none
};

// The RTM_NEWLINK/RTM_DELLINK messages of one netlink datagram, in order. Other message types and
// truncated or malformed parts are skipped (the rest of a datagram after a bad header is dropped).
std::vector<LinkEvent> parse_link_events(std::span<const std::uint8_t> datagram);

// A non-blocking NETLINK_ROUTE socket subscribed to RTMGRP_LINK.
class LinkEventSocket {
 public:
  // nullptr and *error on failure (no netlink in this kernel or sandbox).
  static std::unique_ptr<LinkEventSocket> open(std::string* error);
  ~LinkEventSocket();
  LinkEventSocket(const LinkEventSocket&) = delete;
  LinkEventSocket& operator=(const LinkEventSocket&) = delete;

  int fd() const { return fd_; }
  // Everything queued now. *overrun is set when the kernel dropped messages (ENOBUFS: the socket's
  // buffer was full); the reader must then look at the interfaces itself.
  std::vector<LinkEvent> read(bool* overrun);

 private:
  explicit LinkEventSocket(int fd) : fd_(fd) {}
  int fd_;
};

}  // namespace candp2::can

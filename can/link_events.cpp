#include "can/link_events.hpp"

#include <errno.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstring>

namespace candp2::can {

std::vector<LinkEvent> parse_link_events(std::span<const std::uint8_t> datagram) {
  std::vector<LinkEvent> events;
  std::size_t at = 0;
  // linux/netlink.h: messages are NLMSG_ALIGN'ed one after another; nlmsg_len covers the header.
  while (datagram.size() - at >= sizeof(nlmsghdr)) {
    nlmsghdr h;
    std::memcpy(&h, datagram.data() + at, sizeof h);
    if (h.nlmsg_len < sizeof h || h.nlmsg_len > datagram.size() - at) break;
    const std::span<const std::uint8_t> msg = datagram.subspan(at, h.nlmsg_len);
    at += std::min<std::size_t>(NLMSG_ALIGN(h.nlmsg_len), datagram.size() - at);
    if (h.nlmsg_type != RTM_NEWLINK && h.nlmsg_type != RTM_DELLINK) continue;
    const std::size_t info_at = NLMSG_HDRLEN;
    if (msg.size() < info_at + sizeof(ifinfomsg)) continue;
    ifinfomsg info;
    std::memcpy(&info, msg.data() + info_at, sizeof info);
    LinkEvent e;
    e.kind = h.nlmsg_type == RTM_NEWLINK ? LinkEvent::Kind::New : LinkEvent::Kind::Removed;
    e.index = info.ifi_index;
    e.up = (info.ifi_flags & IFF_UP) != 0;
    // linux/rtnetlink.h: rtattr after the ifinfomsg, each RTA_ALIGN'ed.
    std::size_t a = info_at + NLMSG_ALIGN(sizeof(ifinfomsg));
    while (msg.size() >= a + sizeof(rtattr)) {
      rtattr attr;
      std::memcpy(&attr, msg.data() + a, sizeof attr);
      if (attr.rta_len < sizeof attr || attr.rta_len > msg.size() - a) break;
      if (attr.rta_type == IFLA_IFNAME) {
        const auto* text = reinterpret_cast<const char*>(msg.data() + a + RTA_LENGTH(0));
        const std::size_t max = attr.rta_len - RTA_LENGTH(0);
        e.name.assign(text, strnlen(text, max));
      }
      a += RTA_ALIGN(attr.rta_len);
    }
    events.push_back(std::move(e));
  }
  return events;
}

std::unique_ptr<LinkEventSocket> LinkEventSocket::open(std::string* error) {
  const int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0) {
    if (error) *error = std::string("socket(NETLINK_ROUTE) failed: ") + std::strerror(errno);
    return nullptr;
  }
  sockaddr_nl addr{};
  addr.nl_family = AF_NETLINK;
  addr.nl_groups = RTMGRP_LINK;
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) < 0) {
    if (error) *error = std::string("bind(RTMGRP_LINK) failed: ") + std::strerror(errno);
    ::close(fd);
    return nullptr;
  }
  return std::unique_ptr<LinkEventSocket>(new LinkEventSocket(fd));
}

LinkEventSocket::~LinkEventSocket() {
  ::close(fd_);
}

std::vector<LinkEvent> LinkEventSocket::read(bool* overrun) {
  std::vector<LinkEvent> events;
  // One RTM_NEWLINK of a CAN interface is about 1.5 kB; 16 kB holds a batch.
  alignas(nlmsghdr) std::array<std::uint8_t, 16384> buf;
  for (;;) {
    const ssize_t n = ::recv(fd_, buf.data(), buf.size(), MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == ENOBUFS) {  // the kernel dropped messages; the socket stays usable
        if (overrun) *overrun = true;
        continue;
      }
      break;  // EAGAIN, or an error that the next read reports again
    }
    if (n == 0) break;
    auto part = parse_link_events(std::span<const std::uint8_t>(buf.data(), std::size_t(n)));
    for (auto& e : part) events.push_back(std::move(e));
  }
  return events;
}

}  // namespace candp2::can

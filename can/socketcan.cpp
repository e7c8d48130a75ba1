#include "can/socketcan.hpp"

#include <errno.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <net/if_arp.h>
#include <sys/epoll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "can/can_link.hpp"
#include "can/link_events.hpp"
#include "common/hex.hpp"

namespace candp2::can {

namespace socketcan {

static_assert(sizeof(can_frame) == 16, "classic CAN_MTU");

RawFrame encode(const Frame& frame) {
  RawFrame raw;
  raw.can_id =
      frame.extended ? ((frame.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (frame.id & CAN_SFF_MASK);
  if (frame.remote) raw.can_id |= CAN_RTR_FLAG;
  raw.len = std::min(frame.dlc, kMaxDlc);
  if (!frame.remote) std::copy_n(frame.data.begin(), raw.len, raw.data.begin());
  return raw;
}

std::optional<Frame> decode(const RawFrame& raw) {
  if (raw.can_id & CAN_ERR_FLAG) return std::nullopt;
  Frame f;
  f.extended = (raw.can_id & CAN_EFF_FLAG) != 0;
  f.id = raw.can_id & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  f.remote = (raw.can_id & CAN_RTR_FLAG) != 0;
  f.dlc = std::min(raw.len, kMaxDlc);
  if (!f.remote) std::copy_n(raw.data.begin(), f.dlc, f.data.begin());
  return f;
}

ErrorEffect decode_error(const RawFrame& raw) {
  ErrorEffect e;
  const std::uint32_t cls = raw.can_id & CAN_ERR_MASK;
  auto describe = [&](const char* what) {
    if (!e.description.empty()) e.description += ' ';
    e.description += what;
  };
  // linux/can/error.h: the class bits in can_id, details in data[]. Applied from least to most
  // severe so that a frame reporting several conditions ends in the worst state.
  if (cls & CAN_ERR_RESTARTED) {
    describe("restarted");
    e.state = BusState::Ok;
  }
  if (cls & CAN_ERR_CRTL) {
    const std::uint8_t c = raw.data[1];
    describe("controller:");
    if (c & CAN_ERR_CRTL_ACTIVE) {
      describe("error-active");
      e.state = BusState::Ok;
    }
    if (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) {
      describe((c & CAN_ERR_CRTL_TX_WARNING) ? "tx-warning" : "rx-warning");
      e.state = BusState::Warning;
    }
    if (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) {
      describe((c & CAN_ERR_CRTL_TX_PASSIVE) ? "tx-passive" : "rx-passive");
      e.state = BusState::ErrorPassive;
    }
    if (c & CAN_ERR_CRTL_RX_OVERFLOW) {
      describe("rx-overflow");
      e.rx_lost = 1;  // the controller does not say how many; at least one frame is gone
    }
    if (c & CAN_ERR_CRTL_TX_OVERFLOW) describe("tx-overflow");
    if (c == CAN_ERR_CRTL_UNSPEC) describe("unspecified");
  }
  if (cls & CAN_ERR_BUSOFF) {
    describe("bus-off");
    e.state = BusState::BusOff;
  }
  if (cls & CAN_ERR_TX_TIMEOUT) describe("tx-timeout");
  if (cls & CAN_ERR_LOSTARB) describe("lost-arbitration");
  if (cls & CAN_ERR_PROT) describe("protocol-violation");
  if (cls & CAN_ERR_TRX) describe("transceiver");
  if (cls & CAN_ERR_ACK) describe("no-ack");
  if (cls & CAN_ERR_BUSERROR) describe("bus-error");
  if (e.description.empty()) describe("unknown error class");
  return e;
}

}  // namespace socketcan

namespace {

// Error classes that change what bus_state() and rx_lost() report; bus errors (CAN_ERR_BUSERROR,
// CAN_ERR_PROT, CAN_ERR_ACK) are left out on purpose: they can flood and carry no state.
constexpr can_err_mask_t kErrorMask = CAN_ERR_CRTL | CAN_ERR_BUSOFF | CAN_ERR_RESTARTED;

std::string errno_text(int err) {
  return std::string(std::strerror(err));
}

bool fail(std::string* error, std::string message) {
  if (error) *error = std::move(message);
  return false;
}

// A raw CAN socket bound to interface `index`, error frames and SO_RXQ_OVFL on; -1 and *error on
// failure. Binding to a down interface works: the kernel then reports ENETDOWN once (net/can/raw.c
// raw_bind) and frames flow as soon as the interface is up.
int open_raw(const std::string& interface, unsigned index, bool receive_own, std::string* error) {
  const std::string who = "interface " + interface;
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    fail(error, "cannot open " + who + ": this kernel has no CAN support (socket(AF_CAN) failed: " +
                    errno_text(errno) + "; modprobe can_raw)");
    return -1;
  }
  auto set = [&](int level, int name, const void* value, socklen_t size, const char* what) {
    if (::setsockopt(fd, level, name, value, size) == 0) return true;
    fail(error, "cannot open " + who + ": setsockopt(" + what + ") failed: " + errno_text(errno));
    return false;
  };
  const int on = 1;
  const can_err_mask_t err_mask = kErrorMask;
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (!set(SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask, "CAN_RAW_ERR_FILTER") ||
      !set(SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on, "SO_RXQ_OVFL") ||
      (receive_own &&
       !set(SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &on, sizeof on, "CAN_RAW_RECV_OWN_MSGS"))) {
    ::close(fd);
    return -1;
  }
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) < 0) {
    fail(error, "cannot bind to " + who + ": " + errno_text(errno));
    ::close(fd);
    return -1;
  }
  return fd;
}

// IFF_UP of `interface`, asked through any socket (SIOCGIFFLAGS); false when it does not exist.
bool interface_is_up(int fd, const std::string& interface) {
  ifreq ifr{};
  std::memcpy(ifr.ifr_name, interface.c_str(), interface.size() + 1);
  return ::ioctl(fd, SIOCGIFFLAGS, &ifr) == 0 && (ifr.ifr_flags & IFF_UP);
}

class SocketCanChannel final : public Channel {
 public:
  SocketCanChannel(int fd, std::string interface, unsigned index, SocketCanOptions options)
      : fd_(fd),
        index_(index),
        interface_(interface),
        name_("socketcan:" + interface),
        receive_own_(options.receive_own),
        log_(options.log, "socketcan " + interface) {}
  ~SocketCanChannel() override {
    if (epoll_fd_ >= 0) ::close(epoll_fd_);
    ::close(fd_);
  }
  SocketCanChannel(const SocketCanChannel&) = delete;
  SocketCanChannel& operator=(const SocketCanChannel&) = delete;

  // The controller state when the channel opens (can_get_state; none for vcan).
  void set_initial_state(BusState s) { state_ = s; }
  // Opened on a down interface: bus-off, and the socket reports ENETDOWN once (raw_bind).
  void set_initially_down() {
    link_down_ = true;
    enetdown_pending_ = true;
  }
  // Link events (interface up, down, removed, created) through rtnetlink and one epoll
  // descriptor for them and the raw socket. Without them (no netlink), the channel learns of an
  // interface coming back only from the next frame sent or received.
  void watch_link() {
    std::string error;
    events_ = LinkEventSocket::open(&error);
    if (events_) {
      epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
      if (epoll_fd_ >= 0 && add(fd_) && add(events_->fd())) return;
      error = "epoll: " + errno_text(errno);
      if (epoll_fd_ >= 0) ::close(epoll_fd_);
      epoll_fd_ = -1;
      events_.reset();
    }
    log_.warn("no link events (" + error +
              "): an interface coming up is noticed at the next frame");
  }

  void send(const Frame& frame) override {
    const socketcan::RawFrame raw = socketcan::encode(frame);
    can_frame cf{};
    cf.can_id = raw.can_id;
    cf.len = raw.len;
    std::copy(raw.data.begin(), raw.data.end(), cf.data);
    const ssize_t n = ::send(fd_, &cf, sizeof cf, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n == static_cast<ssize_t>(sizeof cf)) {
      if (tx_failing_) {
        log_.info("transmit works again after " + std::to_string(tx_failing_) + " dropped frames");
        tx_failing_ = 0;
      }
      if (link_down_) restarted();
      return;
    }
    const int err = n < 0 ? errno : EIO;
    ++tx_dropped_;
    // ENOBUFS: the interface transmit queue is full (SocketCAN does not block for it);
    // ENETDOWN: the interface went down. Log the first drop of a run, then every 1000th.
    if (err == ENETDOWN) link_down_ = true;
    if (tx_failing_++ % 1000 == 0)
      log_.warn("frame " + format_candump(frame) + " dropped: " +
                (err == ENOBUFS ? std::string("transmit queue full (ENOBUFS)") : errno_text(err)) +
                " (" + std::to_string(tx_dropped_) + " dropped so far)");
  }

  std::optional<Frame> receive() override {
    link_events();
    // Error frames are consumed here and never returned; read on until a data frame or EAGAIN.
    for (;;) {
      can_frame cf{};
      iovec iov{&cf, sizeof cf};
      alignas(cmsghdr) char control[CMSG_SPACE(sizeof(std::uint32_t))];
      msghdr msg{};
      msg.msg_iov = &iov;
      msg.msg_iovlen = 1;
      msg.msg_control = control;
      msg.msg_controllen = sizeof control;
      const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
      if (n < 0) {
        const int err = errno;
        if (err == EAGAIN || err == EWOULDBLOCK) return std::nullopt;
        if (err == EINTR) continue;
        if (err == ENETDOWN) {
          if (!network_down()) continue;
        } else if (err == ENODEV) {
          if (!removed_) log_.error("interface was removed; bus state reported as bus-off");
          link_down_ = removed_ = true;
        } else {
          log_.error("receive failed: " + errno_text(err));
        }
        return std::nullopt;
      }
      count_overflow(msg);
      if (n != static_cast<ssize_t>(sizeof cf)) {
        log_.warn("ignored a " + std::to_string(n) + "-byte read (not a classic CAN frame)");
        continue;
      }
      if (link_down_) {
        log_.info("interface is up again; controller error-active");
        restarted();
      }
      socketcan::RawFrame raw;
      raw.can_id = cf.can_id;
      raw.len = cf.len;
      std::copy(std::begin(cf.data), std::end(cf.data), raw.data.begin());
      if (raw.can_id & CAN_ERR_FLAG) {
        handle_error(raw);
        continue;
      }
      return socketcan::decode(raw);
    }
  }

  BusState bus_state() const override { return link_down_ ? BusState::BusOff : state_; }
  std::uint32_t rx_lost() const override { return rx_lost_; }
  std::uint32_t tx_dropped() const override { return tx_dropped_; }
  int poll_fd() const override { return epoll_fd_ >= 0 ? epoll_fd_ : fd_; }
  std::string_view name() const override { return name_; }

 private:
  bool add(int fd) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = fd;
    return ::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev) == 0;
  }

  // The socket said ENETDOWN: the kernel reports a down transition once per socket. Returns
  // whether the interface is down (false: read on).
  bool network_down() {
    if (enetdown_pending_) {  // the link events told already
      enetdown_pending_ = false;
      return link_down_;
    }
    // Up again already (a bit rate change, `ip link set down/up`): the controller restarted
    // error-active (linux/can/netlink.h CAN_STATE_ERROR_ACTIVE after ndo_open).
    if (interface_is_up(fd_, interface_)) {
      log_.info("interface was restarted (down and up); controller error-active");
      restarted();
      return false;
    }
    if (!link_down_) log_.error("interface went down; bus state reported as bus-off");
    link_down_ = true;
    return true;
  }

  // What the kernel said about interfaces since the last call: this interface going down, coming
  // up, removed, or created again under its name (then the socket is bound anew).
  void link_events() {
    if (!events_) return;
    bool overrun = false;
    const auto events = events_->read(&overrun);
    bool went_down = false;
    std::optional<bool> up;
    for (const auto& e : events) {
      if (e.index == static_cast<int>(index_) && !removed_) {
        if (e.kind == LinkEvent::Kind::Removed) {
          log_.error("interface was removed; bus state reported as bus-off until it is back");
          link_down_ = removed_ = true;
          up.reset();
          continue;
        }
        if (!e.up) went_down = true;
        up = e.up;
      } else if (e.kind == LinkEvent::Kind::New && e.name == interface_ &&
                 e.index != static_cast<int>(index_)) {
        if (!rebind(static_cast<unsigned>(e.index))) return;
        up = e.up;
      }
    }
    if (overrun && !removed_) up = interface_is_up(fd_, interface_);
    if (!up) return;
    if (!*up) {
      if (!link_down_) {
        log_.error("interface went down; bus state reported as bus-off");
        enetdown_pending_ = true;
      }
      link_down_ = true;
      return;
    }
    if (link_down_) {
      log_.info("interface is up again; controller error-active");
      restarted();
    } else if (went_down) {
      log_.info("interface was restarted (down and up); controller error-active");
      restarted();
    }
    if (went_down) enetdown_pending_ = true;
  }

  // The interface was created again (a new index): a new socket bound to it.
  bool rebind(unsigned index) {
    std::string error;
    const int fd = open_raw(interface_, index, receive_own_, &error);
    if (fd < 0) {
      log_.error("interface is back (index " + std::to_string(index) +
                 ") but cannot be opened: " + error);
      return false;
    }
    ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd_, nullptr);
    ::close(fd_);
    fd_ = fd;
    index_ = index;
    removed_ = false;
    link_down_ = true;  // until the interface is seen up
    enetdown_pending_ = !interface_is_up(fd_, interface_);
    overflow_ = {};
    if (!add(fd_)) log_.error("epoll: " + errno_text(errno));
    log_.info("interface was created again (index " + std::to_string(index) + "); socket reopened");
    return true;
  }

  void count_overflow(msghdr& msg) {
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL &&
          c->cmsg_len >= CMSG_LEN(sizeof(std::uint32_t))) {
        std::uint32_t cumulative = 0;
        std::memcpy(&cumulative, CMSG_DATA(c), sizeof cumulative);
        if (const std::uint32_t lost = overflow_.observe(cumulative)) {
          rx_lost_ += lost;
          log_.warn("socket receive queue overflowed: " + std::to_string(lost) +
                    " frames lost (SO_RXQ_OVFL)");
        }
      }
    }
  }

  void handle_error(const socketcan::RawFrame& raw) {
    const auto e = socketcan::decode_error(raw);
    rx_lost_ += e.rx_lost;
    const std::string text = "error frame " + format_hex_id(raw.can_id) + " [" +
                             candp2::hex_bytes(raw.data) + "]: " + e.description;
    if (e.state && *e.state != state_) {
      log_.warn(text + "; bus state " + std::string(to_string(state_)) + " -> " +
                std::string(to_string(*e.state)));
      state_ = *e.state;
    } else {
      log_.log(e.rx_lost ? LogLevel::Warn : LogLevel::Debug, text);
    }
  }

  void restarted() {
    link_down_ = false;
    if (state_ != BusState::Ok)
      log_.info("bus state " + std::string(to_string(state_)) + " -> ok (interface restarted)");
    state_ = BusState::Ok;
  }

  static std::string format_hex_id(std::uint32_t id) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%08X", static_cast<unsigned>(id));
    return buf;
  }

  int fd_;
  unsigned index_;
  int epoll_fd_ = -1;
  std::unique_ptr<LinkEventSocket> events_;
  std::string interface_;
  std::string name_;
  bool receive_own_;
  Logger log_;
  BusState state_ = BusState::Ok;
  bool link_down_ = false;
  bool enetdown_pending_ = false;  // a down transition the socket has yet to report (ENETDOWN)
  bool removed_ = false;           // the interface was deleted (RTM_DELLINK, ENODEV)
  std::uint32_t rx_lost_ = 0;
  std::uint32_t tx_dropped_ = 0;
  std::uint32_t tx_failing_ = 0;  // drops since the last successful send, for log rate limiting
  socketcan::OverflowCounter overflow_;
};

}  // namespace

std::unique_ptr<Channel> open_socketcan(const std::string& interface, std::string* error,
                                        SocketCanOptions options) {
  const std::string who = "interface " + interface;
  if (interface.empty() || interface.size() >= IFNAMSIZ) {
    fail(error, "invalid CAN interface name '" + interface + "' (1.." +
                    std::to_string(IFNAMSIZ - 1) + " characters)");
    return nullptr;
  }
  // 1. The interface must exist (if_nametoindex works without kernel CAN support).
  const unsigned index = ::if_nametoindex(interface.c_str());
  if (index == 0) {
    fail(error, who + " does not exist (for a virtual bus: modprobe vcan; ip link add dev " +
                    interface + " type vcan; ip link set " + interface + " up)");
    return nullptr;
  }
  // 2. The kernel must speak CAN.
  const int probe = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (probe < 0) {
    fail(error, "cannot open " + who + ": this kernel has no CAN support (socket(AF_CAN) failed: " +
                    errno_text(errno) + "; modprobe can_raw)");
    return nullptr;
  }
  // 3. It must be a CAN interface, and up unless the caller takes a down one.
  ifreq ifr{};
  std::memcpy(ifr.ifr_name, interface.c_str(), interface.size() + 1);
  const bool is_can =
      ::ioctl(probe, SIOCGIFHWADDR, &ifr) != 0 || ifr.ifr_hwaddr.sa_family == ARPHRD_CAN;
  const int flags_errno = ::ioctl(probe, SIOCGIFFLAGS, &ifr) < 0 ? errno : 0;
  ::close(probe);
  if (!is_can) {
    fail(error, who + " is not a CAN interface");
    return nullptr;
  }
  if (flags_errno) {
    fail(error, "cannot read the flags of " + who + ": " + errno_text(flags_errno));
    return nullptr;
  }
  const bool up = (ifr.ifr_flags & IFF_UP) != 0;
  if (!up && !options.allow_down) {
    fail(error, who + " is down (ip link set " + interface + " up)");
    return nullptr;
  }
  const int fd = open_raw(interface, index, options.receive_own, error);
  if (fd < 0) return nullptr;

  Logger log(options.log, "socketcan " + interface);
  auto channel = std::make_unique<SocketCanChannel>(fd, interface, index, options);
  channel->watch_link();
  const CanLink link(interface);
  if (!up) {
    // A controller never given a bit rate cannot be set up (`ip link set can0 up`: "bit-timing
    // not yet defined"); vcan has no controller state and no bit timing.
    const bool controller = link.state().has_value();
    channel->set_initially_down();
    log.warn("opened, but the interface is down" +
             std::string(controller && !link.bittiming() ? " and has no bit timing yet" : "") +
             ": bus state bus-off until it is up (`" +
             std::string(controller ? "ip link set " + interface + " type can bitrate N && " : "") +
             "ip link set " + interface + " up`)");
    return channel;
  }
  // A real controller may already be warning, error-passive or bus-off (restart-ms 0) before this
  // socket saw any error frame; vcan has no controller state.
  if (const auto state = link.state()) {
    channel->set_initial_state(to_bus_state(*state));
    log.info("opened (raw socket, error frames on), controller " + std::string(to_string(*state)));
  } else {
    log.info("opened (raw socket, error frames on)");
  }
  return channel;
}

}  // namespace candp2::can

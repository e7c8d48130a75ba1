#include "can/socketcand_client.hpp"

#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <map>
#include <utility>

#include "can/socketcand_net.hpp"

namespace candp2::can {

namespace {

using socketcand::ElementSplitter;
using socketcand_net::address_text;
using socketcand_net::errno_text;
using socketcand_net::is_printable_element;
using socketcand_net::printable;
using socketcand_net::set_error;
using socketcand_net::UniqueFd;

// ---------------------------------------------------------------------------------------------
// Client
// ---------------------------------------------------------------------------------------------

using Clock = std::chrono::steady_clock;

int remaining_ms(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return static_cast<int>(std::max<std::chrono::milliseconds::rep>(0, left.count()));
}

// Blocking helper for the handshake, bounded by one deadline.
class Handshake {
 public:
  Handshake(int fd, Clock::time_point deadline, std::string who)
      : fd_(fd), deadline_(deadline), who_(std::move(who)) {}

  bool next(std::string* element, std::string* error) {
    while (elements_.empty()) {
      pollfd p{fd_, POLLIN, 0};
      const int r = ::poll(&p, 1, remaining_ms(deadline_));
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) return fail(error, "timed out waiting for the server during the handshake");
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
      if (n == 0) return fail(error, "the server closed the connection during the handshake");
      if (n < 0) {
        if (errno == EAGAIN || errno == EINTR) continue;
        return fail(error, "receive failed during the handshake: " + errno_text(errno));
      }
      items_.clear();
      splitter_.feed(std::string_view(buf, static_cast<std::size_t>(n)), items_);
      for (auto& item : items_) {
        if (item.kind == ElementSplitter::Kind::Element) elements_.push_back(std::move(item.text));
        if (item.kind == ElementSplitter::Kind::Overflow)
          return fail(error, "the server sent an over-long line (not a socketcand server?)");
      }
    }
    *element = std::move(elements_.front());
    elements_.pop_front();
    return true;
  }

  bool send(std::string_view text, std::string* error) {
    while (!text.empty()) {
      const ssize_t n = ::send(fd_, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n > 0) {
        text.remove_prefix(static_cast<std::size_t>(n));
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && errno == EAGAIN) {
        pollfd p{fd_, POLLOUT, 0};
        if (::poll(&p, 1, remaining_ms(deadline_)) <= 0)
          return fail(error, "timed out sending to the server during the handshake");
        continue;
      }
      return fail(error, "send failed during the handshake: " + errno_text(errno));
    }
    return true;
  }

  // Waits for `< ok >`; an `< error ... >` answer becomes the message.
  bool expect_ok(std::string_view after, std::string* error) {
    std::string e;
    if (!next(&e, error)) return false;
    const auto w = socketcand::words(e);
    if (w.size() == 1 && w[0] == "ok") return true;
    if (!w.empty() && w[0] == "error") {
      std::string reason;
      for (std::size_t i = 1; i < w.size(); ++i) {
        if (i > 1) reason += ' ';
        reason += w[i];
      }
      return fail(error, "the server refused " + std::string(after) + ": " + reason);
    }
    return fail(error,
                "expected '< ok >' after " + std::string(after) + ", got '" + printable(e) + "'");
  }

  ElementSplitter& splitter() { return splitter_; }
  std::deque<std::string>& elements() { return elements_; }

 private:
  bool fail(std::string* error, std::string message) {
    if (error) *error = "socketcand " + who_ + ": " + std::move(message);
    return false;
  }
  int fd_;
  Clock::time_point deadline_;
  std::string who_;
  ElementSplitter splitter_;
  std::vector<ElementSplitter::Item> items_;
  std::deque<std::string> elements_;
};

class SocketcandChannel final : public SocketcandClientChannel {
 public:
  static constexpr std::size_t kMaxOutput = 256 * 1024;  // queued `< send >` bytes

  SocketcandChannel(UniqueFd sock, UniqueFd epoll, std::string who, LogSink* log,
                    ElementSplitter splitter, std::deque<std::string> pending, std::string host,
                    std::uint16_t port, std::string channel)
      : sock_(std::move(sock)),
        epoll_(std::move(epoll)),
        name_("socketcand:" + who),
        log_(log, "socketcand " + who),
        splitter_(std::move(splitter)),
        host_(std::move(host)),
        port_(port),
        channel_(std::move(channel)) {
    for (const auto& e : pending) element(e);
  }

  // ---- reconnection: exponential backoff through the owner's timers, never blocking.
  std::optional<Time> next_deadline() const override {
    if (link_ == Link::Down) return retry_at_;
    if (link_ != Link::Up) return attempt_deadline_;
    return std::nullopt;
  }

  void advance(Time now) override {
    if (link_ == Link::Down && now >= retry_at_) {
      start_connect(now);
    } else if (link_ != Link::Up && link_ != Link::Down && now >= attempt_deadline_) {
      attempt_failed("no answer within " + std::to_string(kAttemptTimeout.count() / 1000) + " ms",
                     now);
    }
  }

  void send(const Frame& frame) override {
    if (!sock_) {
      ++tx_dropped_;
      if (tx_dropped_ == 1 || tx_dropped_ % 1000 == 0)
        log_.warn("not connected: frame " + format_candump(frame) + " dropped (" +
                  std::to_string(tx_dropped_) + " so far)");
      return;
    }
    if (frame.remote) {
      ++tx_dropped_;
      ++remote_dropped_;
      log_.log(remote_dropped_ == 1 ? LogLevel::Warn : LogLevel::Debug,
               "remote frame " + format_candump(frame) +
                   " dropped: the socketcand protocol has no remote frames");
      return;
    }
    const std::string line = socketcand::format_send(frame);
    if (out_.size() + line.size() > kMaxOutput) {
      ++tx_dropped_;
      log_.warn("server not reading: frame " + format_candump(frame) + " dropped (" +
                std::to_string(out_.size()) + " bytes waiting)");
      return;
    }
    out_ += line;
    flush();
  }

  std::optional<Frame> receive() override {
    if (link_ == Link::Connecting) finish_connect();
    flush();
    for (;;) {
      if (!rx_.empty()) {
        Frame f = rx_.front();
        rx_.pop_front();
        return f;
      }
      if (!sock_) return std::nullopt;
      char buf[16384];
      const ssize_t n = ::recv(sock_.get(), buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        items_.clear();
        splitter_.feed(std::string_view(buf, static_cast<std::size_t>(n)), items_);
        for (const auto& item : items_) {
          if (!sock_) break;
          switch (item.kind) {
            case ElementSplitter::Kind::Element:
              element(item.text);
              break;
            case ElementSplitter::Kind::Stray:
              log_.warn("ignored " + std::to_string(item.bytes) + " bytes outside < >: '" +
                        printable(item.text) + "'");
              break;
            case ElementSplitter::Kind::Overflow:
              disconnect("the server sent a line longer than " +
                         std::to_string(socketcand::kMaxElementBytes) + " bytes");
              break;
          }
        }
        continue;
      }
      if (n == 0) {
        disconnect("the server closed the connection");
        continue;
      }
      const int err = errno;
      if (err == EINTR) continue;
      if (err == EAGAIN || err == EWOULDBLOCK) return std::nullopt;
      disconnect("receive failed: " + errno_text(err));
    }
  }

  // While the connection is down or being re-established the channel reports bus-off.
  BusState bus_state() const override {
    return sock_ && link_ == Link::Up ? state_ : BusState::BusOff;
  }
  std::uint32_t rx_lost() const override { return rx_lost_; }
  std::uint32_t tx_dropped() const override { return tx_dropped_; }
  int poll_fd() const override { return epoll_.get(); }
  std::uint32_t reconnects() const override { return reconnects_; }
  std::string_view name() const override { return name_; }

 private:
  void element(const std::string& e) {
    const auto w = socketcand::words(e);
    const std::string_view cmd = w.empty() ? std::string_view() : w[0];
    if (link_ != Link::Up) return handshake(e, w);
    if (cmd == "frame") {
      auto r = socketcand::parse_frame(e);
      if (r.frame) {
        rx_.push_back(*r.frame);
      } else {
        ++rx_lost_;  // a frame the server reported that this reader cannot use
        log_.warn("unusable frame from the server (" + r.error + "): '" + printable(e) + "'");
      }
    } else if (cmd == "error") {
      if (const auto raw = socketcand::parse_error_frame(e)) {
        const auto effect = socketcan::decode_error(*raw);
        rx_lost_ += effect.rx_lost;
        if (effect.state && *effect.state != state_) {
          log_.warn("error frame: " + effect.description + "; bus state " +
                    std::string(to_string(state_)) + " -> " +
                    std::string(to_string(*effect.state)));
          state_ = *effect.state;
        } else {
          log_.log(effect.rx_lost ? LogLevel::Warn : LogLevel::Debug,
                   "error frame: " + effect.description);
        }
      } else {
        log_.warn("the server answered: '" + printable(e) + "'");
      }
    } else {
      log_.debug("ignored '" + printable(e) + "'");
    }
  }

  // doc/protocol.md: `< hi >`, `< open BUS >` → `< ok >`, `< rawmode >` → `< ok >`.
  void handshake(const std::string& e, const std::vector<std::string_view>& w) {
    const bool ok = w.size() == 1 && w[0] == "ok";
    if (link_ == Link::Hello && w.size() == 1 && w[0] == "hi") {
      link_ = Link::OpenSent;
      out_ += "< open " + channel_ + " >";
    } else if (link_ == Link::OpenSent && ok) {
      link_ = Link::RawSent;
      out_ += "< rawmode >";
    } else if (link_ == Link::RawSent && ok) {
      link_ = Link::Up;
      state_ = BusState::Ok;
      ++reconnects_;
      log_.warn("reconnected after " + std::to_string(attempts_) + " attempt(s), bus " + channel_ +
                " in raw mode again (reconnection " + std::to_string(reconnects_) + ")");
      attempts_ = 0;
      backoff_ = kFirstBackoff;  // reset after a successful connection
    } else {
      attempt_failed("unexpected '" + printable(e) + "' during the handshake", now_estimate());
      return;
    }
    flush();
  }

  static Time now_estimate() {
    return std::chrono::duration_cast<Time>(Clock::now().time_since_epoch());
  }

  void start_connect(Time now) {
    ++attempts_;
    attempt_deadline_ = now + kAttemptTimeout;
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_NUMERICSERV;
    addrinfo* res = nullptr;
    // Numeric hosts resolve without I/O; a name is looked up here (not bounded, see the header).
    if (::getaddrinfo(host_.c_str(), std::to_string(port_).c_str(), &hints, &res) != 0 || !res)
      return attempt_failed("cannot resolve " + host_, now);
    std::unique_ptr<addrinfo, decltype(&::freeaddrinfo)> guard(res, &::freeaddrinfo);
    UniqueFd fd(::socket(res->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    if (!fd) return attempt_failed("socket() failed: " + errno_text(errno), now);
    const bool done = ::connect(fd.get(), res->ai_addr, res->ai_addrlen) == 0;
    if (!done && errno != EINPROGRESS) return attempt_failed(errno_text(errno), now);
    const int on = 1;
    ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    epoll_event ev{};
    ev.events = done ? EPOLLIN : EPOLLOUT;  // EPOLLOUT: the non-blocking connect completed
    if (::epoll_ctl(epoll_.get(), EPOLL_CTL_ADD, fd.get(), &ev) < 0)
      return attempt_failed("epoll: " + errno_text(errno), now);
    sock_ = std::move(fd);
    want_write_ = false;
    splitter_ = ElementSplitter();
    link_ = done ? Link::Hello : Link::Connecting;
  }

  void finish_connect() {
    pollfd p{sock_.get(), POLLOUT, 0};
    if (::poll(&p, 1, 0) <= 0) return;  // still in progress
    int soerr = 0;
    socklen_t len = sizeof soerr;
    ::getsockopt(sock_.get(), SOL_SOCKET, SO_ERROR, &soerr, &len);
    if (soerr != 0) return attempt_failed(errno_text(soerr), now_estimate());
    epoll_event ev{};
    ev.events = EPOLLIN;
    ::epoll_ctl(epoll_.get(), EPOLL_CTL_MOD, sock_.get(), &ev);
    link_ = Link::Hello;
  }

  // A failed attempt: close, wait, try again with twice the delay (100 ms .. 5 s).
  void attempt_failed(const std::string& why, Time now) {
    if (sock_) ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, sock_.get(), nullptr);
    sock_.reset();
    out_.clear();
    link_ = Link::Down;
    retry_at_ = now + backoff_;
    log_.debug("reconnection attempt " + std::to_string(attempts_) + " failed: " + why +
               "; next in " + std::to_string(backoff_.count() / 1000) + " ms");
    backoff_ = std::min(backoff_ * 2, kMaxBackoff);
  }

  void flush() {
    if (!sock_) {
      out_.clear();
      return;
    }
    std::size_t done = 0;
    while (done < out_.size()) {
      const ssize_t n =
          ::send(sock_.get(), out_.data() + done, out_.size() - done, MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n > 0) {
        done += static_cast<std::size_t>(n);
        continue;
      }
      const int err = errno;
      if (n < 0 && err == EINTR) continue;
      if (n < 0 && (err == EAGAIN || err == EWOULDBLOCK)) break;
      disconnect("send failed: " + errno_text(err));
      return;
    }
    out_.erase(0, done);
    watch_write(!out_.empty());
  }

  void watch_write(bool on) {
    if (on == want_write_ || !sock_) return;
    epoll_event ev{};
    ev.events = EPOLLIN | (on ? EPOLLOUT : 0u);
    ::epoll_ctl(epoll_.get(), EPOLL_CTL_MOD, sock_.get(), &ev);
    want_write_ = on;
  }

  void disconnect(const std::string& why) {
    if (!sock_) return;
    if (link_ != Link::Up) return attempt_failed(why, now_estimate());
    // Logged once per transition; the attempts that follow log at debug level.
    log_.error(why + "; channel is down (bus state bus-off), reconnecting in " +
               std::to_string(kFirstBackoff.count() / 1000) + " ms with backoff up to " +
               std::to_string(kMaxBackoff.count() / 1000000) + " s");
    ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, sock_.get(), nullptr);
    sock_.reset();
    tx_dropped_ += static_cast<std::uint32_t>(std::count(out_.begin(), out_.end(), '<'));
    out_.clear();
    link_ = Link::Down;
    backoff_ = kFirstBackoff;
    attempts_ = 0;
    retry_at_ = now_estimate() + backoff_;
    backoff_ = std::min(backoff_ * 2, kMaxBackoff);
  }

  enum class Link { Up, Connecting, Hello, OpenSent, RawSent, Down };
  static constexpr Duration kFirstBackoff = milliseconds(100);
  static constexpr Duration kMaxBackoff = seconds(5);
  static constexpr Duration kAttemptTimeout = seconds(3);  // connect + handshake

  UniqueFd sock_;
  UniqueFd epoll_;
  std::string name_;
  Logger log_;
  ElementSplitter splitter_;
  std::vector<ElementSplitter::Item> items_;
  std::deque<Frame> rx_;
  std::string out_;
  bool want_write_ = false;
  BusState state_ = BusState::Ok;
  std::uint32_t rx_lost_ = 0;
  std::uint32_t tx_dropped_ = 0;
  std::uint32_t remote_dropped_ = 0;
  std::uint32_t reconnects_ = 0;
  std::string host_;
  std::uint16_t port_;
  std::string channel_;
  Link link_ = Link::Up;
  Duration backoff_ = kFirstBackoff;
  Time retry_at_{0};
  Time attempt_deadline_{0};
  std::uint32_t attempts_ = 0;
};

}  // namespace

std::unique_ptr<Channel> connect_socketcand(const std::string& host, std::uint16_t port,
                                            const std::string& channel, std::string* error,
                                            int timeout_ms, LogSink* log) {
  const std::string who = host + ":" + std::to_string(port);
  if (!socketcand_net::valid_bus_name(channel)) {
    set_error(error, "socketcand " + who + ": bus name '" + channel + "' must be 1.." +
                         std::to_string(socketcand::kMaxBusName) +
                         " printable characters without spaces or < >");
    return nullptr;
  }
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(0, timeout_ms));
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICSERV;
  addrinfo* res = nullptr;
  const int gai = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &res);
  if (gai != 0 || !res) {
    set_error(error, "socketcand " + who + ": cannot resolve host: " + ::gai_strerror(gai));
    return nullptr;
  }
  std::unique_ptr<addrinfo, decltype(&::freeaddrinfo)> guard(res, &::freeaddrinfo);

  UniqueFd sock;
  std::string last_error = "no address";
  for (addrinfo* ai = res; ai && !sock; ai = ai->ai_next) {
    UniqueFd fd(::socket(ai->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    if (!fd) {
      last_error = errno_text(errno);
      continue;
    }
    if (::connect(fd.get(), ai->ai_addr, ai->ai_addrlen) < 0) {
      if (errno != EINPROGRESS) {
        last_error = errno_text(errno);
        continue;
      }
      pollfd p{fd.get(), POLLOUT, 0};
      int r;
      do {
        r = ::poll(&p, 1, remaining_ms(deadline));
      } while (r < 0 && errno == EINTR);
      if (r <= 0) {
        last_error = "timed out after " + std::to_string(timeout_ms) + " ms";
        continue;
      }
      int soerr = 0;
      socklen_t len = sizeof soerr;
      ::getsockopt(fd.get(), SOL_SOCKET, SO_ERROR, &soerr, &len);
      if (soerr != 0) {
        last_error = errno_text(soerr);
        continue;
      }
    }
    sock = std::move(fd);
  }
  if (!sock) {
    set_error(error, "cannot connect to socketcand at " + who + ": " + last_error);
    return nullptr;
  }
  const int on = 1;
  ::setsockopt(sock.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);

  // doc/protocol.md: `< hi >`, then `< open BUS >` → `< ok >` (BCM mode), `< rawmode >` → `< ok >`.
  Handshake hs(sock.get(), deadline, who);
  std::string e;
  if (!hs.next(&e, error)) return nullptr;
  if (const auto w = socketcand::words(e); !(w.size() == 1 && w[0] == "hi")) {
    set_error(error, "socketcand " + who + ": expected the greeting '< hi >', got '" +
                         printable(e) + "' (not a socketcand server?)");
    return nullptr;
  }
  if (!hs.send("< open " + channel + " >", error) || !hs.expect_ok("bus " + channel, error) ||
      !hs.send("< rawmode >", error) || !hs.expect_ok("rawmode", error))
    return nullptr;

  UniqueFd ep(::epoll_create1(EPOLL_CLOEXEC));
  epoll_event ev{};
  ev.events = EPOLLIN;
  if (!ep || ::epoll_ctl(ep.get(), EPOLL_CTL_ADD, sock.get(), &ev) < 0) {
    set_error(error, "socketcand " + who + ": epoll setup failed: " + errno_text(errno));
    return nullptr;
  }
  Logger(log, "socketcand " + who).info("connected, bus " + channel + " in raw mode");
  return std::make_unique<SocketcandChannel>(std::move(sock), std::move(ep), who + "/" + channel,
                                             log, std::move(hs.splitter()),
                                             std::move(hs.elements()), host, port, channel);
}

}  // namespace candp2::can

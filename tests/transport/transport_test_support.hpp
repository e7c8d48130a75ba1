// Shared helpers for the transport tests: a socketcand server exporting a VirtualBus and served by
// the event loop, a raw TCP client that checks exact bytes, and bounded waits on the loop.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "can/frame.hpp"
#include "can/socketcand.hpp"
#include "can/virtual_bus.hpp"
#include "common/log.hpp"
#include "event_loop/event_loop.hpp"

namespace candp2::test {

using namespace std::chrono_literals;

// Upper bound for every wait on something that should happen at once on a loopback socket.
inline constexpr Duration kWait = std::chrono::seconds(10);

inline can::Frame F(const char* candump) {
  auto r = can::parse_candump(candump);
  if (!r) throw std::runtime_error(std::string("bad test frame ") + candump);
  return *r.frame;
}

// Waits on the loop for the next frame of `ch` (nullopt after the timeout).
inline std::optional<can::Frame> receive_within(EventLoop& loop, can::Channel& ch,
                                                Duration timeout = kWait) {
  std::optional<can::Frame> f;
  loop.run_until([&] { return (f = ch.receive()).has_value(); }, timeout);
  return f;
}

// Runs connect_socketcand() on a helper thread while this thread's loop keeps serving the server
// (the handshake needs both sides). The helper touches nothing but its own objects and `log`; an
// eventfd wakes the loop when it is done, and join() orders everything it wrote before our reads.
inline std::unique_ptr<can::Channel> connect_served(EventLoop& loop, std::uint16_t port,
                                                    const std::string& bus, std::string* error,
                                                    LogSink* log = nullptr, int timeout_ms = 5000) {
  const int efd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  std::atomic<bool> done{false};
  bool woke = false;
  loop.add_fd(efd, EventLoop::kReadable, [&](std::uint32_t) {
    std::uint64_t v;
    [[maybe_unused]] auto n = ::read(efd, &v, sizeof v);
    woke = true;
  });
  std::unique_ptr<can::Channel> ch;
  std::thread helper([&] {
    ch = can::connect_socketcand("127.0.0.1", port, bus, error, timeout_ms, log);
    done = true;
    const std::uint64_t one = 1;
    [[maybe_unused]] auto n = ::write(efd, &one, sizeof one);
  });
  loop.run_until([&] { return woke || done.load(); },
                 std::chrono::milliseconds(timeout_ms) + std::chrono::seconds(5));
  helper.join();
  loop.remove_fd(efd);
  ::close(efd);
  return ch;
}

// A socketcand server on 127.0.0.1 (free port) exporting a VirtualBus. `peer` is another node on
// that bus. The loop serves the server and, after every event, publishes what the server's endpoint
// received, stamped with the fixed `wall` clock so that tests can compare exact bytes (or with the
// real wall clock, as the daemon does).
struct ServerRig {
  static can::SocketcandServer::Options default_options() {
    can::SocketcandServer::Options o;
    o.host = "127.0.0.1";
    o.port = 0;
    o.channel = "vcan0";
    return o;
  }

  // live_clock: stamp with the real wall clock (EventLoop::wall_now()) instead of `wall`.
  explicit ServerRig(can::SocketcandServer::Options options = default_options(),
                     bool live_clock = false)
      : live_clock_(live_clock) {
    endpoint = bus.endpoint("socketcand");
    peer = bus.endpoint("peer");
    std::string error;
    server = can::SocketcandServer::listen(options, *endpoint, &log, &error);
    if (!server) throw std::runtime_error("listen failed: " + error);
    for (const int fd : server->poll_fds())
      loop.add_fd(fd, EventLoop::kReadable,
                  [this, fd](std::uint32_t) { server->on_readable(fd, stamp()); });
    loop.add_deferred([this] {
      bool any = false;
      while (auto f = endpoint->receive()) {
        server->publish(*f, stamp());
        any = true;
      }
      return any;
    });
  }

  // A connected client channel; its descriptor is watched so that waits wake up on its data.
  std::unique_ptr<can::Channel> connect_client(std::string* error = nullptr) {
    std::string e;
    auto ch = connect_served(loop, server->port(), "vcan0", &e, &client_log);
    if (error) *error = e;
    if (ch) loop.add_fd(ch->poll_fd(), EventLoop::kReadable, [](std::uint32_t) {});
    return ch;
  }

  EventLoop loop;
  MemoryLog log;         // the server's log (written on this thread only)
  MemoryLog client_log;  // clients' log
  can::VirtualBus bus;
  std::unique_ptr<can::VirtualEndpoint> endpoint;
  std::unique_ptr<can::VirtualEndpoint> peer;
  std::unique_ptr<can::SocketcandServer> server;
  Time wall = std::chrono::seconds(1700000000);

 private:
  Time stamp() const { return live_clock_ ? EventLoop::wall_now() : wall; }
  bool live_clock_;
};

// A plain TCP client for byte-exact protocol checks. Reads happen in the loop (unless `reading`
// is false: a client that never reads, to provoke the server's output limit).
class RawClient {
 public:
  RawClient(EventLoop& loop, std::uint16_t port, bool reading = true, int rcvbuf = 0)
      : loop_(loop) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (rcvbuf > 0) ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    // Completes from the listen backlog; the server accepts later, in the loop.
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0)
      throw std::runtime_error(std::string("connect: ") + std::strerror(errno));
    ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) | O_NONBLOCK);
    if (reading) {
      loop_.add_fd(fd_, EventLoop::kReadable, [this](std::uint32_t) { pull(); });
      watched_ = true;
    }
  }
  ~RawClient() {
    if (watched_) loop_.remove_fd(fd_);
    ::close(fd_);
  }
  RawClient(const RawClient&) = delete;
  RawClient& operator=(const RawClient&) = delete;

  void send(std::string_view text) {
    while (!text.empty()) {
      const ssize_t n = ::send(fd_, text.data(), text.size(), MSG_NOSIGNAL);
      if (n <= 0) throw std::runtime_error(std::string("send: ") + std::strerror(errno));
      text.remove_prefix(static_cast<std::size_t>(n));
    }
  }

  // Waits for `n` bytes and returns them (fewer if the connection closed or the wait timed out).
  std::string take(std::size_t n, Duration timeout = kWait) {
    loop_.run_until([&] { return buffer_.size() >= n || closed_; }, timeout);
    const std::string out = buffer_.substr(0, n);
    buffer_.erase(0, out.size());
    return out;
  }
  // take(expected.size()): for EXPECT_EQ(c.take_like("< ok >"), "< ok >").
  std::string take_like(std::string_view expected) { return take(expected.size()); }

  // Waits until the server closed the connection.
  bool wait_closed(Duration timeout = kWait) {
    return loop_.run_until([&] { return closed_; }, timeout);
  }
  bool closed() const { return closed_; }
  const std::string& buffer() const { return buffer_; }
  void clear() { buffer_.clear(); }
  int fd() const { return fd_; }

 private:
  void pull() {
    char buf[65536];
    for (;;) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        buffer_.append(buf, static_cast<std::size_t>(n));
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      if (n < 0 && errno == EINTR) continue;
      closed_ = true;  // EOF or reset
      loop_.remove_fd(fd_);
      watched_ = false;
      return;
    }
  }

  EventLoop& loop_;
  int fd_ = -1;
  bool watched_ = false;
  bool closed_ = false;
  std::string buffer_;
};

}  // namespace candp2::test
